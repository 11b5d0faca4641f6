//! The effects of a real arm that the paper's model does not contain: a smooth
//! servo angle error, direction-dependent play, and springs whose stiffness
//! changes with load (softening, or stiffening in a form the model lacks).
//!
//! All three act through the model's public API: the first two change the
//! angle the joint is driven to before the model sees it, the third solves the
//! model's own deflection with compliances that depend on the torques the
//! model computes. No kinematics is written here.

use model::{Arm, Deflection, DeflectionError, SolverOptions};
use serde::{Deserialize, Serialize};

/// Which shape the simulator gives each servo's smooth angle error
/// ([`ServoError`]); its size is [`super::SimConfig::servo_error_rad`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ServoErrorShape {
    /// `A (u sin(w q + phi) + v (q / 100°)³)`: a bow over the travel and one
    /// slow wave (`w` 1.5..3 rad per rad, a period of 120°..240°). The default.
    #[default]
    SineCubic,
    /// `A Σ_{n=1..3} (u_n / n) sin(n w q + phi_n)`: the same slow wave with its
    /// second and third harmonics (periods down to 40°), amplitudes falling as
    /// `1/n` like a sawtooth's: a potentiometer track whose resistance is not
    /// uniform, with sharper features between the tuned points than a
    /// piecewise-linear curve with knots every 25° follows.
    Harmonics,
}

impl ServoErrorShape {
    /// Whether this is the default shape (left out of serialised settings).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// One harmonic of a servo's angle error: `amplitude sin(n omega q + phase)`
/// for the `n`-th harmonic of [`ServoError::omega`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Harmonic {
    /// Amplitude, rad.
    pub amplitude_rad: f64,
    /// Phase, rad.
    pub phase_rad: f64,
}

/// A servo's smooth angle error: `e(q) = sine sin(omega q + phase) + cubic
/// (q / 100°)³ + Σ_n harmonic_n sin(n omega q + phase_n)` for the second and
/// third harmonics `n = 2, 3`.
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
    /// The second and third harmonics of the sine ([`ServoErrorShape::Harmonics`]);
    /// zero amplitudes, and left out of the truth file, for the default shape.
    #[serde(default, skip_serializing_if = "no_harmonics")]
    pub harmonics: [Harmonic; 2],
}

/// Whether every harmonic's amplitude is 0.
fn no_harmonics(harmonics: &[Harmonic; 2]) -> bool {
    harmonics.iter().all(|h| h.amplitude_rad == 0.0)
}

impl ServoError {
    /// The angle error at commanded angle `q` (rad), rad.
    pub fn at(&self, q: f64) -> f64 {
        let x = q / 100f64.to_radians();
        let mut e =
            self.sine_rad * (self.omega * q + self.phase_rad).sin() + self.cubic_rad * x * x * x;
        for (n, h) in (2u32..).zip(&self.harmonics) {
            // Skipped when off, so the default shape's numbers stay bit for bit.
            if h.amplitude_rad != 0.0 {
                e += h.amplitude_rad * (f64::from(n) * self.omega * q + h.phase_rad).sin();
            }
        }
        e
    }
}

/// How a true spring's compliance depends on the torque it carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spring {
    /// `k`: the model's linear spring.
    Linear,
    /// `k (1 + s |tau|)`: more compliant under load, the form the
    /// calibration model fits (`model::Joint::softening`). `per_nm` is `s`, 1/Nm.
    Softening {
        /// `s`, 1/Nm, > 0.
        per_nm: f64,
    },
    /// `k / (1 + c |tau|)`: stiffer under load. The spring yields
    /// `k tau / (1 + c |tau|)`, which grows with the torque at the rate
    /// `k / (1 + c |tau|)²` (never negative) and never exceeds `k / c`: a drive
    /// that hardens as its mesh takes the load. Not the model's form: its
    /// `k (1 + s |tau|)` with `s < 0` falls linearly and stops yielding at
    /// `|tau| = 1/|s|`. `per_nm` is `c`, 1/Nm.
    Stiffening {
        /// `c`, 1/Nm, > 0.
        per_nm: f64,
    },
}

impl Spring {
    /// The compliance, rad/Nm, of a spring of compliance `k` (rad/Nm) at
    /// its linear limit, carrying `tau_nm`.
    pub fn compliance(self, k: f64, tau_nm: f64) -> f64 {
        match self {
            Self::Linear => k,
            Self::Softening { per_nm } => k * (1.0 + per_nm * tau_nm.abs()),
            Self::Stiffening { per_nm } => k / (1.0 + per_nm * tau_nm.abs()),
        }
    }
}

