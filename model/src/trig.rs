//! Sine and cosine of the joint angles: the one transcendental function on
//! the model's hot path, and on the MCU its most expensive step.
//!
//! The RP2040 has no FPU: libm's `sinf`/`cosf` evaluate their kernels in f64
//! soft-float (about 8,700 cycles per call in the emulator), and even an f32
//! polynomial costs some 3,400 cycles in soft-float operations. Its core has a
//! one-cycle 32-bit integer multiplier, though, so the f32 kernel here works
//! in fixed point:
//!
//! 1. the angle becomes a phase, `x / 2π` turns in units of 2⁻³² turn, by one
//!    integer product of its mantissa with `2⁴⁰ / 2π` (exact reduction: no
//!    rounded multiple of `π/2` is subtracted);
//! 2. the phase's top bits give the quadrant, the rest `w ∈ [-1, 1)` eighths
//!    of a turn;
//! 3. the Taylor polynomials of `sin(πw/4)` (to `w¹¹`) and `cos(πw/4)` (to
//!    `w¹⁰`) run in Q30 (truncation below 2e-10, rounding about 1e-9);
//! 4. two integer-to-float conversions, their exponents lowered by 30, give the results.
//!
//! The result is within 1.5e-7 of the exact value for any angle up to
//! [`REDUCTION_LIMIT`] (see the tests); beyond it, or for a non-finite angle,
//! libm answers (through nalgebra).

/// Largest angle the fixed-point kernel takes, rad.
pub const REDUCTION_LIMIT: f32 = 4096.0;

/// `2⁴⁰ / 2π`, rounded: turns per radian in units of 2⁻⁴⁰ turn.
const TURNS_PER_RAD_2_40: u64 = 174_992_710_548;

/// `sin(πw/4) = w (S0 + w² (S1 + … + w² S5))`, coefficients in Q30.
const SIN_Q30: [i32; 6] = [843_314_857, -86_699_834, 2_674_041, -39_273, 336, -2];
/// `cos(πw/4) = C0 + w² (C1 + … + w² C5)`, coefficients in Q30.
const COS_Q30: [i32; 6] = [
    1_073_741_824,
    -331_168_970,
    17_023_473,
    -350_031,
    3_856,
    -26,
];

/// `(sin x, cos x)` of an f32 angle, computed in fixed point.
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    let bits = x.to_bits();
    // Finite floats of one sign order like their bits; NaN's bits exceed every finite magnitude.
    let magnitude = bits & 0x7fff_ffff;
    if magnitude > REDUCTION_LIMIT.to_bits() {
        return nalgebra::ComplexField::sin_cos(x);
    }
    // Below 2⁻¹², sin x = x and cos x = 1 to f32 precision.
    if magnitude < 0x3980_0000 {
        return (x, 1.0);
    }
    let phase = phase_of(magnitude);
    let phase = if bits >> 31 == 1 {
        phase.wrapping_neg()
    } else {
        phase
    };
    // Nearest quarter turn, and what is left of the phase in eighths of a turn (Q30).
    let quadrant = phase.wrapping_add(1 << 29) >> 30;
    let w = (phase.wrapping_sub(quadrant << 30) as i32) << 1;
    let w2 = mul_q30(w, w);
    let s = mul_q30(w, horner(&SIN_Q30, w2));
    let c = horner(&COS_Q30, w2);
    let (s, c) = match quadrant {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    (from_q30(s), from_q30(c))
}

/// The phase of a positive angle given by its f32 bits, in units of 2⁻³² turn (mod one turn).
fn phase_of(magnitude: u32) -> u32 {
    let exponent = (magnitude >> 23) as i32;
    let mantissa = u64::from((magnitude & 0x7f_ffff) | 0x80_0000);
    // angle = mantissa · 2^(exponent − 150); phase = angle · 2³² / 2π.
    let product = mantissa * TURNS_PER_RAD_2_40;
    let shift = 150 + 8 - exponent;
    // The angle is at most REDUCTION_LIMIT (exponent ≤ 139), so the shift is ≥ 19.
    if shift >= 64 {
        0
    } else {
        (product >> shift) as u32
    }
}

/// `a · b` of two Q30 numbers of magnitude at most 1, from 16-bit halves: the
/// core multiplies 32 × 32 bits into 32 in one cycle, but has no 64-bit product.
#[inline]
fn mul_q30(a: i32, b: i32) -> i32 {
    let (ah, al) = (a >> 16, a & 0xffff);
    let (bh, bl) = (b >> 16, b & 0xffff);
    let low = ((al as u32 * bl as u32) >> 30) as i32;
    ((ah * bh) << 2) + ((ah * bl) >> 14) + ((al * bh) >> 14) + low
}

/// `p[0] + x (p[1] + x (… + x p[n]))` in Q30.
#[inline]
fn horner(p: &[i32; 6], x: i32) -> i32 {
    p.iter().rev().fold(0, |acc, &c| c + mul_q30(x, acc))
}

/// A Q30 number as f32: the integer's conversion with its exponent lowered
/// by 30, exact and without a soft-float multiplication (a non-zero integer
/// converts to at least 1.0, so the result stays normal).
#[inline]
fn from_q30(v: i32) -> f32 {
    if v == 0 {
        return 0.0;
    }
    f32::from_bits((v as f32).to_bits() - (30 << 23))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn worst_error(xs: impl Iterator<Item = f32>) -> f64 {
        xs.map(|x| {
            let (s, c) = sin_cos_f32(x);
            let x = f64::from(x);
            (f64::from(s) - x.sin())
                .abs()
                .max((f64::from(c) - x.cos()).abs())
        })
        .fold(0.0, f64::max)
    }

    #[test]
    fn matches_f64_over_the_joint_range() {
        // Every 1e-4 rad over ±2π: all quadrants and their boundaries.
        let err = worst_error((-62_832..=62_832).map(|i| i as f32 * 1e-4));
        assert!(err < 1.5e-7, "worst error {err:e}");
    }

    #[test]
    fn matches_f64_up_to_the_reduction_limit() {
        let sign = |i: i32| if i % 2 == 0 { 1.0 } else { -1.0 };
        let err = worst_error((0..=40_000).map(|i| i as f32 * 0.1024 * sign(i)));
        assert!(err < 1.5e-7, "worst error {err:e}");
        let far = worst_error([5e3f32, -1e4, 123_456.7].into_iter());
        assert!(far < 1e-6, "libm beyond the limit: {far:e}");
    }

    #[test]
    fn small_angles_are_exact_to_f32_precision() {
        for x in [3e-3f32, -1e-3, 2.4e-4, -3e-5, 1e-9, 0.0, -0.0] {
            let (s, c) = sin_cos_f32(x);
            let x64 = f64::from(x);
            assert!((f64::from(s) - x64.sin()).abs() <= 5e-9, "sin {x}");
            assert!((f64::from(c) - x64.cos()).abs() <= 6e-8, "cos {x}");
        }
    }

    #[test]
    fn exact_quarter_turns() {
        let (s, c) = sin_cos_f32(core::f32::consts::FRAC_PI_2);
        assert!((s - 1.0).abs() < 1e-7 && c.abs() < 1e-7);
        let (s, c) = sin_cos_f32(-core::f32::consts::PI);
        assert!(s.abs() < 1e-7 && (c + 1.0).abs() < 1e-7);
    }

    #[test]
    fn non_finite_angles_give_nan() {
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (s, c) = sin_cos_f32(x);
            assert!(s.is_nan() && c.is_nan(), "{x}");
        }
    }
}
