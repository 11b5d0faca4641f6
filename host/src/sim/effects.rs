//! The effects of a real arm that the paper's model does not contain: a smooth
//! servo angle error, direction-dependent play, and a stiffness that softens
//! with load.
//!
//! All three act through the model's public API: the first two change the
//! angle the joint is driven to before the model sees it, the third solves the
//! model's own deflection with compliances that depend on the torques the
//! model computes. No kinematics is written here.

use model::{Arm, Deflection, DeflectionError, JOINTS, SolverOptions};
use serde::{Deserialize, Serialize};

/// A servo's smooth angle error: `e(q) = sine sin(omega q + phase) + cubic (q / 100°)³`.
///
/// The servo curve of the method is two straight lines, so any error that is a
/// straight line on each side of 0 would be absorbed by the level-1 servo
/// calibration; a sine and a cubic are not.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoError {
    /// Amplitude of the sinusoidal part, rad.
    pub sine_rad: f64,
    /// Angular frequency of the sinusoidal part, rad of error phase per rad of joint angle.
    pub omega: f64,
    /// Phase of the sinusoidal part, rad.
    pub phase_rad: f64,
    /// Value of the cubic part at +100°, rad.
    pub cubic_rad: f64,
}

impl ServoError {
    /// The angle error at commanded angle `q` (rad), rad.
    pub fn at(&self, q: f64) -> f64 {
        let x = q / 100f64.to_radians();
        self.sine_rad * (self.omega * q + self.phase_rad).sin() + self.cubic_rad * x * x * x
    }
}

/// Largest change of any angle between two outer iterations of the softened
/// solve at which it counts as converged, rad.
const SOFTENING_TOLERANCE_RAD: f64 = 1e-13;
/// Outer iterations of the softened solve before giving up.
const SOFTENING_MAX_ITERATIONS: u32 = 100;

/// The deflection of `arm` driven to `q` under `payload_kg` when every
/// compliance `k` is really `k (1 + softening |tau|)` at its torque `tau`,
/// with the arm carrying the softened compliances of the solution.
///
/// Solved by an outer fixed-point iteration around the model's own
/// deflection solve: set the compliances from the torques of the last
/// deflected pose, deflect again (warm-started), until the pose stops moving.
/// At the fixed point `qa = q + k (1 + s |tau(qa)|) tau(qa)`.
pub fn softened_deflection(
    arm: &Arm<f64>,
    q: &[f64; JOINTS],
    payload_kg: f64,
    softening_per_nm: f64,
) -> Result<(Deflection<f64>, Arm<f64>), DeflectionError> {
    let options = SolverOptions::default();
    let mut softened = *arm;
    let mut deflection = arm.chain().deflect(q, payload_kg, &options)?;
    let mut last_step = f64::NAN;
    for _ in 0..SOFTENING_MAX_ITERATIONS {
        // Torques do not depend on the compliances, so any chain of this arm gives them.
        let tau = softened
            .chain()
            .gravity_torques(&deflection.qa, deflection.beta, payload_kg);
        for (i, joint) in softened.joints.iter_mut().enumerate() {
            joint.compliance =
                arm.joints[i].compliance * (1.0 + softening_per_nm * tau.joints[i].abs());
        }
        softened.base_compliance = arm.base_compliance * (1.0 + softening_per_nm * tau.base.abs());
        let next = softened.chain().deflect_from(
            q,
            payload_kg,
            (deflection.qa, deflection.beta),
            &options,
        )?;
        last_step = (next.beta - deflection.beta).abs();
        for (a, b) in next.qa.iter().zip(&deflection.qa) {
            last_step = last_step.max((a - b).abs());
        }
        deflection = next;
        if last_step <= SOFTENING_TOLERANCE_RAD {
            return Ok((deflection, softened));
        }
    }
    Err(DeflectionError::NotConverged {
        iterations: SOFTENING_MAX_ITERATIONS,
        last_step,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_support::bundled_arm;

    #[test]
    fn servo_error_is_not_piecewise_linear() {
        let e = ServoError {
            sine_rad: 0.02,
            omega: 2.0,
            phase_rad: 0.3,
            cubic_rad: -0.01,
        };
        // A piecewise-linear curve through -100°, 0, +100° is linear on [0, 100°]:
        // its midpoint value would be the mean of the ends.
        let h = 100f64.to_radians();
        let chord = 0.5 * (e.at(0.0) + e.at(h));
        assert!((e.at(0.5 * h) - chord).abs() > 1e-3);
        assert_eq!(
            ServoError {
                sine_rad: 0.0,
                omega: 2.0,
                phase_rad: 0.3,
                cubic_rad: 0.0
            }
            .at(1.0),
            0.0
        );
    }

    #[test]
    fn softening_sags_more_and_vanishes_when_off() {
        let mut arm = bundled_arm();
        for j in &mut arm.joints {
            j.compliance = 0.05;
        }
        arm.base_compliance = 0.02;
        let q = [0.3, 1.2, 0.4, 0.2, -0.6, 0.1];
        let linear = arm
            .chain()
            .tool_point(&q, 0.0663, &SolverOptions::default())
            .unwrap();
        let (off, _) = softened_deflection(&arm, &q, 0.0663, 0.0).unwrap();
        assert!((off.tool_point() - linear).norm() < 1e-12);
        let rigid = arm.chain().rigid_tool_point(&q);
        let (soft, _) = softened_deflection(&arm, &q, 0.0663, 0.3).unwrap();
        assert!(
            (soft.tool_point() - rigid).norm() > (linear - rigid).norm() * 1.05,
            "softening must add sag"
        );
    }

    #[test]
    fn softened_solution_satisfies_its_equation() {
        let mut arm = bundled_arm();
        for j in &mut arm.joints {
            j.compliance = 0.08;
        }
        arm.base_compliance = 0.03;
        let (q, load, s) = ([0.0, -1.3, 0.2, 0.0, 0.9, 0.0], 0.0663, 0.3);
        let (d, softened) = softened_deflection(&arm, &q, load, s).unwrap();
        let tau = arm.chain().gravity_torques(&d.qa, d.beta, load);
        for i in 0..JOINTS {
            let k = arm.joints[i].compliance * (1.0 + s * tau.joints[i].abs());
            assert!(
                (softened.joints[i].compliance - k).abs() < 1e-9,
                "joint {i}"
            );
        }
        assert!(
            (softened.base_compliance - arm.base_compliance * (1.0 + s * tau.base.abs())).abs()
                < 1e-9
        );
        // With those compliances the model's own fixed-point equation holds.
        assert!(softened.chain().fixed_point_residual(&q, load, &d) < 1e-9);
    }
}
