//! Fixtures for the engine's unit tests: the shared LRM-like test arm set up
//! so that every parameter is identifiable, and a few poses, so the tests stay
//! fast in debug builds. Integration tests use the bundled arm.

use model::testing::{ErrorSizes, lrm_like_arm, random_errors, random_q};
use model::{Arm, PARAM_COUNT};
use rand::{SeedableRng, rngs::StdRng};

use super::Sample;

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
pub fn true_errors(seed: u64) -> [f64; PARAM_COUNT] {
    let sizes = ErrorSizes {
        length_m: 2e-3,
        angle_rad: 0.02,
        compliance: 1e-2..2e-1,
    };
    random_errors(&mut StdRng::seed_from_u64(seed), &sizes)
}

/// `n` random poses within ±100°, alternating between no load and 66.3 g.
pub fn small_samples(n: usize) -> Vec<Sample> {
    let mut rng = StdRng::seed_from_u64(11);
    (0..n)
        .map(|i| Sample {
            id: i as u32,
            q: random_q(&mut rng),
            load_kg: if i % 2 == 0 { 0.0 } else { 0.0663 },
        })
        .collect()
}
