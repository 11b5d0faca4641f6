//! `a + b` (and `a − b` as `a + (−b)`).

use super::{
    DEFAULT_NAN, INFINITY, QUIET, SIGN, exponent, round_and_pack, round_onto, shift_right_sticky,
    unpack_finite,
};

/// Bits below the significand kept for rounding.
const GUARD: u32 = 7;

/// The bits of `a + b` for the bits of two `f32`s.
///
/// Normal operands inline, anything else the careful way. The smaller
/// significand is aligned with a sticky bit below the guard bits; adding,
/// the sum may carry one bit up; subtracting, it loses at most one leading
/// bit unless the exponents differ by at most one, and then nothing was
/// shifted out and the difference is exact.
#[inline(always)]
pub fn add(a: u32, b: u32) -> u32 {
    let (big, small) = if a & !SIGN >= b & !SIGN {
        (a, b)
    } else {
        (b, a)
    };
    let (e, e_small) = (exponent(big), exponent(small));
    // Ordered by magnitude, so both are normal unless one of these holds.
    if e_small == 0 || e == 255 {
        return careful(a, b);
    }
    let subtract = (a ^ b) & SIGN != 0;
    // Sign and exponent field minus one of a sum in [1, 2) times 2^e.
    let head = (big & SIGN) + ((e - 1) << 23);
    let m_big = aligned(big);
    let m_small = shift_right_sticky(aligned(small), e - e_small);
    if !subtract {
        let m = m_big + m_small;
        if m < 1 << (24 + GUARD) {
            return round_onto(head, m, GUARD);
        }
        if e == 254 {
            return (head & SIGN) | INFINITY;
        }
        return round_onto(head + (1 << 23), (m >> 1) | (m & 1), GUARD);
    }
    let m = m_big - m_small;
    if m >= 1 << (23 + GUARD) {
        return round_onto(head, m, GUARD);
    }
    if m == 0 {
        // x − x is +0 when rounding to nearest.
        return 0;
    }
    let (m, shift) = normalise(m);
    if shift < e {
        return round_onto(head - (shift << 23), m, GUARD);
    }
    round_and_pack(head & SIGN, e as i32 - shift as i32, m, GUARD)
}

/// `m` (not zero, below `2^(24 + GUARD)`) shifted left until its leading bit
/// is at bit `23 + GUARD`, and the shift: a binary search, as the core has no
/// count-leading-zeros instruction.
#[inline(always)]
fn normalise(m: u32) -> (u32, u32) {
    let step = |(m, shift): (u32, u32), by: u32| {
        if m < 1 << (24 + GUARD - by) {
            (m << by, shift + by)
        } else {
            (m, shift)
        }
    };
    // Unrolled by hand: the firmware is built for size, which keeps loops.
    step(step(step(step(step((m, 0), 16), 8), 4), 2), 1)
}

/// The significand of a normal `f32` with its leading bit at bit `23 + GUARD`.
#[inline(always)]
fn aligned(bits: u32) -> u32 {
    ((bits << 9) >> (9 - GUARD)) | (1 << (23 + GUARD))
}

/// Sums with zeros, subnormals, infinities or NaN.
#[cold]
#[inline(never)]
fn careful(a: u32, b: u32) -> u32 {
    let (abs_a, abs_b) = (a & !SIGN, b & !SIGN);
    if abs_a > INFINITY {
        return a | QUIET;
    }
    if abs_b > INFINITY {
        return b | QUIET;
    }
    if abs_a == INFINITY {
        return if abs_b == INFINITY && a != b {
            DEFAULT_NAN
        } else {
            a
        };
    }
    if abs_b == INFINITY {
        return b;
    }
    if abs_b == 0 {
        // x + 0 is x, and −0 + −0 is −0 while +0 + −0 is +0.
        return if abs_a == 0 { a & b } else { a };
    }
    if abs_a == 0 {
        return b;
    }
    let (big, small) = if abs_a >= abs_b { (a, b) } else { (b, a) };
    let ((e, m_big), (e_small, m_small)) = (unpack_finite(big), unpack_finite(small));
    let sign = big & SIGN;
    let m_big = m_big << GUARD;
    let m_small = shift_right_sticky(m_small << GUARD, (e - e_small) as u32);
    if (big ^ small) & SIGN == 0 {
        let m = m_big + m_small;
        if m >= 1 << (24 + GUARD) {
            return round_and_pack(sign, e + 1, (m >> 1) | (m & 1), GUARD);
        }
        return round_and_pack(sign, e, m, GUARD);
    }
    let m = m_big - m_small;
    if m == 0 {
        // x − x is +0 when rounding to nearest.
        return 0;
    }
    let (m, shift) = normalise(m);
    round_and_pack(sign, e - shift as i32, m, GUARD)
}
