@ __aeabi_fmul, a × b in binary32 (round to nearest, ties to even), for the
@ RP2040's Cortex-M0+ (ARMv6-M Thumb: no FPU, a one-cycle 32 × 32 → 32 bit
@ multiplier).
@
@ The common case only: normal operands with a normal product. Their product
@ comes from 16-bit halves of the significands, rounding needs no loop, and
@ nothing spills. Anything else (zero, subnormal, infinite or NaN operands,
@ a product that overflows or is subnormal) goes on in Rust, `soft_float_mul`
@ (mul.rs), with the operands untouched. The emulator test
@ `tests/tests/emulator_soft_float.rs` checks the two together bit for bit
@ against the host's FPU.

    .syntax unified
    .section .text.__aeabi_fmul,"ax",%progbits
    .global __aeabi_fmul
    .type __aeabi_fmul,%function
    .p2align 2
    .thumb_func
__aeabi_fmul:
    @ r0 = a, r1 = b. Both exponent fields in 1..=254, their sum − 128 in 0..=252:
    @ the product's field, sum − 127 or sum − 126, is then in 1..=254 (rounding
    @ up into 255 gives infinity, the right result, by itself).
    lsls r2, r0, #1
    lsrs r2, r2, #24
    subs r2, #1
    cmp r2, #253
    bhi .Lfmul_careful
    lsls r3, r1, #1
    lsrs r3, r3, #24
    subs r3, #1
    cmp r3, #253
    bhi .Lfmul_careful
    adds r2, r2, r3
    subs r2, #126
    cmp r2, #252
    bhi .Lfmul_careful
    push {r4, r5}
    @ r5: the sign and the exponent field minus one of a product in [1, 2).
    lsls r5, r2, #23
    movs r3, r0
    eors r3, r1
    lsrs r3, r3, #31
    lsls r3, r3, #31
    adds r5, r5, r3
    @ Significands of 24 bits as ah 2^16 + al, ah of 8 bits (implicit bit at 7).
    uxth r2, r0
    lsls r0, r0, #9
    lsrs r0, r0, #25
    adds r0, #128
    uxth r3, r1
    lsls r1, r1, #9
    lsrs r1, r1, #25
    adds r1, #128
    @ The top 32 bits of the 48-bit product: ah bh 2^16 + ah bl + al bh + (al bl >> 16),
    @ below 2^32 and at least 2^30.
    movs r4, r2
    muls r4, r3, r4
    muls r2, r1, r2
    muls r3, r0, r3
    muls r0, r1, r0
    lsls r0, r0, #16
    adds r0, r0, r2
    adds r0, r0, r3
    lsrs r1, r4, #16
    adds r0, r0, r1
    bmi 1f
    @ In [1, 2): shift in bit 15 of al bl; r4 keeps the bits below it (sticky).
    lsls r4, r4, #17
    adcs r0, r0, r0
    b 2f
1:  @ In [2, 4): r4 keeps the low 16 bits of al bl; one more in the exponent.
    lsls r4, r4, #16
    movs r1, #1
    lsls r1, r1, #23
    adds r5, r5, r1
2:  @ r0 has the leading bit at 31: the significand is r0 >> 8, the round bit 7.
    lsrs r1, r0, #8
    adds r1, r1, r5
    lsls r0, r0, #25
    bcc 3f
    @ Half an ulp or more: up, carrying into the exponent (and to infinity) by
    @ itself; exactly half (nothing below the round bit): to even.
    adds r1, #1
    orrs r0, r4
    bne 3f
    lsrs r1, r1, #1
    lsls r1, r1, #1
3:  movs r0, r1
    pop {r4, r5}
    bx lr
.Lfmul_careful:
    ldr r2, =soft_float_mul
    bx r2
    .ltorg
    .size __aeabi_fmul, . - __aeabi_fmul
