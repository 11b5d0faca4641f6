//! The servo outputs: the bus trait, and the pure maths from a joint angle to
//! a pulse that can never leave the joint's limits or the safe pulse range.
//!
//! The angle -> pulse map is the calibration's [`ServoCurve`] of 2 to 9
//! knots, evaluated by `model` itself, so the board's pulses are the host's
//! to rounding. Its cost per channel and servo frame is a binary search over
//! at most seven inner knots, a subtraction, a multiplication and an
//! addition: the segments' slopes are worked out once ([`PreparedCurve`]).
//!
//! Everything else [`pulse_for`] needs is worked out once too, not per
//! frame: the joint limits in force (per calibration, [`joint_limits`]) and
//! the safe pulse range as floats. On the Cortex-M0+ every float
//! comparison and conversion is a call (27 to 50 cycles a comparison), so
//! the segment search and the clamps compare the floats' bits as integers
//! (`crate::float`: every value there is finite), and the pulse is rounded
//! on its bits too.

use model::ServoCurve;
use model::servo::{MAX_KNOTS, Slopes};

use crate::CHANNELS;
use crate::float::{clamp, is_nan, ordered, round_u16};

/// The board's [`CHANNELS`] PWM outputs.
pub trait ServoBus {
    /// Puts `pulse_us` on `channel` from the next PWM period on, or stops its
    /// pulses (`None`: the servo goes limp). Must not block.
    fn set_pulse(&mut self, channel: usize, pulse_us: Option<u16>);
}

/// A servo curve with its segments' slopes worked out, as the servo frame uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedCurve {
    /// The curve.
    pub curve: ServoCurve<f32>,
    slopes: Slopes<f32>,
    /// The inner knots' angles as ordered integers (`crate::float::ordered`), the curve's
    /// `knot_count() - 2` first: the segment search without float comparisons.
    inner: [i32; MAX_KNOTS - 2],
}

impl PreparedCurve {
    /// Works out `curve`'s slopes (once per calibration, not per frame).
    pub fn new(curve: ServoCurve<f32>) -> Self {
        let mut inner = [0; MAX_KNOTS - 2];
        let knots = curve.angles_rad();
        for (key, &angle) in inner.iter_mut().zip(&knots[1..knots.len() - 1]) {
            *key = ordered(angle);
        }
        Self {
            slopes: curve.slopes(),
            curve,
            inner,
        }
    }

    /// Pulse (µs) for a joint angle (rad): [`ServoCurve::pulse_us`] bit for bit.
    ///
    /// The segment is [`ServoCurve::segment_of`]'s, found on the integers;
    /// `model` evaluates it.
    pub fn pulse_us(&self, angle: f32) -> f32 {
        let segment = if is_nan(angle) {
            // Where `segment_of` puts NaN (the pulse is NaN on any segment).
            0
        } else {
            let key = ordered(angle);
            let inner = &self.inner[..self.curve.knot_count() - 2];
            inner.partition_point(|&knot| knot <= key)
        };
        self.curve.pulse_on(&self.slopes, segment, angle)
    }
}

/// What [`pulse_for`] did to a joint angle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pulse {
    /// Pulse to send, µs.
    pub us: u16,
    /// Whether the angle or the pulse had to be clamped to a limit.
    pub clamped: bool,
}

/// The pulse for `angle_rad` on a servo with `curve`: the angle is clamped to
/// `limits_rad`, the pulse to `pulse_range_us` (the safe range as floats,
/// within `0..=u16::MAX`). `None` for a non-finite angle (the caller keeps
/// the previous pulse). Both ranges must be ordered (`lo <= hi`), as
/// [`joint_limits`] and the config's pulse range are.
pub fn pulse_for(
    curve: &PreparedCurve,
    angle_rad: f32,
    limits_rad: [f32; 2],
    pulse_range_us: [f32; 2],
) -> Option<Pulse> {
    if !angle_rad.is_finite() {
        return None;
    }
    let (angle, angle_clamped) = clamp(angle_rad, limits_rad);
    let raw = curve.pulse_us(angle);
    if !raw.is_finite() {
        return None;
    }
    let (us, pulse_clamped) = clamp(raw, pulse_range_us);
    Some(Pulse {
        us: round_u16(us),
        clamped: angle_clamped || pulse_clamped,
    })
}

