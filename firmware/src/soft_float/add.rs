//! `a + b` (and `a − b` as `a + (−b)`).

use super::{
    DEFAULT_NAN, INFINITY, QUIET, SIGN, round_and_pack, shift_right_sticky, unpack_finite,
};

/// Bits below the significand kept for rounding.
const GUARD: u32 = 7;

/// `m` (not zero, below `2^(24 + GUARD)`) shifted left until its leading bit
/// is at bit `23 + GUARD`, and the shift.
fn normalise(m: u32) -> (u32, u32) {
    let shift = m.leading_zeros() - (8 - GUARD);
    (m << shift, shift)
}

/// The bits of `a + b` for the bits of two `f32`s, every case.
///
/// The smaller significand is aligned with a sticky bit below the guard
/// bits; adding, the sum may carry one bit up; subtracting, it may lose
/// leading bits. On the MCU, `fadd.s` takes the common case (normal
/// operands, results far from the ends of the range) and hands everything
/// else to this.
pub fn add(a: u32, b: u32) -> u32 {
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
