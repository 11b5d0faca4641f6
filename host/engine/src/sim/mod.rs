//! The digital twin the calibration is tested against: a seeded "true" arm
//! drawn around the nominal one, measured by a simulated tracker.
//!
//! ```text
//! nominal Arm + seed + SimConfig --TrueArm::draw--> TrueArm
//! TrueArm + passes (poses under a load) --simulate--> measurements (noisy) + noise-free positions
//! ```
//!
//! The true arm has errors on all 43 parameters of the method (DH, base,
//! tool, compliances), applied with [`model::ParamId`] and
//! [`model::Arm::with_errors`], and every position is computed by the
//! `model` crate. On top, each switchable (see [`SimConfig`]), it has what
//! the method's model does not: a smooth servo angle error (of one of two
//! shapes, [`ServoErrorShape`]), direction-dependent play, springs whose
//! stiffness changes with load ([`Spring`]: softening by default, in the
//! form the calibration model fits, or stiffening in a form it does not
//! contain), and tracker noise. With all four off
//! ([`SimConfig::model_only`]) a measurement is exactly the model's
//! prediction for the true arm.
//!
//! | module | what it holds |
//! |---|---|
//! | `config` | [`SimConfig`]: error sizes, effect switches and their defaults |
//! | `draw` | [`TrueArm::draw`]: the seeded true arm |
//! | `effects` | servo error, springs that soften or stiffen |
//! | `measure` | [`TrueArm::simulate`] / [`TrueArm::measure`] |
//! | [`positioning`] | the error at the tool when the board (the firmware library) drives the true arm |
//! | `truth` | the truth file (JSON): true arm and the 43 errors by name |
//! | `webcam` | [`Webcam`]: a camera watching the true arm's board, [`TrueArm::watch`] |
//! | [`render`] | the webcam's images of the board: lens, light, blur, noise |

mod config;
mod draw;
mod effects;
mod measure;
pub mod positioning;
pub mod render;
mod truth;
mod webcam;

pub use config::SimConfig;
pub use draw::TrueArm;
pub use effects::{
    Harmonic, ServoError, ServoErrorShape, Spring, softened_deflection, spring_deflection,
};
pub use measure::{Pass, Simulation};
pub use truth::TRUTH_SCHEMA;
pub use webcam::{DEFAULT_PIXEL_NOISE_PX, Watched, Webcam};

/// The seed `lrmcal simulate` and the demo use when none is given.
pub const DEFAULT_SEED: u64 = 1;

/// Why a simulation could not be run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A configuration value is out of its range.
    #[error("simulator setting `{field}`: expected {expected}, found {found}")]
    Config {
        /// The [`SimConfig`] field.
        field: &'static str,
        /// The allowed range in words, with units.
        expected: &'static str,
        /// The value given.
        found: String,
    },
    /// The nominal arm has a NaN or infinite number.
    #[error("the nominal arm has a non-finite number")]
    NominalNotFinite,
    /// Two poses share an id.
    #[error("pose id {pose} appears twice; expected unique pose ids")]
    DuplicatePose {
        /// The repeated id.
        pose: u32,
    },
    /// A pose has a NaN or infinite angle.
    #[error("pose {pose} has a non-finite joint angle")]
    NonFiniteAngle {
        /// The pose id.
        pose: u32,
    },
    /// A load is unusable.
    #[error("load {load_kg} kg: {reason}")]
    Load {
        /// The load given.
        load_kg: f64,
        /// What was expected.
        reason: &'static str,
    },
    /// The true arm's deflection could not be solved.
    #[error("simulate pose {pose} with {load_kg} kg: {reason}")]
    Model {
        /// The pose id.
        pose: u32,
        /// The load, kg.
        load_kg: f64,
        /// The model's error (`no_std`, so not a `std::error::Error` source).
        reason: model::DeflectionError,
    },
}

#[cfg(test)]
pub(crate) mod test_support {
    //! The bundled arm for the simulator's and planner's unit tests.

