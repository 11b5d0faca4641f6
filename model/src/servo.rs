//! An RC servo's angle -> pulse map: piecewise-linear through up to
//! [`MAX_KNOTS`] knots (sorted joint angles, rad, with their pulses, µs), the
//! two end segments extended beyond the outer knots.
//!
//! # How many knots, and where
//!
//! Between its tuned points a hobby servo misses by what its feedback
//! potentiometer's track is off a straight line (a smooth bow over the whole
//! travel) and by the eccentricity of its output gear and horn (once per
//! output turn, so half a cycle over a ±100° travel): smooth errors of at most
//! a cycle or so over the range. A polyline with knots `h` apart misses a
//! sinusoid of wavelength `λ` and amplitude `A` by up to `A (π h / λ)² / 2`.
//! Knots every 25° (9 over ±100°) follow a whole cycle over the range to 8 %
//! of its amplitude and the eccentricity to 2.4 %; knots every 50° (5) leave
//! 31 % and 9.5 %.
//!
//! The identification pays for every knot: a joint with `n` knots adds `n - 1`
//! parameters (a common shift of all its pulses is the joint's own angle
//! offset, which the rank analysis removes). With 9 knots that is 48 more
//! besides the 32 the bundled arm keeps, 80 in all from the 180 coordinates
//! of ~60 measured poses, and each inner knot moves the curve over 50° of a
//! 200° travel, seen by about 15 of those poses: the fewest that still
//! average the tracker's noise. Eleven knots would leave under two
//! coordinates per parameter. So a curve holds at most 9 knots; `servo-tune`
//! starts with 5 (every 50°) at the protractor, and the identification may
//! refine with more. On the board, with the slopes worked out once per
//! calibration ([`ServoCurve::slopes`]), a pulse costs a binary search over
//! at most seven inner knots and three operations per channel and servo frame.
//!
//! Each segment is evaluated from its end nearer 0 rad, so a curve through
//! -100°, 0° and +100° gives bit for bit the pulses of the two straight lines
//! that were the servo model before knots ([`ServoCurve::from_three_points`]).

use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::{Real, real};

/// Most knots a curve holds (see the module docs for why 9).
pub const MAX_KNOTS: usize = 9;

/// Pulses a hobby servo accepts, µs: the board's safe range by default, the
/// range `servo-tune` can record and arm files must keep their knots in.
pub const PULSE_RANGE_US: [u16; 2] = [500, 2500];

/// The angle -> pulse curve of one servo: 2 to [`MAX_KNOTS`] knots.
///
/// Built by [`ServoCurve::new`] (any knots, checked for their count only) or
/// the three-point constructors; [`ServoCurve::check`] says whether it maps
/// angle to pulse one-to-one, as the board requires.
///
/// Its `Default` is an empty curve, only a placeholder in [`crate::PerJoint`]'s
/// unused slots: [`ServoCurve::check`] refuses it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(
    try_from = "Knots<T>",
    into = "Knots<T>",
    bound(
        serialize = "T: Real + Serialize",
        deserialize = "T: Real + Deserialize<'de>"
    )
)]
pub struct ServoCurve<T> {
    /// Knot angles, rad; entries from `len` on are zero.
    angles: [T; MAX_KNOTS],
    /// Knot pulses, µs; entries from `len` on are zero.
    pulses: [T; MAX_KNOTS],
    /// Knots in use, 2..=[`MAX_KNOTS`].
    len: u8,
}

/// A curve as it is written: `{ angles_rad: [...], pulses_us: [...] }` in
/// JSON, two length-prefixed lists in postcard.
#[derive(Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Knots<T> {
    angles_rad: Vec<T, MAX_KNOTS>,
    pulses_us: Vec<T, MAX_KNOTS>,
}

impl<T: Real> TryFrom<Knots<T>> for ServoCurve<T> {
    type Error = KnotCount;

    fn try_from(k: Knots<T>) -> Result<Self, KnotCount> {
        Self::new(&k.angles_rad, &k.pulses_us)
    }
}

