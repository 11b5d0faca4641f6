//! Single-precision addition and multiplication for the RP2040's core.
//!
//! The Cortex-M0+ has no FPU, so every `f32` operation of the compensation
//! is a call: about 1,100 per moving servo frame. compiler-builtins' generic
//! routines cost about 120 cycles per addition and 145 per multiplication
//! there (measured in the emulator), 80 % of the frame. These do the same
//! IEEE-754 operations (binary32, round to nearest, ties to even,
//! subnormals, infinities, NaN) with results bit-identical to an FPU's, so
//! the model computes exactly what it computed before, only sooner.
//!
//! The common case (normal operands, a result far from the ends of the
//! range) is Thumb assembly: 51 to 70 cycles per call. The same in Rust
//! took 94 to 128: the compiler spills to the stack, short of low registers
//! with `r7` kept as the frame pointer. Adding or subtracting a zero, which
//! the model's matrices and the servo curves' knots at 0 rad do about 120
//! times a moving servo frame, takes the assembly 18 to 23 cycles (it went
//! on to Rust, 60). Everything else is Rust, which the assembly hands the
//! operands to.
//!
//! | file | what it holds |
//! |---|---|
//! | `fadd.s`, `fmul.s` | `__aeabi_fadd`, `__aeabi_fsub` and `__aeabi_fmul`, their common case |
//! | `add.rs`, `mul.rs` | `a + b` and `a × b`, every case: the rest on the MCU, the reference on the host |
//! | `cases.rs` | operand pairs of every class, shared with the emulator test |
//! | `tests.rs` | the Rust routines against the host's FPU |
//!
//! On the MCU they replace the compiler's routines of the same names (the
//! Pico SDK replaces them too, with the chip's boot-ROM routines; the
//! emulated board has no copy of that ROM, so the cycles could not be
//! measured with those). The assembly cannot run on the host:
//! `tests/tests/emulator_soft_float.rs` calls the exported routines of the
//! real binary in the emulator on the same pairs and compares them with the
//! host's FPU.

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

/// The exponent and significand of a finite, non-zero `f32` with the
/// significand's leading bit at bit 23 (subnormals normalised: their
/// exponent drops below 1).
fn unpack_finite(bits: u32) -> (i32, u32) {
    let e = (bits >> 23) & 0xff;
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
///
/// The significand is added to the sign and the exponent field minus one:
/// its implicit bit adds the one back (a subnormal has none, and its field
/// is 0), and rounding up into the next binade, or to infinity, carries
/// into the exponent by itself. It rounds up when the bits rounded away
/// exceed half an ulp, or equal it and the significand is odd:
/// `rest + lsb + half − 1` reaches `2 half` exactly then.
fn round_and_pack(sign: u32, e: i32, m: u32, guard: u32) -> u32 {
    if e >= 255 {
        return sign | INFINITY;
    }
    let (head, m) = if e >= 1 {
        (sign | ((e as u32 - 1) << 23), m)
    } else {
        (sign, shift_right_sticky(m, (1 - e) as u32))
    };
    let significand = m >> guard;
    let rest = m & ((1 << guard) - 1);
    let up = (rest + (significand & 1) + (1 << (guard - 1)) - 1) >> guard;
    head + significand + up
}

/// `m >> shift`, with the lowest bit set if any bit shifted out was.
fn shift_right_sticky(m: u32, shift: u32) -> u32 {
    if shift >= 32 {
        return u32::from(m != 0);
    }
    (m >> shift) | u32::from(m & ((1 << shift) - 1) != 0)
}

/// The compiler's single-precision routines, replaced on the MCU: their
/// common cases in Thumb assembly, the rest in Rust.
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
mod exports {
    core::arch::global_asm!(include_str!("fadd.s"), options(raw));
    core::arch::global_asm!(include_str!("fmul.s"), options(raw));

    /// `a + b` for what `fadd.s` leaves.
    #[unsafe(no_mangle)]
    pub extern "aapcs" fn soft_float_add(a: u32, b: u32) -> u32 {
        super::add(a, b)
    }

    /// `a × b` for what `fmul.s` leaves.
    #[unsafe(no_mangle)]
    pub extern "aapcs" fn soft_float_mul(a: u32, b: u32) -> u32 {
        super::mul(a, b)
    }
}

#[cfg(test)]
mod cases;
#[cfg(test)]
mod tests;
