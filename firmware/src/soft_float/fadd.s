@ __aeabi_fadd and __aeabi_fsub, a + b and a − b in binary32 (round to
@ nearest, ties to even), for the RP2040's Cortex-M0+ (ARMv6-M Thumb).
@
@ The common case only: normal operands, the larger of exponent field 32 to
@ 253, so that neither a carry out of the sum nor a cancelling difference can
@ leave the normal range; and a zero with a finite operand (x ± 0 is x, and
@ ±0 ± 0 is −0 only when both are −0), which the model's matrices and the
@ servo curves' knot at 0 rad give a hundred times a servo frame. Anything
@ else (subnormal, infinite or NaN operands, results near the ends of the
@ range) goes on in Rust, `soft_float_add` (add.rs), with the operands
@ untouched but ordered by magnitude (which changes only which NaN comes
@ back). The emulator test `tests/tests/emulator_soft_float.rs` checks the
@ two together bit for bit against the host's FPU.
@
@ The significands get 7 guard bits below them (leading bit at 30), the
@ smaller one's shifted-out bits leave a sticky bit, and a difference is a
@ sum with the smaller one negated: a sum lies in [2^30, 2^32), a difference
@ in [0, 2^31). A difference loses at most one leading bit unless the
@ exponents differ by at most one, and then it is exact.

    .syntax unified
    .section .text.__aeabi_fadd,"ax",%progbits
    .global __aeabi_fsub
    .type __aeabi_fsub,%function
    .global __aeabi_fadd
    .type __aeabi_fadd,%function
    .p2align 2
    .thumb_func
__aeabi_fsub:
    movs r2, #1
    lsls r2, r2, #31
    eors r1, r2                 @ a − b = a + (−b)
    .thumb_func
__aeabi_fadd:
    @ Order by magnitude: r0 the larger.
    lsls r2, r0, #1
    lsls r3, r1, #1
    cmp r2, r3
    bhs 1f
    movs r2, r0
    movs r0, r1
    movs r1, r2
    lsls r2, r0, #1
    lsls r3, r1, #1
1:  lsrs r2, r2, #24            @ e: exponent field of the larger
    lsrs r3, r3, #24
    beq .Lfadd_small            @ the smaller is zero or subnormal
    subs r3, r2, r3             @ d: the exponents' difference
    subs r2, #32
    cmp r2, #221
    bhi .Lfadd_careful          @ e below 32 or above 253
    cmp r3, #25
    bhi .Lfadd_larger           @ the smaller is below a quarter ulp of the larger
    push {r4, r5, r6}
    lsrs r4, r0, #23
    subs r4, #1
    lsls r4, r4, #23            @ r4: the sign and exponent field − 1 of the larger
    movs r6, r0
    eors r6, r1
    asrs r6, r6, #31            @ r6: −1 if the signs differ, else 0
    movs r5, #1
    lsls r5, r5, #30            @ r5: the implicit bit at 30
    lsls r0, r0, #9
    lsrs r0, r0, #2
    orrs r0, r5                 @ the larger significand
    lsls r1, r1, #9
    lsrs r1, r1, #2
    orrs r1, r5                 @ the smaller significand ...
    movs r2, r1
    lsrs r1, r1, r3             @ ... shifted right by d ...
    negs r3, r3
    adds r3, #32
    lsls r2, r2, r3             @ (the bits shifted out, at the top)
    beq 2f
    movs r2, #1
    orrs r1, r2                 @ ... with a sticky bit if any was lost
2:  eors r1, r6
    subs r1, r1, r6             @ negated if the signs differ
    adds r0, r0, r1
    bmi .Lfadd_carry            @ a sum in [2, 4)
    beq .Lfadd_zero             @ x − x
    cmp r0, r5
    blo .Lfadd_normalise        @ a difference lost its leading bit
.Lfadd_round7:
    @ Leading bit at 30: the significand is r0 >> 7, the round bit 6.
    lsrs r1, r0, #7
    adds r1, r1, r4
    lsls r0, r0, #26            @ C: the round bit; Z: nothing below it
.Lfadd_rounding:
    bcc .Lfadd_out
    beq .Lfadd_tie
    adds r1, #1                 @ above half an ulp: up (carrying into the exponent)
.Lfadd_out:
    movs r0, r1
    pop {r4, r5, r6}
    bx lr
.Lfadd_tie:
    adds r1, #1                 @ exactly half: to even
    lsrs r1, r1, #1
    lsls r1, r1, #1
    b .Lfadd_out
.Lfadd_carry:
    @ Leading bit at 31: one more in the exponent (e ≤ 253, so no overflow before
    @ rounding), the significand r0 >> 8, the round bit 7.
    lsrs r1, r0, #8
    adds r1, r1, r4
    lsrs r2, r5, #7
    adds r1, r1, r2
    lsls r0, r0, #25
    b .Lfadd_rounding
.Lfadd_normalise:
    @ One step per lost bit (at most 24; e ≥ 32 keeps the result normal).
    movs r3, #0
3:  adds r3, #1
    lsls r0, r0, #1
    cmp r0, r5
    blo 3b
    lsls r3, r3, #23
    subs r4, r4, r3
    b .Lfadd_round7
.Lfadd_zero:
    pop {r4, r5, r6}            @ +0 when rounding to nearest
    bx lr
.Lfadd_larger:
    bx lr
.Lfadd_small:
    lsls r3, r1, #1
    bne .Lfadd_careful          @ the smaller is subnormal
    cmp r2, #255
    beq .Lfadd_careful          @ the larger is infinite or NaN
    lsls r3, r0, #1
    bne .Lfadd_larger           @ x ± 0 = x, the larger (normal or subnormal)
    ands r0, r1                 @ ±0 ± 0: −0 only if both are
    bx lr
.Lfadd_careful:
    ldr r2, =soft_float_add
    bx r2
    .ltorg
    .size __aeabi_fadd, . - __aeabi_fadd
    .size __aeabi_fsub, . - __aeabi_fsub
