//! Float comparisons and rounding on the floats' bits, for the servo frame.
//!
//! The Cortex-M0+ has no FPU: every `f32` comparison is a call into
//! compiler-builtins (27 to 50 cycles), `f32::clamp` makes three of them,
//! `libm::roundf` and a conversion to an integer cost about 120 cycles.
//! Where the values are known not to be NaN (the servo frame's angles,
//! limits and pulses are finite), comparing the bits as integers gives the
//! same answers in a few instructions. Each function says what it needs
//! and is tested against the float operations it stands for.

/// A float that is not NaN as an integer in the same order: for `a` and `b`
/// not NaN, `a < b` exactly when `ordered(a) < ordered(b)`, and `a == b`
/// exactly when `ordered(a) == ordered(b)` (-0.0 and +0.0 are both 0).
///
/// The bits of a positive float, read as an integer, grow with its value;
/// a negative float is its magnitude's bits negated. A few instructions and
/// an integer comparison, where a float comparison is a call of 27 to 50
/// cycles on the Cortex-M0+.
#[inline]
pub fn ordered(x: f32) -> i32 {
    let bits = x.to_bits() as i32;
    let magnitude = bits & i32::MAX;
    if bits < 0 { -magnitude } else { magnitude }
}

/// `x.is_nan()` on the bits (`is_nan` compares `x` with itself: a call on the Cortex-M0+).
#[inline]
pub fn is_nan(x: f32) -> bool {
    x.to_bits() & 0x7fff_ffff > 0x7f80_0000
}

/// `x.clamp(lo, hi)` and whether it changed `x`, for `x`, `lo` and `hi` not
/// NaN and `lo <= hi`: two integer comparisons ([`ordered`]), where
/// `f32::clamp` makes three float comparisons (it checks `lo <= hi` first)
/// and the test for a change two more.
#[inline]
pub fn clamp(x: f32, [lo, hi]: [f32; 2]) -> (f32, bool) {
    let key = ordered(x);
    if key < ordered(lo) {
        (lo, true)
    } else if key > ordered(hi) {
        (hi, true)
    } else {
        (x, false)
    }
}

/// `libm::roundf(x) as u16` (to nearest, halves away from zero, saturating;
/// 0 for NaN), bit for bit, on the float's bits: a shift and an addition
/// instead of `roundf` and a conversion (about 120 cycles on the Cortex-M0+).
///
/// A positive `x` is `m · 2^(e − 23)` with the 24-bit significand `m` and
/// the exponent `e`: from 0.5 (`e = -1`) to below 65536 (`e = 15`), adding
/// half of the integer part's lowest bit to `m` and shifting the fraction
/// bits out rounds it half up. Below 0.5 it rounds to 0, from 65535.5 on
/// it saturates.
#[inline]
pub fn round_u16(x: f32) -> u16 {
    let bits = x.to_bits();
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    if bits >> 31 != 0 || exponent < -1 {
        // Negative (NaN included), -0.0, or below 0.5.
        return 0;
    }
    if exponent > 15 {
        // 65536 and beyond, infinity, or NaN.
        return if bits > 0x7f80_0000 { 0 } else { u16::MAX };
    }
    let significand = (bits & 0x007f_ffff) | 0x0080_0000;
    let shift = (23 - exponent) as u32;
    let rounded = (significand + (1 << (shift - 1))) >> shift;
    rounded.min(u32::from(u16::MAX)) as u16
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Floats of every kind but NaN: zeros, subnormals, ends of the range,
    /// infinities, and what a servo frame sees.
    pub(crate) fn specials() -> Vec<f32> {
        let mut v = vec![
            0.0,
            f32::from_bits(1),
            f32::from_bits(0x007f_ffff),
            f32::MIN_POSITIVE,
            1e-30,
            1e-6,
            0.3,
            1.0,
            1.7453293,
            499.9,
            500.0,
            1650.0,
            2500.0,
            2500.1,
            65535.0,
            1e30,
            f32::MAX,
            f32::INFINITY,
        ];
        v.extend(v.clone().iter().map(|x| -x));
        v.extend(v.clone().iter().flat_map(|x| [x.next_up(), x.next_down()]));
        v
    }

    #[test]
    fn ordered_integers_compare_as_the_floats_do() {
        let v = specials();
        for &a in &v {
            for &b in &v {
                let (ka, kb) = (ordered(a), ordered(b));
                assert_eq!(ka < kb, a < b, "{a:e} < {b:e}");
                assert_eq!(ka == kb, a == b, "{a:e} == {b:e}");
                assert_eq!(ka > kb, a > b, "{a:e} > {b:e}");
            }
        }
        assert!(is_nan(f32::NAN) && is_nan(-f32::NAN) && is_nan(f32::from_bits(0x7f80_0001)));
        assert!(v.iter().all(|&x| !is_nan(x)));
    }

    #[test]
    fn clamping_is_f32_clamp_and_says_when_it_changed_the_value() {
        let ranges = [
            [-1.0f32, 1.0],
            [500.0, 2500.0],
            [0.3, 0.3],
            [-0.0, 0.0],
            [0.0, -0.0],
            [-2.0, -1.0],
            [f32::NEG_INFINITY, f32::INFINITY],
        ];
        for [lo, hi] in ranges {
            for x in specials() {
                let (y, changed) = clamp(x, [lo, hi]);
                assert_eq!(
                    y.to_bits(),
                    x.clamp(lo, hi).to_bits(),
                    "{x} in [{lo}, {hi}]"
                );
                assert_eq!(changed, y != x, "{x} in [{lo}, {hi}]");
            }
        }
    }

    #[test]
    fn rounding_is_roundf_bit_for_bit() {
        let reference = |x: f32| libm::roundf(x) as u16;
        let mut checked = 0u32;
        let mut check = |x: f32| {
            assert_eq!(round_u16(x), reference(x), "{x:e} ({:#010x})", x.to_bits());
            checked += 1;
        };
        // Every whole and half µs of the range and beyond, and their neighbours.
        for n in 0..=70_000u32 {
            for x in [n as f32, n as f32 + 0.5] {
                check(x);
                check(x.next_up());
                check(x.next_down());
                check(-x);
            }
        }
        // Every exponent, both signs, with fractions at the edges and a spread between.
        let mut fraction = 0x2545_f491u32;
        for exponent in 0..=255u32 {
            for sign in [0, 1u32 << 31] {
                let mut fractions = vec![0, 1, 2, 0x007f_fffe, 0x007f_ffff];
                for k in 0..23 {
                    fractions.extend([1 << k, (1 << k) - 1, (1 << k) + 1]);
                }
                for _ in 0..500 {
                    // xorshift: a fixed spread of fractions.
                    fraction ^= fraction << 13;
                    fraction ^= fraction >> 17;
                    fraction ^= fraction << 5;
                    fractions.push(fraction & 0x007f_ffff);
                }
                for f in fractions {
                    check(f32::from_bits(sign | exponent << 23 | (f & 0x007f_ffff)));
                }
            }
        }
        for x in [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ] {
            check(x);
        }
        assert!(checked > 500_000);
    }
}