impl<T: Real> From<ServoCurve<T>> for Knots<T> {
    fn from(c: ServoCurve<T>) -> Self {
        // At most MAX_KNOTS entries each: both pushes always fit.
        Self {
            angles_rad: c.angles_rad().iter().copied().collect(),
            pulses_us: c.pulses_us().iter().copied().collect(),
        }
    }
}

/// Knots that cannot make a curve: fewer than 2 or more than [`MAX_KNOTS`],
/// or not as many angles as pulses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KnotCount {
    /// Angles given.
    pub angles: usize,
    /// Pulses given.
    pub pulses: usize,
}

impl core::fmt::Display for KnotCount {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "a servo curve needs 2 to {MAX_KNOTS} knots, one pulse per angle; found {} angles and {} pulses",
            self.angles, self.pulses
        )
    }
}

/// The slopes of a curve's segments, µs/rad, and the knot each segment is
/// evaluated from ([`ServoCurve::slopes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slopes<T> {
    slopes: [T; MAX_KNOTS - 1],
    /// The end of each segment nearer 0 rad (see the module docs).
    anchors: [u8; MAX_KNOTS - 1],
}

/// Why a curve does not map angle to pulse one-to-one. Knots count from 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveFault {
    /// This knot's angle or pulse is NaN or infinite.
    NotFinite {
        /// The knot.
        knot: usize,
    },
    /// This knot's angle is not above the one before it.
    AnglesNotIncreasing {
        /// The knot.
        knot: usize,
    },
    /// From the knot before to this one the pulse stands still or turns back.
    PulsesNotMonotonic {
        /// The knot.
        knot: usize,
    },
    /// Fewer than two knots: only the placeholder `Default` curve has them.
    TooFewKnots,
}

impl CurveFault {
    /// The knot at fault, counted from 0.
    pub fn knot(self) -> usize {
        match self {
            Self::NotFinite { knot }
            | Self::AnglesNotIncreasing { knot }
            | Self::PulsesNotMonotonic { knot } => knot,
            Self::TooFewKnots => 0,
        }
    }
}

impl core::fmt::Display for CurveFault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        // Knots are counted from 1 for people, like joints.
        match *self {
            Self::NotFinite { knot } => write!(f, "knot {} is NaN or infinite", knot + 1),
            Self::AnglesNotIncreasing { knot } => {
                write!(f, "knot {}'s angle is not above knot {}'s", knot + 1, knot)
            }
            Self::PulsesNotMonotonic { knot } => write!(
                f,
                "the pulse from knot {} to knot {} does not keep the direction of the curve",
                knot,
                knot + 1
            ),
            Self::TooFewKnots => f.write_str("a curve needs at least 2 knots"),
        }
    }
}

impl<T: Real> ServoCurve<T> {
    /// The curve through `angles_rad` (rad, meant in increasing order) and
    /// their `pulses_us` (µs). Only the count is checked here; see
    /// [`ServoCurve::check`] for the order.
    pub fn new(angles_rad: &[T], pulses_us: &[T]) -> Result<Self, KnotCount> {
        let n = angles_rad.len();
        if n != pulses_us.len() || !(2..=MAX_KNOTS).contains(&n) {
            return Err(KnotCount {
                angles: n,
                pulses: pulses_us.len(),
            });
        }
        let mut curve = Self {
            angles: [T::zero(); MAX_KNOTS],
            pulses: [T::zero(); MAX_KNOTS],
            len: n as u8,
        };
        curve.angles[..n].copy_from_slice(angles_rad);
        curve.pulses[..n].copy_from_slice(pulses_us);
        Ok(curve)
    }

    /// The level-1 curve of earlier arm and calibration files: the pulses
    /// (µs) measured at -100°, 0° and +100°.
    pub fn from_three_points(minus100: T, zero: T, plus100: T) -> Self {
        let span: T = real(100.0f64.to_radians());
        Self::new(&[-span, T::zero(), span], &[minus100, zero, plus100])
            .unwrap_or_else(|_| unreachable!("three knots are always a valid count"))
    }

