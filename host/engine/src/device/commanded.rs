//! What a board holding a calibration will command for nominal joint
//! targets, worked out on the host: the compensation of its calibration (the
//! solve the board spreads over its servo frames, here run to the end in
//! f64), and whether the commands stay where the board lets them go: within
//! each joint's range (with the play's offset the board adds on top) and
//! within the calibration's largest corrections. `move --xyz` and the demo's
//! positioning choose, among the nominal solutions for a tool point, one the
//! board can command without clamping or falling back.

use model::{Arm, Chain, CompensationOptions, PerJoint};
use protocol::{Calibration, CompensationMode};

/// The share of a joint's largest correction a pose may use: the board's
/// solve, one step per servo frame while the targets move, passes through
/// states beyond the final one, and a state beyond the bound is not sent.
pub const HEADROOM: f64 = 0.8;

/// The joint ranges a board accepts move targets in, rad: its calibration's
/// limits cut to the hard range, or the default range without one, as the
/// firmware decides them (its own function and configuration).
pub fn board_limits(calibration: Option<&Calibration>) -> Vec<[f32; 2]> {
    let config = firmware::Config::default();
    let limits = firmware::servo::joint_limits(
        calibration.map(|c| &c.calibrated),
        config.hard_limits_rad,
        config.default_limits_rad,
    );
    let joints = calibration.map_or(limits.len(), |c| c.calibrated.joints.len());
    limits.into_iter().take(joints).collect()
}

/// `arm` with its joint limits cut to the ranges the board accepts targets
/// in (`calibration`'s, or a board's without one).
pub fn within_board(arm: &Arm<f64>, calibration: Option<&Calibration>) -> Arm<f64> {
    let mut arm = *arm;
    for (joint, [lo, hi]) in arm.joints.iter_mut().zip(board_limits(calibration)) {
        joint.limits = [
            joint.limits[0].max(f64::from(lo)),
            joint.limits[1].min(f64::from(hi)),
        ];
    }
    arm
}

/// A board's calibration as its compensation sees it, in f64.
#[derive(Clone, Debug)]
pub struct Commanded {
    nominal: Chain<f64>,
    calibrated: Chain<f64>,
    /// The joint ranges the board enforces, rad.
    limits: Vec<[f64; 2]>,
    /// Half of each joint's play: the board's offset in the way of motion, rad.
    half_play: PerJoint<f64>,
    /// The calibration's largest corrections, cut to the board's cap, times [`HEADROOM`], rad.
    max_correction: Vec<f64>,
    mode: CompensationMode,
    payload_kg: f64,
}

/// Why the board could not command a nominal pose as it is meant.
#[derive(Clone, Debug, PartialEq)]
pub enum Refusal {
    /// The compensation does not reach the tool point.
    NotReached {
        /// How far it stays, m.
        error_m: f64,
    },
    /// A joint's command (with the play's offset either way) leaves its range.
    OutsideRange {
        /// The joint, 1-based.
        joint: usize,
        /// The command, rad.
        command_rad: f64,
        /// The range, rad.
        range_rad: [f64; 2],
    },
    /// A joint's correction is beyond the calibration's largest (less the headroom).
    TooLarge {
        /// The joint, 1-based.
        joint: usize,
        /// The correction, rad.
        correction_rad: f64,
        /// The largest the board allows, rad.
        max_rad: f64,
    },
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotReached { error_m } => write!(
                f,
                "the compensation stays {:.2} mm from the tool point",
                error_m * 1e3
            ),
            Self::OutsideRange {
                joint,
                command_rad,
                range_rad,
            } => write!(
                f,
                "the compensation would command joint {joint} at {:.1}° (with half its play), \
                 outside its range [{:.1}°, {:.1}°]",
                command_rad.to_degrees(),
                range_rad[0].to_degrees(),
                range_rad[1].to_degrees()
            ),
            Self::TooLarge {
                joint,
                correction_rad,
                max_rad,
            } => write!(
                f,
                "the compensation would correct joint {joint} by {:.1}°, more than the \
                 {:.1}° the calibration's largest correction leaves for a target",
                correction_rad.to_degrees(),
                max_rad.to_degrees()
            ),
        }
    }
}

