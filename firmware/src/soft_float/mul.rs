//! `a × b`.

use super::{
    DEFAULT_NAN, FRACTION, IMPLICIT, INFINITY, QUIET, SIGN, exponent, round_and_pack, round_onto,
    unpack_finite,
};

/// Bits below the significand that the product keeps for rounding.
const GUARD: u32 = 8;

/// The bits of `a × b` for the bits of two `f32`s.
///
/// The common case inline: normal operands whose product is normal (their
/// exponents' sum alone decides it, up to a rounding into infinity, which
/// the packing carries). Anything else goes the careful way.
#[inline(always)]
pub fn mul(a: u32, b: u32) -> u32 {
    let (ea, eb) = (exponent(a), exponent(b));
    let sum = ea + eb;
    // Both operands normal: an exponent field plus one with bit 0 cleared is
    // zero only for the fields 0 and 255, and the product of the two is zero
    // if either is. The product normal: its exponent field, `sum − 127` or
    // `sum − 126`, is in 1..=254 for `sum` in 128..=380. One comparison for
    // both (branches cost more than arithmetic here): `normal − 1` has its
    // top bit set only when `normal` is zero.
    let normal = ((ea + 1) & 0xfe) * ((eb + 1) & 0xfe);
    if (sum.wrapping_sub(128) | (normal.wrapping_sub(1) & SIGN)) > 252 {
        return careful(a, b);
    }
    // Sign and exponent field minus one of a product in [1, 2).
    let head = ((a ^ b) & SIGN) + ((sum - 128) << 23);
    let (m, doubled) = significand_product(significand(a), significand(b));
    round_onto(head + (u32::from(doubled) << 23), m, GUARD)
}

/// The significand of a normal `f32`, leading bit at bit 23.
#[inline(always)]
fn significand(bits: u32) -> u32 {
    (bits & FRACTION) | IMPLICIT
}

/// The product of two significands with their leading bit at bit 23, as its
/// top 32 bits with the leading bit at bit 31 and a sticky bit, and whether
/// it lies in [2, 4) rather than [1, 2).
///
/// The 48-bit product comes from 16-bit halves (`a = ah 2¹⁶ + al`, `ah` of 8
/// bits): its top 32 bits are `ah bh 2¹⁶ + ah bl + al bh + (al bl >> 16)`,
/// which cannot overflow; the low 16 bits of `al bl` only decide the sticky bit.
#[inline(always)]
fn significand_product(a: u32, b: u32) -> (u32, bool) {
    let (ah, al) = (a >> 16, a & 0xffff);
    let (bh, bl) = (b >> 16, b & 0xffff);
    let low = al * bl;
    let top = ((ah * bh) << 16) + ah * bl + al * bh + (low >> 16);
    let sticky = u32::from(low & 0xffff != 0);
    if top >= 1 << 31 {
        (top | sticky, true)
    } else {
        ((top << 1) | ((low >> 15) & 1) | sticky, false)
    }
}

/// Products of zeros, subnormals, infinities and NaN, and products that
/// overflow or are subnormal.
#[cold]
#[inline(never)]
fn careful(a: u32, b: u32) -> u32 {
    let sign = (a ^ b) & SIGN;
    let (abs_a, abs_b) = (a & !SIGN, b & !SIGN);
    if abs_a > INFINITY {
        return a | QUIET;
    }
    if abs_b > INFINITY {
        return b | QUIET;
    }
    if abs_a == INFINITY || abs_b == INFINITY {
        return if abs_a == 0 || abs_b == 0 {
            DEFAULT_NAN
        } else {
            sign | INFINITY
        };
    }
    if abs_a == 0 || abs_b == 0 {
        return sign;
    }
    let ((ea, ma), (eb, mb)) = (unpack_finite(a), unpack_finite(b));
    let (m, doubled) = significand_product(ma, mb);
    round_and_pack(sign, ea + eb - 127 + i32::from(doubled), m, GUARD)
}