    /// The data-sheet curve of a hobby servo: 900 / 1650 / 2400 µs at -100° / 0° / +100°.
    pub fn nominal() -> Self {
        Self::from_three_points(real(900.0), real(1650.0), real(2400.0))
    }

    /// This curve's pulses at `angles_rad`: the same map through other knots.
    pub fn resampled(&self, angles_rad: &[T]) -> Result<Self, KnotCount> {
        let n = angles_rad.len();
        let mut pulses = [T::zero(); MAX_KNOTS];
        if n > MAX_KNOTS {
            return Err(KnotCount {
                angles: n,
                pulses: n,
            });
        }
        for (p, &a) in pulses.iter_mut().zip(angles_rad) {
            *p = self.pulse_us(a);
        }
        Self::new(angles_rad, &pulses[..n])
    }

    /// Number of knots, 2..=[`MAX_KNOTS`].
    pub fn knot_count(&self) -> usize {
        usize::from(self.len)
    }

    /// The knots' angles, rad.
    pub fn angles_rad(&self) -> &[T] {
        &self.angles[..self.knot_count()]
    }

    /// The knots' pulses, µs.
    pub fn pulses_us(&self) -> &[T] {
        &self.pulses[..self.knot_count()]
    }

    /// The knots' pulses to change in place (tuning, identification), µs.
    pub fn pulses_us_mut(&mut self) -> &mut [T] {
        let n = self.knot_count();
        &mut self.pulses[..n]
    }

    /// The knots' angles to change in place (identification moves a knot to
    /// the angle its pulse really reaches), rad.
    pub fn angles_rad_mut(&mut self) -> &mut [T] {
        let n = self.knot_count();
        &mut self.angles[..n]
    }

    /// The same curve with every number passed through `f` (e.g. `f64 -> f32`).
    pub fn map<U: Real>(&self, f: impl Fn(T) -> U) -> ServoCurve<U> {
        let mut out = ServoCurve {
            angles: [U::zero(); MAX_KNOTS],
            pulses: [U::zero(); MAX_KNOTS],
            len: self.len,
        };
        for (k, (&a, &p)) in self.angles_rad().iter().zip(self.pulses_us()).enumerate() {
            out.angles[k] = f(a);
            out.pulses[k] = f(p);
        }
        out
    }

    /// Whether the pulses grow with the angle.
    fn increasing(&self) -> bool {
        self.pulses[self.knot_count() - 1] > self.pulses[0]
    }

    /// The segment `[k, k + 1]` and the end of it the value is computed from:
    /// the one nearer 0 rad (see the module docs).
    fn segment(&self, k: usize) -> (usize, usize, usize) {
        let a = &self.angles;
        let anchor = if a[k + 1].abs() < a[k].abs() {
            k + 1
        } else {
            k
        };
        (k, k + 1, anchor)
    }

    /// Pulse (µs) for a joint angle (rad); beyond the outer knots the end
    /// segments are extended.
    pub fn pulse_us(&self, angle: T) -> T {
        self.pulse_through(angle, |k| self.slope(k))
    }

    /// The slope of segment `[k, k + 1]`, µs/rad.
    fn slope(&self, k: usize) -> T {
        let (a, p) = (&self.angles, &self.pulses);
        (p[k + 1] - p[k]) / (a[k + 1] - a[k])
    }

    /// Every segment's slope and the knot it is evaluated from, worked out
    /// once for a curve evaluated often.
    pub fn slopes(&self) -> Slopes<T> {
        let mut out = Slopes {
            slopes: [T::zero(); MAX_KNOTS - 1],
            anchors: [0; MAX_KNOTS - 1],
        };
        for k in 0..self.knot_count() - 1 {
            out.slopes[k] = self.slope(k);
            // At most MAX_KNOTS - 1: fits a byte.
            out.anchors[k] = self.segment(k).2 as u8;
        }
        out
    }

    /// [`ServoCurve::pulse_us`], bit for bit, with the slopes of
    /// [`ServoCurve::slopes`] instead of a division: what the board does six
    /// times a servo frame. Slopes of another curve give a wrong pulse, never
    /// a panic.
    pub fn pulse_us_with(&self, slopes: &Slopes<T>, angle: T) -> T {
        self.pulse_on(slopes, self.segment_of(angle), angle)
    }

