//! From a calibration file (JSON, [`lrmcal_core::io::calibration_file`]) to the
//! payload the board stores, with the largest correction the board may
//! apply to each joint worked out from the calibration
//! ([`max_corrections`]).

use model::{Arm, CompensationOptions, PerJoint};
use protocol::PerChannel;
use protocol::calibration::{MAX_CALIBRATION_LEN, MAX_CORRECTION_RAD};
use protocol::{Calibration, CalibrationFault};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use lrmcal_core::io::calibration_file::CalibrationFile;

/// Random poses [`max_corrections`] looks at besides the grid's (fixed seed:
/// the same calibration always gets the same bounds and the same id).
const RANDOM_POSES: usize = 1000;
/// Seed of those poses.
const POSES_SEED: u64 = 0x00c0_4ec7;
/// The margin on the largest correction seen: times this (the poses are a
/// sample, and near a singular pose the correction grows) ...
const CORRECTION_FACTOR: f64 = 1.5;
/// ... plus this, rad (3°): room for the solve's steps on the way.
const CORRECTION_SLACK_RAD: f64 = 0.052_359_877_559_829_89;

/// Why the board cannot drive an arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NotDriven {
    /// More joints than the board has channels.
    #[error(
        "the arm has {joints} joints and the board drives arms of 1 to {}",
        protocol::CHANNELS
    )]
    Joints {
        /// The arm's joints.
        joints: usize,
    },
    /// A joint without a servo curve: an arm moved by its own controller.
    #[error(
        "joint {joint} has no servo curve (an arm the board does not drive: its arm file has \
         no `servo` table)"
    )]
    NoServo {
        /// The joint, from 1.
        joint: usize,
    },
}

/// Whether the board can drive `arm`: at most [`protocol::CHANNELS`] joints,
/// each with a servo curve. The one check `push`, `move` and the demo's
/// positioning make before anything goes to a board.
pub fn drivable(arm: &Arm<f64>) -> Result<(), NotDriven> {
    let joints = arm.joints.len();
    if joints > protocol::CHANNELS {
        return Err(NotDriven::Joints { joints });
    }
    match arm.joints.iter().position(|j| j.servo.is_none()) {
        Some(joint) => Err(NotDriven::NoServo { joint: joint + 1 }),
        None => Ok(()),
    }
}

/// The payload for `file`, in single precision, with the home pose `home_rad`:
/// the file's board arms ([`CalibrationFile::board_arms`]) and the largest
/// corrections between them.
pub fn payload(
    file: &CalibrationFile,
    home_rad: PerChannel<f32>,
) -> Result<Calibration, CalibrationFault> {
    // An arm the board cannot drive is refused here, before the corrections
    // of its joints are worked out.
    let joints = file.arm.joints.len();
    if joints > protocol::CHANNELS || home_rad.len() != joints {
        return Err(CalibrationFault::JointCount {
            joints: joints.min(usize::from(u8::MAX)) as u8,
        });
    }
    let (nominal, calibrated) = file.board_arms();
    identified(Calibration {
        id: 0,
        option: file.option,
        nominal: nominal.map(|x| x as f32),
        calibrated: calibrated.map(|x| x as f32),
        home_rad,
        max_correction_rad: max_corrections(&nominal, &calibrated),
    })
}

/// The payload of a board that knows `arm` but corrects nothing: `arm` as
/// both the nominal and the calibrated arm (its joints, servo curves,
/// limits), home at each joint's 0 (or the limit nearest it), and the
/// smallest margin for corrections, [`CORRECTION_SLACK_RAD`], since none is
/// ever asked for. With compensation off it drives the nominal arm's joints
/// through their nominal curves: an uncalibrated arm on its own board.
pub fn uncorrected(arm: &Arm<f64>) -> Result<Calibration, CalibrationFault> {
    let joints = arm.joints.len();
    if joints > protocol::CHANNELS {
        return Err(CalibrationFault::JointCount {
            joints: joints.min(usize::from(u8::MAX)) as u8,
        });
    }
    let single = arm.map(|x| x as f32);
    identified(Calibration {
        id: 0,
        // The option says which parameters a fit corrected; here none was
        // fitted, and the board does not look at it.
        option: protocol::ModelOption::Kinematic,
        nominal: single,
        calibrated: single,
        home_rad: PerChannel::from_fn(joints, |j| {
            let [lo, hi] = single.joints[j].limits;
            0f32.clamp(lo, hi)
        }),
        max_correction_rad: PerChannel::splat(joints, CORRECTION_SLACK_RAD as f32),
    })
}