    /// The bundled LRM-like arm (`host/core/arms/lrm.toml`).
    pub fn bundled_arm() -> model::Arm<f64> {
        lrmcal_core::io::arm_source::bundled("lrm")
            .expect("the bundled arm parses")
            .arm
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lrmcal_core::dataset::Pose;
    use model::testing::TEST_ARM_JOINTS as JOINTS;
    use test_support::bundled_arm;

    fn grid_poses() -> Vec<Pose> {
        // A small deterministic spread of poses (the planner's grid is tested elsewhere).
        let levels = [-1.5, 0.0, 1.5];
        (0..729u32)
            .step_by(7)
            .map(|id| {
                let mut n = id;
                let q = model::PerJoint::from_fn(6, |_| {
                    let level = levels[(n % 3) as usize];
                    n /= 3;
                    level
                });
                Pose { id, q }
            })
            .collect()
    }

    #[test]
    fn with_every_effect_off_measurements_are_the_models_prediction_exactly() {
        let truth = TrueArm::draw(&bundled_arm(), 5, &SimConfig::model_only()).unwrap();
        let poses = grid_poses();
        let sim = truth.simulate(&poses, &[0.0, 0.0663]).unwrap();
        assert_eq!(sim.measurements, sim.noise_free);
        let chain = truth.arm.chain();
        for m in &sim.measurements {
            let expected = chain
                .tool_point(&m.pose.q, m.load_kg, &model::SolverOptions::default())
                .unwrap();
            assert_eq!(m.position, expected, "pose {}", m.pose.id);
        }
    }

    #[test]
    fn each_effect_changes_the_measurements() {
        let nominal = bundled_arm();
        let poses = grid_poses();
        let base = TrueArm::draw(&nominal, 5, &SimConfig::model_only())
            .unwrap()
            .measure(&poses, &[0.0663])
            .unwrap();
        let off = SimConfig::model_only();
        let on = SimConfig::default();
        for (name, config) in [
            (
                "servo error",
                SimConfig {
                    servo_error_rad: on.servo_error_rad,
                    ..off
                },
            ),
            (
                "backlash",
                SimConfig {
                    backlash_rad: on.backlash_rad,
                    ..off
                },
            ),
            (
                "softening",
                SimConfig {
                    softening_per_nm: on.softening_per_nm,
                    ..off
                },
            ),
            (
                "stiffening",
                SimConfig {
                    stiffening_per_nm: 0.3,
                    ..off
                },
            ),
            (
                "servo error with harmonics",
                SimConfig {
                    servo_error_rad: on.servo_error_rad,
                    servo_error_shape: ServoErrorShape::Harmonics,
                    ..off
                },
            ),
            (
                "noise",
                SimConfig {
                    noise_sigma_m: on.noise_sigma_m,
                    ..off
                },
            ),
        ] {
            let m = TrueArm::draw(&nominal, 5, &config)
                .unwrap()
                .measure(&poses, &[0.0663])
                .unwrap();
            let mean_mm = base
                .iter()
                .zip(&m)
                .map(|(a, b)| (a.position - b.position).norm())
                .sum::<f64>()
                / m.len() as f64
                * 1e3;
            // Each effect is of the order of a millimetre, never zero, never centimetres.
            assert!(
                (0.05..10.0).contains(&mean_mm),
                "{name}: mean change {mean_mm} mm"
            );
        }
    }

    /// The stiffening spring is solved exactly: each measurement without
    /// noise is the tool point of the deflection that satisfies the
    /// stiffening equation, and it sags less than the model's linear spring.
    #[test]
    fn stiffening_measurements_are_the_exact_stiffened_pose() {
        let config = SimConfig {
            stiffening_per_nm: 0.4,
            ..SimConfig::model_only()
        };
        let truth = TrueArm::draw(&bundled_arm(), 6, &config).unwrap();
        let linear = TrueArm::draw(&bundled_arm(), 6, &SimConfig::model_only()).unwrap();
        let poses = grid_poses();
        let sim = truth.simulate(&poses, &[0.0663]).unwrap();
        let lin = linear.measure(&poses, &[0.0663]).unwrap();
        let chain = truth.arm.chain();
        let (mut sag_stiff, mut sag_linear) = (0.0, 0.0);
        for (m, l) in sim.noise_free.iter().zip(&lin) {
            let (d, solved) = spring_deflection(
                &truth.arm,
                &m.pose.q,
                0.0663,
                Spring::Stiffening { per_nm: 0.4 },
            )
            .unwrap();
            assert_eq!(m.position, d.tool_point());
            assert!(solved.chain().fixed_point_residual(&m.pose.q, 0.0663, &d) < 1e-12);
            let rigid = chain.rigid_tool_point(&m.pose.q);
            sag_stiff += (m.position - rigid).norm();
            sag_linear += (l.position - rigid).norm();
        }
        assert!(sag_stiff < 0.95 * sag_linear, "{sag_stiff} vs {sag_linear}");
    }

    #[test]
    fn noise_has_the_configured_spread() {
        let config = SimConfig {
            noise_sigma_m: 0.3e-3,
            ..SimConfig::default()
        };
        let truth = TrueArm::draw(&bundled_arm(), 9, &config).unwrap();
        let sim = truth.simulate(&grid_poses(), &[0.0, 0.0663]).unwrap();
        let d: Vec<f64> = sim
            .measurements
            .iter()
            .zip(&sim.noise_free)
            .flat_map(|(a, b)| {
                (a.position - b.position)
                    .iter()
                    .copied()
                    .collect::<Vec<_>>()
            })
            .collect();
        let sigma = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
        assert!((sigma / 0.3e-3 - 1.0).abs() < 0.15, "sigma {sigma}");
    }

    #[test]
    fn simulation_is_deterministic_per_seed() {
        let nominal = bundled_arm();
        let poses = grid_poses();
        let a = TrueArm::draw(&nominal, 42, &SimConfig::default())
            .unwrap()
            .simulate(&poses, &[0.0663])
            .unwrap();
        let b = TrueArm::draw(&nominal, 42, &SimConfig::default())
            .unwrap()
            .simulate(&poses, &[0.0663])
            .unwrap();
        let c = TrueArm::draw(&nominal, 43, &SimConfig::default())
            .unwrap()
            .simulate(&poses, &[0.0663])
            .unwrap();
        assert_eq!(a, b);
        assert_ne!(a.measurements, c.measurements);
    }

    #[test]
    fn each_pass_draws_fresh_noise() {
        let config = SimConfig {
            noise_sigma_m: 0.2e-3,
            ..SimConfig::model_only()
        };
        let truth = TrueArm::draw(&bundled_arm(), 2, &config).unwrap();
        let poses = grid_poses();
        let sim = truth.simulate(&poses, &[0.0, 0.0663]).unwrap();
        let noise = |k: usize| sim.measurements[k].position - sim.noise_free[k].position;
        for k in 0..poses.len() {
            assert_ne!(noise(k), noise(poses.len() + k));
        }
    }

    #[test]
    fn play_makes_a_reading_depend_on_the_way_in() {
        let config = SimConfig {
            backlash_rad: 2f64.to_radians(),
            ..SimConfig::model_only()
        };
        let truth = TrueArm::draw(&bundled_arm(), 4, &config).unwrap();
        let target = Pose {
            id: 0,
            q: [0.2; JOINTS].into(),
        };
        let (below, above) = (
            Pose {
                id: 1,
                q: [-0.5; JOINTS].into(),
            },
            Pose {
                id: 2,
                q: [0.9; JOINTS].into(),
            },
        );
        let from_below = truth.measure(&[below, target], &[0.0]).unwrap()[1];
        let from_above = truth.measure(&[above, target], &[0.0]).unwrap()[1];
        let gap_mm = (from_below.position - from_above.position).norm() * 1e3;
        // Six joints, each 1..3 degrees apart between the two ways in, at lever arms up to
        // 0.54 m: at most 6 x 28 mm.
        assert!((0.5..60.0).contains(&gap_mm), "{gap_mm} mm");
        // Without play the way in does not matter.
        let exact = TrueArm::draw(&bundled_arm(), 4, &SimConfig::model_only()).unwrap();
        let a = exact.measure(&[below, target], &[0.0]).unwrap()[1];
        let b = exact.measure(&[above, target], &[0.0]).unwrap()[1];
        assert_eq!(a.position, b.position);
    }

    #[test]
    fn bad_poses_and_loads_are_named() {
        let truth = TrueArm::draw(&bundled_arm(), 1, &SimConfig::default()).unwrap();
        let p = Pose {
            id: 4,
            q: [0.0; JOINTS].into(),
        };
        let err = truth.measure(&[p, p], &[0.0]).unwrap_err();
        assert_eq!(err, SimError::DuplicatePose { pose: 4 });
        let err = truth.measure(&[p], &[-0.1]).unwrap_err().to_string();
        assert!(err.contains("-0.1") && err.contains(">= 0"), "{err}");
        let err = truth.measure(&[p], &[0.1, 0.1]).unwrap_err().to_string();
        assert!(err.contains("only once"), "{err}");
        let nan = Pose {
            id: 9,
            q: [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0].into(),
        };
        assert_eq!(
            truth.measure(&[nan], &[0.0]).unwrap_err(),
            SimError::NonFiniteAngle { pose: 9 }
        );
    }

    #[test]
    fn an_impossibly_soft_arm_reports_the_failing_pose() {
        let config = SimConfig {
            joint_compliance: [60.0, 60.0],
            ..SimConfig::model_only()
        };
        let truth = TrueArm::draw(&bundled_arm(), 1, &config).unwrap();
        let err = truth
            .measure(
                &[Pose {
                    id: 17,
                    q: [0.0, 1.5, 0.0, 0.0, 0.0, 0.0].into(),
                }],
                &[1.0],
            )
            .unwrap_err();
        assert!(matches!(err, SimError::Model { pose: 17, .. }), "{err:?}");
    }
}
