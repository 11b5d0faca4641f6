//! The targets of a comparison at the tool: random tool points the nominal
//! arm reaches clear of collisions, and each board's nominal joint targets
//! for them as `lrmcal move --xyz` solves them on that board.

use firmware::{CHANNELS, Config};
use model::{Arm, PerJoint};
use nalgebra::Vector3;
use protocol::{Calibration, CompensationMode};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::PositioningError;
use crate::device::commanded::Commanded;
use crate::ik::{self, IkError, IkOptions};
use crate::plan::PlanConfig;

/// Samples drawn per target wanted before giving up: most random poses are clear.
const SAMPLES_PER_TARGET: usize = 50;

/// One target: a tool point and each board's nominal joint targets for it.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// Where the tool is asked to go, world frame, m.
    pub point_m: Vector3<f64>,
    /// The nominal arm's joint targets for it, one per board (in the order
    /// of the boards), each nearest that board's previous target's, rad.
    pub q: Vec<PerJoint<f64>>,
}

/// The targets of a comparison, and how many random tool points were left
/// out because a board could not command any solution for them.
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    /// The targets, in visiting order.
    pub targets: Vec<Target>,
    /// Random tool points left out: some board's compensation could not
    /// reach them within its joint ranges and largest corrections.
    pub left_out: usize,
}

/// `count` random tool points the nominal arm reaches clear of collisions
/// within the joint ranges the board accepts without a calibration, each
/// with every board's nominal joint targets solved as `lrmcal move --xyz`
/// solves them on that board, on the nominal arm the board was sent:
/// nearest the pose of the board's target before (home, all zero, for the
/// first) among those its compensation (for `payload_kg`) can command. A
/// point some calibrated board cannot be sent to is left out for all.
pub fn targets(
    nominal: &Arm<f64>,
    count: usize,
    seed: u64,
    collisions: &PlanConfig,
    boards: &[(String, Option<Calibration>)],
    payload_kg: f64,
) -> Result<Targets, PositioningError> {
    if nominal.joints.len() > CHANNELS {
        return Err(PositioningError::TooManyJoints {
            joints: nominal.joints.len(),
        });
    }
    let config = Config::default();
    let board =
        firmware::servo::joint_limits(None, config.hard_limits_rad, config.default_limits_rad);
    let within_board = |nominal: &Arm<f64>| {
        let mut arm = *nominal;
        for (joint, [lo, hi]) in arm.joints.iter_mut().zip(&board) {
            joint.limits = [
                joint.limits[0].max(f64::from(*lo)),
                joint.limits[1].min(f64::from(*hi)),
            ];
        }
        arm
    };
    let arm = within_board(nominal);
    let chain = arm.chain();
    // Each board's targets are solved on the nominal arm it was sent, as
    // `move --xyz` solves them: a calibration's stands where the arm does.
    let board_arms: Vec<Arm<f64>> = boards
        .iter()
        .map(|(_, c)| {
            c.as_ref()
                .map_or(arm, |c| within_board(&c.nominal.map(f64::from)))
        })
        .collect();
    let options = IkOptions {
        collisions: Some(collisions.clone()),
        ..IkOptions::default()
    };
    let commanded: Vec<Option<Commanded>> = boards
        .iter()
        .map(|(_, c)| {
            c.as_ref()
                .map(|c| Commanded::new(c, CompensationMode::Full, payload_kg))
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut found = Vec::with_capacity(count);
    let mut left_out = 0;
    let mut from = vec![PerJoint::splat(arm.joints.len(), 0.0); boards.len().max(1)];
    let tries = count * SAMPLES_PER_TARGET;
    for _ in 0..tries {
        if found.len() == count {
            break;
        }
        let q = PerJoint::from_fn(arm.joints.len(), |i| {
            let [lo, hi] = arm.joints[i].limits;
            rng.random_range(lo..=hi)
        });
        if collisions.contact(&chain.frames(&q, 0.0)).is_some() {
            continue;
        }
        let point_m = chain.rigid_tool_point(&q);
        let mut solved = Vec::with_capacity(from.len());
        for (b, start) in from.iter().enumerate() {
            let calibrated = commanded.get(b).and_then(Option::as_ref);
            let admit = |q: &[f64]| match calibrated {
                Some(board) => board.command(q).map(drop).map_err(|r| r.to_string()),
                None => Ok(()),
            };
            let solved_on = board_arms.get(b).unwrap_or(&arm);
            match ik::solve_position_admitted(solved_on, &point_m, start, &options, &admit) {
                Ok(solution) => solved.push(solution.q),
                Err(IkError::Refused { .. }) => break,
                // A calibrated board's nominal arm stands where the arm does,
                // not quite where the point was drawn from: near the edge of
                // the reach it may not get there within its limits.
                Err(
                    IkError::BeyondReach { .. }
                    | IkError::OutOfReach { .. }
                    | IkError::OutsideLimits { .. }
                    | IkError::Colliding { .. },
                ) if calibrated.is_some() => break,
                Err(source) => {
                    return Err(PositioningError::Ik {
                        index: found.len(),
                        target_mm: (point_m * 1e3).into(),
                        source: Box::new(source),
                    });
                }
            }
        }
        if solved.len() < from.len() {
            left_out += 1;
            continue;
        }
        from.clone_from(&solved);
        found.push(Target { point_m, q: solved });
    }
    if found.len() < count {
        return Err(PositioningError::Targets {
            found: found.len(),
            wanted: count,
            tries,
        });
    }
    Ok(Targets {
        targets: found,
        left_out,
    })
}