/// How far the board may move each joint from its nominal target: the
/// largest correction the compensation of `calibrated` asks for over poses
/// within its limits (each joint at its limits and midway, every
/// combination, and [`RANDOM_POSES`] random poses), with no load and with
/// the rated payload, times [`CORRECTION_FACTOR`] plus
/// [`CORRECTION_SLACK_RAD`], at most `protocol`'s cap. A solve that asks
/// the board for more is a failed one (it falls back to the last good
/// correction).
pub fn max_corrections(nominal: &Arm<f64>, calibrated: &Arm<f64>) -> PerChannel<f32> {
    let n = calibrated.joints.len().min(protocol::CHANNELS);
    let limits = calibrated.joints.map(|j| j.limits);
    let levels = |j: usize| {
        let [lo, hi] = limits[j];
        [lo, 0.5 * (lo + hi), hi]
    };
    let grid = (0..3usize.pow(n as u32)).map(|mut k| {
        PerJoint::from_fn(n, |j| {
            let level = k % 3;
            k /= 3;
            levels(j)[level]
        })
    });
    let mut rng = ChaCha8Rng::seed_from_u64(POSES_SEED);
    let random: Vec<PerJoint<f64>> = (0..RANDOM_POSES)
        .map(|_| PerJoint::from_fn(n, |j| rng.random_range(limits[j][0]..=limits[j][1])))
        .collect();
    let (nominal_chain, chain) = (nominal.chain(), calibrated.chain());
    let options = CompensationOptions {
        max_iterations: 30,
        ..CompensationOptions::default()
    };
    let mut largest = PerChannel::splat(n, 0.0f64);
    for q in grid.chain(random) {
        for load in [0.0, nominal.rated_payload_kg] {
            let Ok(target) = nominal_chain.tool_point(&q, load, &Default::default()) else {
                continue;
            };
            let Ok(c) = chain.compensate(&q, &target, load, None, &options) else {
                continue;
            };
            if c.converged {
                for j in 0..n {
                    largest[j] = largest[j].max((c.q[j] - q[j]).abs());
                }
            }
        }
    }
    largest.map(|m| {
        let bound = m * CORRECTION_FACTOR + CORRECTION_SLACK_RAD;
        (bound as f32).min(MAX_CORRECTION_RAD)
    })
}

/// `fault` in words; for a servo curve, with the knots of `arm` (the
/// calibrated arm it was found in) so the user sees where the curve turns,
/// for a bounded quantity with its value.
pub fn explain(fault: CalibrationFault, arm: &Arm<f64>) -> String {
    if let CalibrationFault::Bound { quantity, .. } = fault
        && let Some(value) = quantity.value(arm)
    {
        return format!("{fault}: found {value}; not sent, the board keeps the calibration it has");
    }
    let CalibrationFault::ServoCurve { joint, .. } = fault else {
        return fault.to_string();
    };
    let Some(curve) = arm.joints.get(usize::from(joint)).and_then(|j| j.servo) else {
        return fault.to_string();
    };
    let knots: Vec<String> = curve
        .angles_rad()
        .iter()
        .zip(curve.pulses_us())
        .map(|(a, p)| format!("{:.2}° {p} µs", a.to_degrees()))
        .collect();
    format!(
        "{fault} (knots: {}); not sent: the board must never map angle to pulse non-monotonically",
        knots.join(", ")
    )
}

/// Checks `calibration` and gives it its id: the CRC-32 of the payload
/// encoded with id 0, so the same calibration always has the same id and
/// `status` shows which one is in use.
pub fn identified(mut calibration: Calibration) -> Result<Calibration, CalibrationFault> {
    calibration.check()?;
    calibration.id = 0;
    let mut buf = [0u8; MAX_CALIBRATION_LEN];
    let bytes = calibration
        .encode(&mut buf)
        .map_err(|_| CalibrationFault::NotFinite)?;
    calibration.id = protocol::frame::crc32(bytes);
    Ok(calibration)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bundled(name: &str) -> Arm<f64> {
        lrmcal_core::io::arm_source::bundled(name)
            .expect("a bundled arm parses")
            .arm
    }

    /// The board drives arms of up to six joints, each with a servo curve.
    #[test]
    fn the_board_refuses_arms_without_servo_curves_or_with_seven_joints() {
        assert_eq!(drivable(&bundled("lrm")), Ok(()));
        assert_eq!(drivable(&bundled("so101")), Ok(()));
        let urdf = lrmcal_core::io::arm_urdf::parse(
            include_str!("../../../core/arms/so101/so101.urdf"),
            None,
            Some("gripper_frame_link"),
        )
        .unwrap();
        let why = drivable(&urdf.arm).unwrap_err().to_string();
        assert!(why.contains("joint 1 has no servo curve"), "{why}");
        let mut seven = bundled("lrm");
        let joints: Vec<_> = seven
            .joints
            .iter()
            .chain(&seven.joints[..1])
            .copied()
            .collect();
        seven.joints = PerJoint::from_slice(&joints).unwrap();
        let why = drivable(&seven).unwrap_err().to_string();
        assert!(why.contains("7 joints") && why.contains("1 to 6"), "{why}");
    }
}
