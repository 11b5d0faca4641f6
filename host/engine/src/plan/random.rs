//! Candidate poses off the grid: joint angles drawn uniformly over the tuned
//! range, kept when they pass the grid's own tests (limits, floor, bodies).
//!
//! Why: a servo's error between its tuned points only shows at angles between
//! them. On the -100/0/+100 grid every joint stands at a tuned point, so a
//! curve fitted there is free to be wrong everywhere else; a pool with poses
//! at every angle lets DETMAX choose poses that pin down the knots in between.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{PlanConfig, check_pose};
use lrmcal_core::dataset::Pose;
use model::{Arm, PerJoint};

/// Half the span of the angles drawn, degrees: the tuned range of the curves.
pub const RANGE_DEG: f64 = 100.0;

/// Draws at most 1000 tries per pose kept before giving up on a crowded arm.
const TRIES_PER_POSE: usize = 1000;

/// `count` random poses of `arm` that pass `config`'s tests, drawn with
/// `seed`, with ids from `first_id` on (after the grid's, so none collides).
/// Fewer when the arm is so crowded that most draws collide.
pub(super) fn random_poses(
    arm: &Arm<f64>,
    chain: &model::Chain<f64>,
    config: &PlanConfig,
    count: usize,
    seed: u64,
    first_id: u32,
) -> Vec<Pose> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let span = RANGE_DEG.to_radians();
    let mut out = Vec::with_capacity(count);
    for _ in 0..count.saturating_mul(TRIES_PER_POSE) {
        if out.len() == count {
            break;
        }
        let q = PerJoint::from_fn(arm.joints.len(), |j| {
            let [lo, hi] = arm.joints[j].limits;
            rng.random_range(lo.max(-span)..=hi.min(span))
        });
        if check_pose(arm, chain, config, &q).is_none() {
            out.push(Pose {
                id: first_id + out.len() as u32,
                q,
            });
        }
    }
    out
}