/// The joint ranges in force per channel: a calibration's limits cut to the
/// hard range, or the default range without a calibration. The channels past
/// a calibrated arm's last joint, which are never driven, get the default range.
pub fn joint_limits(
    calibrated: Option<&model::Arm<f32>>,
    hard: [f32; 2],
    default: [f32; 2],
) -> [[f32; 2]; CHANNELS] {
    core::array::from_fn(|i| match calibrated.and_then(|arm| arm.joints.get(i)) {
        Some(joint) => {
            let [lo, hi] = joint.limits;
            let lo = lo.max(hard[0]);
            let hi = hi.min(hard[1]);
            // A calibration entirely outside the hard range pins the joint at its edge.
            if lo <= hi { [lo, hi] } else { [hi, hi] }
        }
        None => default,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const RANGE: [f32; 2] = [500.0, 2500.0];
    const LIMITS: [f32; 2] = [-1.7453293, 1.7453293];

    #[test]
    fn three_point_curve_gives_its_pulses() {
        let c = PreparedCurve::new(ServoCurve::from_three_points(1000.0, 1500.0, 2100.0));
        let r = 100f32.to_radians();
        assert_eq!(pulse_for(&c, -r, LIMITS, RANGE).unwrap().us, 1000);
        assert_eq!(pulse_for(&c, 0.0, LIMITS, RANGE).unwrap().us, 1500);
        assert_eq!(pulse_for(&c, r, LIMITS, RANGE).unwrap().us, 2100);
        assert_eq!(pulse_for(&c, r / 2.0, LIMITS, RANGE).unwrap().us, 1800);
        assert_eq!(pulse_for(&c, -r / 2.0, LIMITS, RANGE).unwrap().us, 1250);
    }

    #[test]
    fn a_many_knot_curve_gives_the_pulse_of_its_segment() {
        let d = |x: f32| x.to_radians();
        let c = PreparedCurve::new(
            ServoCurve::new(
                &[d(-100.0), d(-75.0), d(-25.0), d(0.0), d(40.0), d(100.0)],
                &[950.0, 1100.0, 1420.0, 1600.0, 1840.0, 2200.0],
            )
            .unwrap(),
        );
        for (deg, us) in [
            (-100.0, 950),
            (-87.5, 1025),
            (-50.0, 1260),
            (-10.0, 1528),
            (0.0, 1600),
            (20.0, 1720),
            (70.0, 2020),
            (100.0, 2200),
            // Beyond the outer knots the end segments go on.
            (-110.0, 890),
            (110.0, 2260),
        ] {
            let p = pulse_for(&c, d(deg), [-2.0, 2.0], RANGE).unwrap();
            assert_eq!((deg, p.us), (deg, us));
        }
    }

    #[test]
    fn angles_and_pulses_are_clamped() {
        let c = PreparedCurve::new(ServoCurve::nominal());
        let p = pulse_for(&c, 3.0, [-1.0, 1.0], RANGE).unwrap();
        assert_eq!(
            p,
            pulse_for(&c, 1.0, [-1.0, 1.0], RANGE)
                .map(|p| Pulse { clamped: true, ..p })
                .unwrap()
        );
        // A wild calibration curve cannot push the pulse out of the safe range.
        let wild = PreparedCurve::new(ServoCurve::from_three_points(-4000.0, 1500.0, 9000.0));
        assert_eq!(
            pulse_for(&wild, 1.7, LIMITS, RANGE).unwrap(),
            Pulse {
                us: 2500,
                clamped: true
            }
        );
        assert_eq!(
            pulse_for(&wild, -1.7, LIMITS, RANGE).unwrap(),
            Pulse {
                us: 500,
                clamped: true
            }
        );
        assert_eq!(pulse_for(&c, f32::NAN, LIMITS, RANGE), None);
        assert_eq!(pulse_for(&c, f32::INFINITY, LIMITS, RANGE), None);
    }

    #[test]
    fn calibration_limits_are_cut_to_the_hard_range() {
        let mut arm = protocol_free_arm();
        arm.joints[0].limits = [-9.0, 9.0];
        arm.joints[1].limits = [4.0, 5.0];
        let l = joint_limits(Some(&arm), [-2.0, 2.0], [-1.0, 1.0]);
        assert_eq!(l[0], [-2.0, 2.0]);
        assert_eq!(l[1], [2.0, 2.0]);
        assert_eq!(l[2], arm.joints[2].limits);
        assert_eq!(
            joint_limits(None, [-2.0, 2.0], [-1.0, 1.0]),
            [[-1.0, 1.0]; 6]
        );
        // A five-joint arm: channel 6 (never driven) gets the default range.
        let five = crate::sim::test_calibration_of(1, 5).calibrated;
        let l = joint_limits(Some(&five), [-2.0, 2.0], [-1.0, 1.0]);
        assert_eq!(l[4], five.joints[4].limits);
        assert_eq!(l[5], [-1.0, 1.0]);
    }

    #[test]
    fn prepared_curves_give_the_model_pulses_bit_for_bit() {
        let d = |x: f32| x.to_radians();
        let mut curves: Vec<ServoCurve<f32>> = (0..CHANNELS).map(crate::sim::test_curve).collect();
        curves.push(ServoCurve::nominal());
        curves.push(ServoCurve::new(&[d(-100.0), d(100.0)], &[900.0, 2400.0]).unwrap());
        // Knots on both sides of zero and at -0.0, falling pulses.
        curves.push(
            ServoCurve::new(
                &[
                    d(-120.0),
                    d(-3.0),
                    -0.0,
                    d(2.0),
                    d(40.0),
                    d(80.0),
                    d(90.0),
                    d(95.0),
                    d(130.0),
                ],
                &[
                    2400.0, 1700.0, 1650.0, 1600.0, 1400.0, 1200.0, 1100.0, 1000.0, 700.0,
                ],
            )
            .unwrap(),
        );
        for curve in curves {
            let prepared = PreparedCurve::new(curve);
            let mut angles = crate::float::tests::specials();
            for &k in curve.angles_rad() {
                angles.extend([k, k.next_up(), k.next_down(), -k]);
            }
            angles.extend((-3000..=3000).map(|i| i as f32 * 1e-3));
            for a in angles {
                assert_eq!(
                    prepared.pulse_us(a).to_bits(),
                    curve.pulse_us(a).to_bits(),
                    "{a:e} on {curve:?}"
                );
            }
            assert!(prepared.pulse_us(f32::NAN).is_nan());
        }
    }

    fn protocol_free_arm() -> model::Arm<f32> {
        crate::sim::test_calibration(1).calibrated
    }
}
