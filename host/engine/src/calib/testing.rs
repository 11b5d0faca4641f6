//! Fixtures for the engine's unit tests: the shared LRM-like test arm set up
//! so that every parameter is identifiable, and a few poses, so the tests stay
//! fast in debug builds. Integration tests use the bundled arm.

use model::testing::{ErrorSizes, TEST_ARM_PARAMS, lrm_like_arm, random_errors, random_q};
use model::{Arm, PerJoint};
use rand::{SeedableRng, rngs::StdRng};

use super::analysis::detmax::DetmaxOptions;
use super::fit::identify::{Diagnostics, Estimate, Identified, IdentifyOptions};
use super::fit::pipeline::{Choice, OptionResult, RunSettings};
use super::parameters::params::{ParamKey, ParamVector};
use super::progress::Silent;
use super::run::{Calibration, Request};
use super::{CalibError, ModelOption};
use super::{Rig, Sample};
use lrmcal_core::dataset::{Measurement, Pose};
use lrmcal_core::io::calibration_file::ErrorStats;

/// The shared LRM-like test arm ([`lrm_like_arm`]) on a slightly tilted base,
/// with the wrist's mass off its axis: gravity then loads every joint, so
/// every compliance (k1 and k6 too) has a torque to show itself by.
pub fn test_arm() -> Arm<f64> {
    let mut arm = lrm_like_arm::<f64>();
    arm.base.rpy = [0.01, -0.02, 0.0];
    arm.joints[5].com = [0.01, 0.005, -0.02];
    arm
}

/// The same arm with every compliance zero: a rigid nominal model.
pub fn rigid_nominal() -> Arm<f64> {
    let mut arm = test_arm();
    arm.base_compliance = 0.0;
    arm.base.rpy = [0.0; 3];
    for j in &mut arm.joints {
        j.compliance = 0.0;
    }
    arm
}

/// Errors of a "true" arm relative to [`rigid_nominal`]: mm and degree level
/// geometry, compliances 1e-2..2e-1 rad/Nm (the nominal arm's are zero).
pub fn true_errors(seed: u64) -> [f64; TEST_ARM_PARAMS] {
    let sizes = ErrorSizes {
        length_m: 2e-3,
        angle_rad: 0.02,
        compliance: 1e-2..2e-1,
    };
    random_errors(&mut StdRng::seed_from_u64(seed), &sizes)
}

/// `n` random poses within ±100°, alternating between no load and 66.3 g,
/// visited in order (each joint's approach follows it).
pub fn small_samples(n: usize) -> Vec<Sample> {
    let mut rng = StdRng::seed_from_u64(11);
    let qs: Vec<PerJoint<f64>> = (0..n).map(|_| random_q(&mut rng).into()).collect();
    qs.iter()
        .zip(lrmcal_core::dataset::approaches(&qs))
        .enumerate()
        .map(|(i, (q, approach))| Sample {
            id: i as u32,
            q: *q,
            load_kg: if i % 2 == 0 { 0.0 } else { 0.0663 },
            target: 0,
            approach,
        })
        .collect()
}

/// Exact measurements of `arm` at `samples` (no noise).
pub fn measure(arm: &Arm<f64>, samples: &[Sample]) -> Vec<Measurement> {
    measure_rig(&Rig::from(*arm), samples)
}

/// Exact measurements of `rig` at `samples`, each row naming its sample's target.
pub fn measure_rig(rig: &Rig, samples: &[Sample]) -> Vec<Measurement> {
    rig.tool_points(samples)
        .expect("the test arm deflects")
        .into_iter()
        .zip(samples)
        .map(|(position, s)| Measurement {
            pose: Pose { id: s.id, q: s.q },
            load_kg: s.load_kg,
            position,
            pixel: None,
            target: rig.targets.name_at(s.target),
            approach: s.approach,
        })
        .collect()
}

/// The load of [`elastic_run`]'s measurements, kg.
pub const LOAD_KG: f64 = 0.0663;

/// 30 poses of an arm whose compliances differ from [`rigid_nominal`]'s,
/// each measured exactly under [`LOAD_KG`]: (nominal, poses, measurements).
pub fn elastic_run() -> (Arm<f64>, Vec<Pose>, Vec<Measurement>) {
    let nominal = rigid_nominal();
    let keys = ["k2", "k3", "k4", "k5", "k6", "k0"].map(key);
    let mut truth = ParamVector::new(keys).expect("distinct keys");
    for (k, e) in keys.into_iter().zip([0.1, 0.05, 0.08, 0.03, 0.04, 0.02]) {
        truth.set(k, e).expect("held key");
    }
    let samples: Vec<Sample> = small_samples(30)
        .into_iter()
        .map(|s| Sample {
            load_kg: LOAD_KG,
            ..s
        })
        .collect();
    let poses = samples.iter().map(|s| Pose { id: s.id, q: s.q }).collect();
    (
        nominal,
        poses,
        measure(&truth.apply(&nominal.into()).arm, &samples),
    )
}

/// A DETMAX selection of 10 poses (two starts) under [`LOAD_KG`], no cross-load.
pub fn elastic_settings() -> RunSettings {
    RunSettings {
        identify_load_kg: LOAD_KG,
        other_load_kg: None,
        choice: Choice::Detmax(DetmaxOptions {
            n: 10,
            starts: 2,
            ..Default::default()
        }),
        identify: IdentifyOptions::default(),
    }
}

/// The parameter called `name`.
pub fn key(name: &str) -> ParamKey {
    ParamKey::from_name(name).expect("a parameter name")
}

/// `option` calibrated as `settings` say through the one calibration run,
/// from `measurements` of `nominal` taken in its file's world frame.
pub fn calibrate_in_arm_frame(
    nominal: &Arm<f64>,
    measurements: &[Measurement],
    option: ModelOption,
    settings: &RunSettings,
) -> Result<OptionResult, CalibError> {
    Calibration::open(&Request::new(nominal, measurements).load(settings.identify_load_kg))?
        .option(option, settings, &Silent)
}

/// A kinematic fit of [`test_arm`] that converged or not, with residual
/// RMS `before` and `after` (m), leave-one-out errors of mean `loo` spread by
/// ±`loo / 2` over 100 measurements, and `estimates`.
pub fn fitted(
    converged: bool,
    before: f64,
    after: f64,
    loo: f64,
    estimates: Vec<Estimate>,
) -> Identified {
    Identified {
        option: ModelOption::Kinematic,
        options: IdentifyOptions::default(),
        rig: Rig::from(test_arm()),
        estimates,
        diagnostics: Diagnostics {
            termination: if converged {
                "Converged"
            } else {
                "LostPatience"
            }
            .into(),
            converged,
            exhausted: !converged,
            evaluations: 10,
            active_set_rounds: 1,
            failed_steps: 0,
            irls_rounds: 1,
            at_bound: vec![],
            rms_before_m: before,
            rms_after_m: after,
            sigma_m: after,
            condition: 10.0,
            loo_mean_m: loo,
            // Each pose's error, the mean `loo`, spread by ±`loo / 2`.
            loo_errors_m: (0..100)
                .map(|k| loo * if k % 2 == 0 { 1.5 } else { 0.5 })
                .collect(),
        },
        fit_residual: ErrorStats::of(&[after; 100]),
        fit_residual_per_target: vec![ErrorStats::of(&[after; 100])],
        outliers: vec![],
        per_measurement: vec![],
        covariance: nalgebra::DMatrix::zeros(0, 0),
    }
}
