//! `a × b`.

use super::{DEFAULT_NAN, INFINITY, QUIET, SIGN, round_and_pack, unpack_finite};

/// Bits below the significand that the product keeps for rounding.
const GUARD: u32 = 8;

/// The product of two significands with their leading bit at bit 23, as its
/// top 32 bits with the leading bit at bit 31 and a sticky bit, and whether
/// it lies in [2, 4) rather than [1, 2).
///
/// The 48-bit product comes from 16-bit halves (`a = ah 2¹⁶ + al`, `ah` of 8
/// bits): its top 32 bits are `ah bh 2¹⁶ + ah bl + al bh + (al bl >> 16)`,
/// which cannot overflow; the low 16 bits of `al bl` only decide the sticky bit.
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

/// The bits of `a × b` for the bits of two `f32`s, every case.
///
/// On the MCU, `fmul.s` takes normal operands with a normal product and
/// hands everything else to this.
pub fn mul(a: u32, b: u32) -> u32 {
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
