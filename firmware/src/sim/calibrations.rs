//! Calibrations for the tests and the fuzzer to upload, of the model's
//! LRM-like test arm (feature `fuzz`, and this crate's tests): test code,
//! kept out of the doubles the product's in-memory board uses.

use model::{PerJoint, ServoCurve};
use protocol::{Calibration, ModelOption};

use crate::{CHANNELS, PerChannel};

/// A calibration of the shared LRM-like test arm
/// ([`model::testing::lrm_like_arm`]): millimetre and degree-level geometric
/// errors, changed compliances and individual servo curves of 3 to 9 knots,
/// each with its own bow between the ends.
pub fn test_calibration(id: u32) -> Calibration {
    test_calibration_of(id, model::testing::TEST_ARM_JOINTS)
}

/// [`test_calibration`] of the test arm's first `joints` joints (1 to 6):
/// the tool sits on the last of them, as on an arm built without the rest.
pub fn test_calibration_of(id: u32, joints: usize) -> Calibration {
    let mut nominal = model::testing::lrm_like_arm::<f32>();
    nominal.joints = PerJoint::from_slice(&nominal.joints[..joints]).expect("at most six joints");
    let mut calibrated = nominal;
    for (i, j) in calibrated.joints.iter_mut().enumerate() {
        let s = if i % 2 == 0 { 1.0 } else { -1.0 };
        j.theta += s * 0.01;
        j.d += 0.001 * s;
        j.a += 0.0015 * s;
        j.compliance *= 1.3;
        j.servo = Some(test_curve(i));
        j.limits = [-1.7, 1.7];
    }
    calibrated.base.rpy[1] += 0.005;
    calibrated.tool.xyz[0] += 0.002;
    Calibration {
        id,
        option: ModelOption::ElastoKinematic,
        nominal,
        calibrated,
        home_rad: PerChannel::from_slice(&[0.0, 0.3, -0.3, 0.0, 0.5, 0.0][..joints])
            .expect("at most six joints"),
        // 20° per joint: far beyond the corrections this calibration asks for.
        max_correction_rad: PerChannel::splat(joints, 0.35),
    }
}

/// Joint `i`'s servo curve in [`test_calibration`]: knots evenly spaced over
/// ±100° (5, 3, 7, 9, 5 and 4 of them), the ends where a three-point tuning
/// would put them, a bow of 12 - 4i µs in between.
pub fn test_curve(i: usize) -> ServoCurve<f32> {
    let n = [5, 3, 7, 9, 5, 4][i % CHANNELS];
    let span = 100f32.to_radians();
    let ends = ServoCurve::from_three_points(
        880.0 + 10.0 * i as f32,
        1640.0 + 5.0 * i as f32,
        2420.0 - 7.0 * i as f32,
    );
    let mut angles = [0.0f32; model::servo::MAX_KNOTS];
    let mut pulses = [0.0f32; model::servo::MAX_KNOTS];
    for k in 0..n {
        let t = k as f32 / (n - 1) as f32;
        angles[k] = span * (2.0 * t - 1.0);
        let bow = (12.0 - 4.0 * i as f32) * libm::sinf(core::f32::consts::PI * t);
        pulses[k] = ends.pulse_us(angles[k]) + bow;
    }
    ServoCurve::new(&angles[..n], &pulses[..n]).expect("3 to 9 knots")
}