impl Commanded {
    /// The board holding `calibration`, compensating in `mode` for
    /// `payload_kg`, with the firmware's own joint ranges and correction cap.
    pub fn new(calibration: &Calibration, mode: CompensationMode, payload_kg: f64) -> Self {
        let config = firmware::Config::default();
        let limits = board_limits(Some(calibration));
        Self {
            nominal: calibration.nominal.map(f64::from).chain(),
            calibrated: calibration.calibrated.map(f64::from).chain(),
            limits: limits.iter().map(|r| r.map(f64::from)).collect(),
            half_play: calibration
                .calibrated
                .joints
                .map(|j| 0.5 * f64::from(j.backlash)),
            max_correction: calibration
                .max_correction_rad
                .iter()
                .map(|m| HEADROOM * f64::from(m.min(config.max_correction_rad)))
                .collect(),
            mode,
            payload_kg,
        }
    }

    /// The joint commands for the nominal targets `q_nominal` (before the
    /// play's offset), or why the board could not send them as meant.
    pub fn command(&self, q_nominal: &[f64]) -> Result<PerJoint<f64>, Refusal> {
        let q = match self.mode {
            CompensationMode::Off => PerJoint::from_fn(q_nominal.len(), |j| q_nominal[j]),
            CompensationMode::ElasticOnly => {
                self.solve(q_nominal, self.calibrated.rigid_tool_point(q_nominal))?
            }
            CompensationMode::Full => {
                let target = self
                    .nominal
                    .tool_point(q_nominal, self.payload_kg, &Default::default())
                    .map_err(|_| Refusal::NotReached {
                        error_m: f64::INFINITY,
                    })?;
                self.solve(q_nominal, target)?
            }
        };
        for j in 0..q.len() {
            let correction = (q[j] - q_nominal[j]).abs();
            if correction > self.max_correction[j] {
                return Err(Refusal::TooLarge {
                    joint: j + 1,
                    correction_rad: correction,
                    max_rad: self.max_correction[j],
                });
            }
            let [lo, hi] = self.limits[j];
            for command in [q[j] - self.half_play[j], q[j] + self.half_play[j]] {
                if command < lo || command > hi {
                    return Err(Refusal::OutsideRange {
                        joint: j + 1,
                        command_rad: command,
                        range_rad: [lo, hi],
                    });
                }
            }
        }
        Ok(q)
    }

    fn solve(
        &self,
        q_nominal: &[f64],
        target: nalgebra::Vector3<f64>,
    ) -> Result<PerJoint<f64>, Refusal> {
        let options = CompensationOptions {
            max_iterations: 30,
            ..CompensationOptions::default()
        };
        match self
            .calibrated
            .compensate(q_nominal, &target, self.payload_kg, None, &options)
        {
            Ok(c) if c.converged => Ok(c.q),
            Ok(c) => Err(Refusal::NotReached { error_m: c.error_m }),
            Err(_) => Err(Refusal::NotReached {
                error_m: f64::INFINITY,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::calibration::max_corrections;

    fn calibration(nominal: model::Arm<f64>, calibrated: model::Arm<f64>) -> Calibration {
        Calibration {
            id: 0,
            option: protocol::ModelOption::ElastoKinematic,
            nominal: nominal.map(|x| x as f32),
            calibrated: calibrated.map(|x| x as f32),
            home_rad: [0.0; 6].into(),
            max_correction_rad: max_corrections(&nominal, &calibrated),
        }
    }

    #[test]
    fn a_sagging_offset_joint_is_corrected_and_refused_at_its_limit() {
        let mut nominal = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
        // The shoulder may not lean back past upright, where it carries no torque.
        nominal.joints[1].limits[0] = 0.0;
        let mut calibrated = nominal;
        calibrated.joints[1].compliance = 0.2;
        // The shoulder's zero is 3° off: every command is corrected by about -3°.
        calibrated.joints[1].theta += 3f64.to_radians();
        let cal = calibration(nominal, calibrated);
        let board = Commanded::new(&cal, CompensationMode::Full, 0.0663);
        let q = [0.0, 1.2, 0.0, 0.0, 0.0, 0.0];
        let c = board.command(&q).unwrap();
        assert!(c[1] < q[1] - 1e-3, "{c:?}");
        // Upright, at its lower limit, there is no room below it.
        let at_limit = [0.0; 6];
        match board.command(&at_limit) {
            Err(Refusal::OutsideRange { joint: 2, .. }) => {}
            other => panic!("{other:?}"),
        }
        // A correction beyond the calibration's largest is refused too.
        let mut tight = cal;
        tight.max_correction_rad[1] = 1e-3;
        match Commanded::new(&tight, CompensationMode::Full, 0.0663).command(&q) {
            Err(Refusal::TooLarge { joint: 2, .. }) => {}
            other => panic!("{other:?}"),
        }
        // Without compensation the nominal targets go as they are.
        let off = Commanded::new(&cal, CompensationMode::Off, 0.0663);
        assert_eq!(off.command(&at_limit), Ok(at_limit.into()));
    }
}