/// Largest change of any angle between two outer iterations of the spring
/// solve at which it counts as converged, rad.
const SPRING_TOLERANCE_RAD: f64 = 1e-13;
/// Outer iterations of the spring solve before giving up.
const SPRING_MAX_ITERATIONS: u32 = 100;

/// The deflection of `arm` driven to `q` under `payload_kg` when every
/// compliance `k` is really `k (1 + softening |tau|)` at its torque `tau`,
/// with the arm carrying the softened compliances of the solution: see
/// [`spring_deflection`].
pub fn softened_deflection(
    arm: &Arm<f64>,
    q: &[f64],
    payload_kg: f64,
    softening_per_nm: f64,
) -> Result<(Deflection<f64>, Arm<f64>), DeflectionError> {
    spring_deflection(
        arm,
        q,
        payload_kg,
        Spring::Softening {
            per_nm: softening_per_nm,
        },
    )
}

/// The deflection of `arm` driven to `q` under `payload_kg` when every
/// compliance `k` (each joint's and the base's) is really
/// `spring.compliance(k, tau)` at its torque `tau`, with the arm carrying
/// the compliances of the solution.
///
/// Solved by an outer fixed-point iteration around the model's own
/// deflection solve: set the compliances from the torques of the last
/// deflected pose, deflect again (warm-started), until no angle moves by
/// more than 1e-13 rad. At the fixed point `qa = q + k(tau(qa)) tau(qa)`
/// for every joint and the base tilt likewise.
pub fn spring_deflection(
    arm: &Arm<f64>,
    q: &[f64],
    payload_kg: f64,
    spring: Spring,
) -> Result<(Deflection<f64>, Arm<f64>), DeflectionError> {
    let options = SolverOptions::default();
    let mut solved = *arm;
    let mut deflection = arm.chain().deflect(q, payload_kg, &options)?;
    let mut last_step = f64::NAN;
    for _ in 0..SPRING_MAX_ITERATIONS {
        // Torques do not depend on the compliances, so any chain of this arm gives them.
        let tau = solved
            .chain()
            .gravity_torques(&deflection.qa, deflection.beta, payload_kg);
        for (i, joint) in solved.joints.iter_mut().enumerate() {
            joint.compliance = spring.compliance(arm.joints[i].compliance, tau.joints[i]);
        }
        solved.base_compliance = spring.compliance(arm.base_compliance, tau.base);
        let next = solved.chain().deflect_from(
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
        if last_step <= SPRING_TOLERANCE_RAD {
            return Ok((deflection, solved));
        }
    }
    Err(DeflectionError::NotConverged {
        iterations: SPRING_MAX_ITERATIONS,
        last_step,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_support::bundled_arm;
    use model::testing::TEST_ARM_JOINTS as JOINTS;

    #[test]
    fn servo_error_is_not_piecewise_linear() {
        let e = ServoError {
            sine_rad: 0.02,
            omega: 2.0,
            phase_rad: 0.3,
            cubic_rad: -0.01,
            harmonics: [Harmonic::default(); 2],
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
                cubic_rad: 0.0,
                harmonics: [Harmonic::default(); 2],
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

    #[test]
    fn harmonics_add_the_second_and_third_of_the_sine() {
        let plain = ServoError {
            sine_rad: 0.01,
            omega: 2.5,
            phase_rad: 0.4,
            cubic_rad: 0.0,
            harmonics: [Harmonic::default(); 2],
        };
        let rich = ServoError {
            harmonics: [
                Harmonic {
                    amplitude_rad: 0.004,
                    phase_rad: 1.0,
                },
                Harmonic {
                    amplitude_rad: 0.003,
                    phase_rad: -2.0,
                },
            ],
            ..plain
        };
        for q in [-1.7, -0.9, -0.2, 0.0, 0.35, 1.1, 1.74] {
            let expected = plain.at(q)
                + 0.004 * (2.0 * 2.5 * q + 1.0).sin()
                + 0.003 * (3.0 * 2.5 * q - 2.0).sin();
            assert!((rich.at(q) - expected).abs() < 1e-15, "q {q}");
        }
        // The third harmonic's period is a third of the sine's: it turns
        // within a 25° knot interval, where a piecewise-linear curve cannot.
        let (a, b) = (0.3, 0.3 + 25f64.to_radians());
        let chord = 0.5 * (rich.at(a) + rich.at(b));
        let mid_gap = (rich.at(0.5 * (a + b)) - chord).abs();
        let plain_gap = (plain.at(0.5 * (a + b)) - 0.5 * (plain.at(a) + plain.at(b))).abs();
        assert!(mid_gap > 2.0 * plain_gap, "{mid_gap} vs {plain_gap}");
    }

    #[test]
    fn spring_forms_give_their_compliance() {
        let k = 0.1;
        assert_eq!(Spring::Linear.compliance(k, -2.0), k);
        let soft = Spring::Softening { per_nm: 0.3 };
        assert!((soft.compliance(k, -2.0) - 0.16).abs() < 1e-15);
        let stiff = Spring::Stiffening { per_nm: 0.5 };
        assert!((stiff.compliance(k, -2.0) - 0.05).abs() < 1e-15);
        // The stiffening spring's yield grows with the torque, never beyond k / c.
        let mut last = 0.0;
        for step in 1..=200 {
            let tau = 0.25 * f64::from(step);
            let yielded = stiff.compliance(k, tau) * tau;
            assert!(yielded > last && yielded < k / 0.5, "tau {tau}");
            assert_eq!(stiff.compliance(k, -tau) * -tau, -yielded);
            last = yielded;
        }
    }

    /// A solved pose of an arm with stiffening springs: every joint's angle
    /// and the base tilt satisfy `qa = q + k tau / (1 + c |tau|)` at the
    /// torques of the solved pose itself.
    fn assert_stiffened_equation(arm: &Arm<f64>, q: &[f64; JOINTS], load: f64, c: f64) {
        let spring = Spring::Stiffening { per_nm: c };
        let (d, solved) = spring_deflection(arm, q, load, spring).unwrap();
        let tau = arm.chain().gravity_torques(&d.qa, d.beta, load);
        for (i, (joint, tau)) in arm.joints.iter().zip(tau.joints).enumerate() {
            let k = joint.compliance / (1.0 + c * tau.abs());
            let moved = d.qa[i] - q[i];
            assert!(
                (moved - k * tau).abs() < 1e-12,
                "joint {i}: {moved} vs {}",
                k * tau
            );
            assert!((solved.joints[i].compliance - k).abs() < 1e-12, "joint {i}");
        }
        let k0 = arm.base_compliance;
        let beta = k0 * tau.base / (1.0 + c * tau.base.abs());
        assert!((d.beta - beta).abs() < 1e-12, "{} vs {beta}", d.beta);
        assert!(solved.chain().fixed_point_residual(q, load, &d) < 1e-12);
    }

    #[test]
    fn stiffened_solution_satisfies_its_equation_and_sags_less() {
        let mut arm = bundled_arm();
        for j in &mut arm.joints {
            j.compliance = 0.15;
        }
        arm.base_compliance = 0.03;
        for (q, load) in [
            ([0.0, -1.3, 0.2, 0.0, 0.9, 0.0], 0.0663),
            ([0.4, 1.6, -1.2, 0.7, -1.5, 0.3], 0.0),
            ([-1.0, 1.74, 0.0, -1.7, 1.74, 1.0], 0.5),
        ] {
            for c in [0.3, 1.0, 5.0] {
                assert_stiffened_equation(&arm, &q, load, c);
            }
            // Stiffer than the linear spring, but it still yields.
            let rigid = arm.chain().rigid_tool_point(&q);
            let linear = arm
                .chain()
                .tool_point(&q, load, &SolverOptions::default())
                .unwrap();
            let (stiff, _) =
                spring_deflection(&arm, &q, load, Spring::Stiffening { per_nm: 0.5 }).unwrap();
            let sag = (stiff.tool_point() - rigid).norm();
            assert!(sag > 0.0 && sag < (linear - rigid).norm(), "{q:?}");
        }
    }

    #[test]
    fn softened_deflection_is_the_softening_spring() {
        let mut arm = bundled_arm();
        for j in &mut arm.joints {
            j.compliance = 0.1;
        }
        arm.base_compliance = 0.02;
        let q = [0.3, 1.2, 0.4, 0.2, -0.6, 0.1];
        let (a, arm_a) = softened_deflection(&arm, &q, 0.0663, 0.3).unwrap();
        let (b, arm_b) =
            spring_deflection(&arm, &q, 0.0663, Spring::Softening { per_nm: 0.3 }).unwrap();
        assert_eq!(
            (a.qa, a.beta, a.tool_point()),
            (b.qa, b.beta, b.tool_point())
        );
        assert_eq!(arm_a, arm_b);
    }
}
