//! Single-precision addition and multiplication for the RP2040's core.
//!
//! The Cortex-M0+ has no FPU, so every `f32` operation of the compensation
//! is a call. compiler-builtins' generic routines cost about 120 cycles per
//! addition and 145 per multiplication there (measured in the emulator),
//! 80 % of a moving servo frame's compensation. These do the same IEEE-754
//! operations (binary32, round to nearest, ties to even, subnormals,
//! infinities, NaN) shaped for this core: the product from four 16-bit
//! partial products of its one-cycle 32-bit multiplier, the common case
//! (normal operands and result) first and everything else on cold paths. The results are bit-identical to an
//! FPU's (see the tests), so the model computes exactly what it computed
//! before, only sooner.
//!
//! On the MCU they replace the compiler's `__aeabi_fadd`, `__aeabi_fsub` and
//! `__aeabi_fmul` (the Pico SDK replaces them too, with the chip's boot-ROM
//! routines; the emulated board has no copy of that ROM, so the cycles could
//! not be measured with those). On the host they are plain functions for the tests.

mod add;
mod mul;

pub use add::add;
pub use mul::mul;

/// Sign bit of an `f32`.
const SIGN: u32 = 0x8000_0000;
/// Exponent field of an `f32`; also the bits of +infinity.
const INFINITY: u32 = 0x7f80_0000;
/// Fraction field of an `f32`.
const FRACTION: u32 = 0x007f_ffff;
/// The implicit leading bit of a normal `f32`'s significand.
const IMPLICIT: u32 = 0x0080_0000;
/// The bit that makes a NaN quiet.
const QUIET: u32 = 0x0040_0000;
/// The NaN returned for invalid operations (∞ − ∞, 0 × ∞).
const DEFAULT_NAN: u32 = 0x7fc0_0000;

/// The biased exponent field of `bits`.
#[inline(always)]
fn exponent(bits: u32) -> u32 {
    (bits >> 23) & 0xff
}

/// The exponent and significand of a finite, non-zero `f32` with the
/// significand's leading bit at bit 23 (subnormals normalised: their
/// exponent drops below 1).
fn unpack_finite(bits: u32) -> (i32, u32) {
    let e = exponent(bits);
    let fraction = bits & FRACTION;
    if e != 0 {
        return (e as i32, fraction | IMPLICIT);
    }
    let shift = fraction.leading_zeros() - 8;
    (1 - shift as i32, fraction << shift)
}

/// `sign` and the magnitude `m · 2^(e − 150 − guard)` packed into an `f32`,
/// rounded to nearest, ties to even. `m` has its leading bit at bit
/// `23 + guard`, so `e` is the biased exponent (below 1: the value is
/// subnormal or rounds to zero); its `guard` low bits are rounded away, the
/// lowest of them set if anything below them was lost (sticky).
#[inline(always)]
fn round_and_pack(sign: u32, e: i32, m: u32, guard: u32) -> u32 {
    if (e - 1) as u32 >= 254 {
        return round_and_pack_extreme(sign, e, m, guard);
    }
    sign | pack_normal(e as u32, m, guard)
}

/// [`round_and_pack`] of a normal `e` (1 to 254), without the sign.
#[inline(always)]
fn pack_normal(e: u32, m: u32, guard: u32) -> u32 {
    round_onto((e - 1) << 23, m, guard)
}

/// `head` plus the significand `m >> guard` rounded to nearest, ties to even.
///
/// `head` is the sign and the exponent field minus one: a significand with
/// its implicit bit adds one to the exponent field, and rounding up into the
/// next binade, or to infinity, carries into it by itself. Rounds up when
/// the bits rounded away exceed half an ulp, or equal it and the significand
/// is odd: `rest + lsb + half − 1` reaches `2 half` exactly then.
#[inline(always)]
fn round_onto(head: u32, m: u32, guard: u32) -> u32 {
    let significand = m >> guard;
    let rest = m & ((1 << guard) - 1);
    let up = (rest + (significand & 1) + (1 << (guard - 1)) - 1) >> guard;
    head + significand + up
}

/// [`round_and_pack`] of a result that overflows (`e` ≥ 255) or is
/// subnormal (`e` < 1).
#[cold]
#[inline(never)]
fn round_and_pack_extreme(sign: u32, e: i32, m: u32, guard: u32) -> u32 {
    if e >= 255 {
        return sign | INFINITY;
    }
    // Subnormal: the exponent field's value 1 without the implicit bit.
    sign | pack_normal(1, shift_right_sticky(m, (1 - e) as u32), guard)
}

/// `m >> shift`, with the lowest bit set if any bit shifted out was.
#[inline(always)]
fn shift_right_sticky(m: u32, shift: u32) -> u32 {
    if shift >= 32 {
        return u32::from(m != 0);
    }
    (m >> shift) | u32::from(m & ((1 << shift) - 1) != 0)
}

/// The compiler's single-precision routines, replaced on the MCU.
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
mod exports {
    /// `a + b`.
    #[unsafe(no_mangle)]
    pub extern "aapcs" fn __aeabi_fadd(a: f32, b: f32) -> f32 {
        f32::from_bits(super::add(a.to_bits(), b.to_bits()))
    }

    /// `a − b`.
    #[unsafe(no_mangle)]
    pub extern "aapcs" fn __aeabi_fsub(a: f32, b: f32) -> f32 {
        f32::from_bits(super::add(a.to_bits(), b.to_bits() ^ super::SIGN))
    }

    /// `a × b`.
    #[unsafe(no_mangle)]
    pub extern "aapcs" fn __aeabi_fmul(a: f32, b: f32) -> f32 {
        f32::from_bits(super::mul(a.to_bits(), b.to_bits()))
    }
}

#[cfg(test)]
mod tests;