    /// The segment `angle` lies on, `k` for `[k, k + 1]`: the first one up
    /// to the second knot, the last one from the last but one knot on (the
    /// end segments go on beyond the outer knots), `0` for NaN. The number
    /// of inner knots at or below `angle`.
    pub fn segment_of(&self, angle: T) -> usize {
        let inner = &self.angles[1..self.knot_count() - 1];
        inner.partition_point(|&x| x <= angle)
    }

    /// [`ServoCurve::pulse_us_with`] for an `angle` on segment `k`, as
    /// [`ServoCurve::segment_of`] finds it: for a caller that finds the
    /// segment its own way. Another segment of the curve gives a point of
    /// that segment's line; a `k` past the curve's last segment gives a
    /// meaningless pulse, past the eighth a panic.
    pub fn pulse_on(&self, slopes: &Slopes<T>, k: usize, angle: T) -> T {
        let at = usize::from(slopes.anchors[k]);
        self.pulses[at] + slopes.slopes[k] * (angle - self.angles[at])
    }

    /// The pulse at `angle` on its segment `k`, whose slope `slope(k)` gives.
    #[inline]
    fn pulse_through(&self, angle: T, slope: impl FnOnce(usize) -> T) -> T {
        let (lo, _, at) = self.segment(self.segment_of(angle));
        self.pulses[at] + slope(lo) * (angle - self.angles[at])
    }

    /// Joint angle (rad) for a pulse (µs): the inverse of [`ServoCurve::pulse_us`].
    ///
    /// Only meaningful for a monotonic curve (see [`ServoCurve::check`]).
    pub fn angle(&self, pulse_us: T) -> T {
        let inner = &self.pulses[1..self.knot_count() - 1];
        let k = if self.increasing() {
            inner.partition_point(|&x| x <= pulse_us)
        } else {
            inner.partition_point(|&x| x > pulse_us)
        };
        let (lo, hi, at) = self.segment(k);
        let (a, p) = (&self.angles, &self.pulses);
        a[at] + (pulse_us - p[at]) * (a[hi] - a[lo]) / (p[hi] - p[lo])
    }

    /// Whether the curve maps angle to pulse one-to-one: finite knots, angles
    /// strictly increasing, pulses strictly increasing or strictly decreasing.
    pub fn check(&self) -> Result<(), CurveFault> {
        let (a, p) = (self.angles_rad(), self.pulses_us());
        if a.len() < 2 {
            return Err(CurveFault::TooFewKnots);
        }
        if let Some(knot) = (0..a.len()).find(|&k| !(a[k].is_finite() && p[k].is_finite())) {
            return Err(CurveFault::NotFinite { knot });
        }
        if let Some(knot) = (1..a.len()).find(|&k| a[k] <= a[k - 1]) {
            return Err(CurveFault::AnglesNotIncreasing { knot });
        }
        let up = p[1] > p[0];
        let turns = |k: &usize| {
            if up {
                p[*k] <= p[*k - 1]
            } else {
                p[*k] >= p[*k - 1]
            }
        };
        match (1..a.len()).find(turns) {
            Some(knot) => Err(CurveFault::PulsesNotMonotonic { knot }),
            None => Ok(()),
        }
    }

    /// Whether [`ServoCurve::check`] passes: what the board requires of every curve.
    pub fn is_monotonic(&self) -> bool {
        self.check().is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use std::string::ToString;
    use std::vec;

    /// The two straight lines through -100°, 0° and +100° that were the
    /// servo model before knots, written as they were.
    fn two_lines<T: Real>(m: T, z: T, p: T, angle: T) -> T {
        let span: T = real(100.0f64.to_radians());
        let slope = if angle < T::zero() {
            (z - m) / span
        } else {
            (p - z) / span
        };
        z + slope * angle
    }

    fn two_lines_angle<T: Real>(m: T, z: T, p: T, pulse: T) -> T {
        let span: T = real(100.0f64.to_radians());
        let below_zero = (pulse < z) == (p > m);
        let (lo, hi) = if below_zero { (m, z) } else { (z, p) };
        (pulse - z) * span / (hi - lo)
    }

    #[test]
    fn three_points_give_the_two_lines_bit_for_bit() {
        let mut rng = rand::rng();
        use rand::Rng;
        for _ in 0..2000 {
            let m: f64 = rng.random_range(500.0..1400.0);
            let z: f64 = rng.random_range(1450.0..1700.0);
            let p: f64 = rng.random_range(1800.0..2500.0);
            let (m, p) = if rng.random_bool(0.5) { (m, p) } else { (p, m) };
            let c = ServoCurve::from_three_points(m, z, p);
            let c32 = c.map(|x| x as f32);
            let a: f64 = rng.random_range(-2.5..2.5);
            assert_eq!(c.pulse_us(a).to_bits(), two_lines(m, z, p, a).to_bits());
            let (m32, z32, p32, a32) = (m as f32, z as f32, p as f32, a as f32);
            assert_eq!(
                c32.pulse_us(a32).to_bits(),
                two_lines(m32, z32, p32, a32).to_bits()
            );
            let pulse: f64 = rng.random_range(400.0..2600.0);
            // Equal up to the sign of a zero.
            assert_eq!(c.angle(pulse), two_lines_angle(m, z, p, pulse));
        }
    }

    #[test]
    fn worked_out_slopes_give_the_same_pulses_bit_for_bit() {
        let mut rng = rand::rng();
        use rand::Rng;
        for n in 2..=MAX_KNOTS {
            let mut angles = [0.0f32; MAX_KNOTS];
            let mut pulses = [0.0f32; MAX_KNOTS];
            for k in 0..n {
                angles[k] = -1.8 + 3.6 * k as f32 / (n - 1) as f32 + rng.random_range(-0.1..0.1);
                pulses[k] =
                    900.0 + 1500.0 * k as f32 / (n - 1) as f32 + rng.random_range(-20.0..20.0);
            }
            let c = ServoCurve::new(&angles[..n], &pulses[..n]).unwrap();
            let slopes = c.slopes();
            for _ in 0..200 {
                let a: f32 = rng.random_range(-2.5..2.5);
                assert_eq!(
                    c.pulse_us_with(&slopes, a).to_bits(),
                    c.pulse_us(a).to_bits()
                );
            }
        }
    }

    #[test]
    fn passes_through_its_knots_and_extends_the_ends() {
        let d = |x: f64| x.to_radians();
        let c = ServoCurve::new(
            &[d(-90.0), d(-40.0), d(10.0), d(60.0), d(95.0)],
            &[1000.0, 1300.0, 1620.0, 1900.0, 2130.0],
        )
        .unwrap();
        assert!(c.is_monotonic());
        for (&a, &p) in c.angles_rad().iter().zip(c.pulses_us()) {
            assert_relative_eq!(c.pulse_us(a), p, epsilon = 1e-9);
        }
        assert_relative_eq!(c.pulse_us(d(-15.0)), 1460.0, epsilon = 1e-9);
        assert_relative_eq!(c.pulse_us(d(-100.0)), 940.0, epsilon = 1e-9);
        assert_relative_eq!(c.pulse_us(d(130.0)), 2360.0, epsilon = 1e-9);
        // Between the knots: straight lines, so halfway is the mean.
        assert_relative_eq!(c.pulse_us(d(77.5)), 2015.0, epsilon = 1e-9);
    }

    #[test]
    fn angle_inverts_pulse_for_either_direction() {
        let d = |x: f64| x.to_radians();
        let angles = [d(-100.0), d(-50.0), d(0.0), d(25.0), d(50.0), d(100.0)];
        for pulses in [
            [1000.0, 1240.0, 1500.0, 1660.0, 1790.0, 2100.0],
            [2300.0, 1900.0, 1600.0, 1420.0, 1300.0, 950.0],
        ] {
            let c = ServoCurve::new(&angles, &pulses).unwrap();
            assert!(c.is_monotonic());
            for a in [-1.9, -0.9, -0.5, 0.0, 0.3, 0.6, 1.7] {
                assert_relative_eq!(c.angle(c.pulse_us(a)), a, epsilon = 1e-12);
            }
        }
    }

    #[test]
    fn faults_name_the_first_bad_knot() {
        let c = |a: &[f64], p: &[f64]| ServoCurve::new(a, p).unwrap().check();
        assert_eq!(
            c(&[-1.0, 0.0, 0.5, 1.0], &[1000.0, 1500.0, 1400.0, 2000.0]),
            Err(CurveFault::PulsesNotMonotonic { knot: 2 })
        );
        assert_eq!(
            c(&[-1.0, 0.0, 1.0], &[2000.0, 1500.0, 1500.0]),
            Err(CurveFault::PulsesNotMonotonic { knot: 2 })
        );
        assert_eq!(
            c(&[-1.0, 0.5, 0.5], &[1000.0, 1500.0, 1600.0]),
            Err(CurveFault::AnglesNotIncreasing { knot: 2 })
        );
        assert_eq!(
            c(&[-1.0, 0.0, 1.0], &[1000.0, f64::NAN, 2000.0]),
            Err(CurveFault::NotFinite { knot: 1 })
        );
        assert_eq!(
            c(&[-1.0, 0.0, f64::INFINITY], &[1000.0, 1500.0, 2000.0]),
            Err(CurveFault::NotFinite { knot: 2 })
        );
        assert_eq!(c(&[-1.0, 1.0], &[1000.0, 2000.0]), Ok(()));
        let msg = CurveFault::PulsesNotMonotonic { knot: 2 }.to_string();
        assert!(msg.contains("knot 2 to knot 3"), "{msg}");
    }

    #[test]
    fn knot_counts_outside_two_to_nine_are_refused() {
        let ten = [0.0f64; 10];
        assert!(ServoCurve::new(&ten[..1], &ten[..1]).is_err());
        assert!(ServoCurve::new(&ten, &ten).is_err());
        let e = ServoCurve::new(&ten[..3], &ten[..4]).unwrap_err();
        assert_eq!(
            e,
            KnotCount {
                angles: 3,
                pulses: 4
            }
        );
        assert!(e.to_string().contains("2 to 9 knots"), "{e}");
        assert!(ServoCurve::new(&ten[..9], &ten[..9]).is_ok());
    }

    #[test]
    fn resampling_keeps_the_map() {
        let c = ServoCurve::<f64>::nominal();
        let d = |x: f64| x.to_radians();
        let five = c
            .resampled(&[d(-100.0), d(-50.0), d(0.0), d(50.0), d(100.0)])
            .unwrap();
        assert_eq!(five.pulses_us(), [900.0, 1275.0, 1650.0, 2025.0, 2400.0]);
        for a in [-2.0, -0.3, 0.0, 0.8, 2.0] {
            assert_relative_eq!(five.pulse_us(a), c.pulse_us(a), epsilon = 1e-9);
        }
    }

    #[test]
    fn serde_writes_the_knots_in_use_and_refuses_bad_counts() {
        let c = ServoCurve::<f32>::nominal();
        let mut buf = [0u8; 128];
        let bytes = postcard::to_slice(&c, &mut buf).unwrap().to_vec();
        // Two length-prefixed lists of three f32.
        assert_eq!(bytes.len(), 2 * (1 + 3 * 4));
        assert_eq!(postcard::from_bytes::<ServoCurve<f32>>(&bytes), Ok(c));
        let one = [1u8, 0, 0, 0, 0, 1, 0, 0, 0, 0];
        assert!(postcard::from_bytes::<ServoCurve<f32>>(&one).is_err());
        let mut ten = vec![10u8];
        ten.extend([0u8; 40]);
        ten.push(10);
        ten.extend([0u8; 40]);
        assert!(postcard::from_bytes::<ServoCurve<f32>>(&ten).is_err());
    }
}
