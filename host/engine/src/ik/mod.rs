//! Inverse kinematics of the tool point: the joint angles that put the
//! nominal, rigid arm's tool point on a target, nearest a given pose, within
//! the joint limits and clear of collisions; or why there are none.
//!
//! ```text
//! nominal Arm + target (world, m) + start pose --solve_position--> IkSolution | IkError (why not, with numbers)
//! ```
//!
//! The board compensates nominal joint targets, so the host solves the
//! *nominal* arm, rigid: deflection is the board's business. `lrmcal move
//! --xyz` and the demo's positioning figure both come through here. It is a
//! stage of its own rather than part of `plan` (which makes candidate grids)
//! and reuses the planner's collision test, [`PlanConfig::contact`].
//!
//! A point is three equations for six joints, so the solutions form a
//! three-dimensional family; the one wanted is the nearest the start pose in
//! joint space (Euclidean, rad), the arm moving as little as it can. Each
//! local solve gets onto the target by damped least squares and then walks
//! along the solutions to a locally nearest one (`solver`). It runs from the
//! start pose and from a fixed set of restarts spread over the joint ranges
//! (the same every call, so answers repeat). The nearest pose met on the
//! target and clear of collisions wins: where a solve ended, or, when that
//! collides, a pose it passed through on the way.
//!
//! When none is, the error says why: a target beyond the sum of the link
//! lengths at once; otherwise, from what the solves found, poses that reach
//! it but collide (which bodies), poses that reach it only with joints
//! beyond their limits (which, by how much; found by a second search with
//! the joints free), or the nearest point the arm does reach within its
//! limits.
//!
//! | file | what it holds |
//! |---|---|
//! | `mod.rs` | the options, the answer and its errors; restarts and the choice among local solves |
//! | `solver.rs` | one local solve: damped least squares onto the target, nearest-pose steps along it |

mod solver;

use std::f64::consts::{PI, TAU};
use std::fmt;

use model::{Arm, PerJoint};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use lrmcal_core::collision::Contact;

use crate::plan::{PlanConfig, PlanError};
use solver::{Limits, Local, Settings, joint_distance};

/// The restarts' random sequence: fixed, so the same target gives the same answer.
const RESTART_SEED: u64 = 0x1c0ffee;

/// How [`solve_position`] searches.
#[derive(Clone, Debug, PartialEq)]
pub struct IkOptions {
    /// On the target when the tool point is this close, m. Default 1e-9 (1e-6 mm).
    pub tolerance_m: f64,
    /// Iterations allowed per start, each one Jacobian and one forward
    /// evaluation. Default 300.
    pub max_iterations: u32,
    /// Starts besides the start pose, spread over the joint ranges. Default 16.
    pub restarts: usize,
    /// The planner's collision settings a solution must pass (bodies, ground,
    /// clearance; its grid levels are not used); `None` for no collision test.
    /// Default [`PlanConfig::default`]: ground at z = 0, 10 mm clearance.
    pub collisions: Option<PlanConfig>,
}

impl Default for IkOptions {
    fn default() -> Self {
        Self {
            tolerance_m: 1e-9,
            max_iterations: 300,
            restarts: 16,
            collisions: Some(PlanConfig::default()),
        }
    }
}

/// Joint angles that put the tool point on the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkSolution {
    /// Nominal joint angles, rad, within the arm's limits.
    pub q: PerJoint<f64>,
    /// Where the nominal arm puts its tool point at `q`, world frame, m.
    pub tool_m: Vector3<f64>,
    /// Distance of `tool_m` from the target, m (at most the tolerance).
    pub error_m: f64,
    /// Euclidean joint-space distance from the start pose, rad.
    pub distance_rad: f64,
}

/// A joint that a pose needs beyond one of its limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimitViolation {
    /// The joint, 1-based.
    pub joint: usize,
    /// The angle the pose needs, rad (the turn nearest the joint's range).
    pub angle_rad: f64,
    /// The limit it passes, rad.
    pub limit_rad: f64,
}

impl fmt::Display for LimitViolation {
    /// `joint 2 at 118.3° (limit 105.0°, 13.3° beyond)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "joint {} at {:.1}° (limit {:.1}°, {:.1}° beyond)",
            self.joint,
            self.angle_rad.to_degrees(),
            self.limit_rad.to_degrees(),
            (self.angle_rad - self.limit_rad).abs().to_degrees()
        )
    }
}

/// Why no joint angles are given for a target.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum IkError {
    /// The target, the start pose or the arm has a NaN or infinite number.
    NotFinite {
        /// Which of them.
        what: &'static str,
    },
    /// A search setting is out of range.
    Setting {
        /// The [`IkOptions`] field.
        field: &'static str,
        /// What is allowed.
        expected: &'static str,
        /// The value given.
        found: String,
    },
    /// The collision settings are out of range.
    Collisions(PlanError),
    /// A joint's limits are the wrong way round.
    Limits {
        /// The joint, 1-based.
        joint: usize,
    },
    /// The target is farther from the base than the links reach end to end.
    BeyondReach {
        /// From the origin of the arm's base frame to the target, m.
        distance_m: f64,
        /// The most the tool point can be from there, m ([`reach_m`]).
        reach_m: f64,
    },
    /// No pose within the limits reaches the target, nor any beyond them.
    OutOfReach {
        /// The nearest point the arm was found to reach within its limits, world frame, m.
        nearest_m: Vector3<f64>,
        /// Its distance from the target, m.
        residual_m: f64,
        /// The pose that reaches it, rad.
        q: PerJoint<f64>,
    },
    /// Poses reach the target, but only with joints beyond their limits.
    OutsideLimits {
        /// The joints beyond their limits in the pose that needs the least
        /// (smallest sum of overshoots), base to tip.
        violations: Vec<LimitViolation>,
        /// That pose, each angle the turn nearest its joint's range, rad.
        q: PerJoint<f64>,
    },
    /// Every pose found that reaches the target within the limits collides.
    Colliding {
        /// What they hit, each once, the nearest pose's first.
        contacts: Vec<Contact>,
        /// The pose nearest the start, rad.
        q: PerJoint<f64>,
    },
    /// Every clear pose found that reaches the target within the limits was
    /// refused by the caller's test (`solve_position_admitted`).
    Refused {
        /// Why the nearest one was refused.
        reason: String,
        /// That pose, rad.
        q: PerJoint<f64>,
        /// How many clear poses were tried.
        tried: usize,
    },
}

impl fmt::Display for IkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotFinite { what } => write!(f, "the {what} has a non-finite number"),
            Self::Setting {
                field,
                expected,
                found,
            } => write!(
                f,
                "inverse-kinematics setting `{field}`: expected {expected}, found {found}"
            ),
            Self::Collisions(e) => write!(f, "{e}"),
            Self::Limits { joint } => {
                write!(f, "joint {joint}'s lower limit is above its upper limit")
            }
            Self::BeyondReach {
                distance_m,
                reach_m,
            } => write!(
                f,
                "out of reach: the target is {:.1} mm from the arm's base, {:.1} mm beyond \
                 the {:.1} mm its links reach end to end",
                distance_m * 1e3,
                (distance_m - reach_m) * 1e3,
                reach_m * 1e3
            ),
            Self::OutOfReach {
                nearest_m,
                residual_m,
                ..
            } => write!(
                f,
                "out of reach: the nearest point the arm reaches within its joint limits is \
                 ({}, {}, {}) mm, {:.3} mm from the target",
                tenths(nearest_m.x * 1e3),
                tenths(nearest_m.y * 1e3),
                tenths(nearest_m.z * 1e3),
                residual_m * 1e3
            ),
            Self::OutsideLimits { violations, .. } => {
                let list: Vec<String> = violations.iter().map(ToString::to_string).collect();
                write!(
                    f,
                    "reachable only with joints beyond their limits: the pose needing the least \
                     has {}",
                    list.join(", ")
                )
            }
            Self::Colliding { contacts, q } => {
                let list: Vec<String> = contacts.iter().map(ToString::to_string).collect();
                write!(
                    f,
                    "every pose found that reaches it within the joint limits collides: {} \
                     (the nearest at {} deg)",
                    list.join("; "),
                    degrees(q)
                )
            }
            Self::Refused { reason, q, tried } => write!(
                f,
                "none of the {tried} clear poses found that reach it can be commanded: at the \
                 nearest ({} deg), {reason}",
                degrees(q)
            ),
        }
    }
}

impl std::error::Error for IkError {}

/// Angles in degrees for messages: `12.3, -45.0, …`.
fn degrees(q: &[f64]) -> String {
    let list: Vec<String> = q.iter().map(|a| tenths(a.to_degrees())).collect();
    list.join(", ")
}

/// `x` to one decimal, without the `-0.0` a tiny negative number would show.
fn tenths(x: f64) -> String {
    format!("{:.1}", (x * 10.0).round() / 10.0 + 0.0)
}

/// The farthest the tool point can be from the origin of the base frame, m:
/// the links end to end (`Σ √(aᵢ² + dᵢ²)` and the tool offset), an upper
/// bound reached only if the chain can stretch in one line.
pub fn reach_m(arm: &Arm<f64>) -> f64 {
    let links: f64 = arm.joints.iter().map(|j| j.a.hypot(j.d)).sum();
    links + Vector3::from(arm.tool.xyz).norm()
}

/// The nominal, rigid arm's joint angles that put its tool point on
/// `target_m` (world frame, m), nearest `start_q` (rad) in joint space,
/// within the joint limits and clear of the collisions in `options`.
///
/// Works without a board; the error says why there is no answer (see
/// [`IkError`]).
pub fn solve_position(
    arm: &Arm<f64>,
    target_m: &Vector3<f64>,
    start_q: &[f64],
    options: &IkOptions,
) -> Result<IkSolution, IkError> {
    solve_position_admitted(arm, target_m, start_q, options, &|_| Ok(()))
}

/// [`solve_position`] among the poses `admit` accepts (`Err` says why
/// not, e.g. the board's compensation would take a joint beyond its range):
/// the nearest clear pose it accepts, or [`IkError::Refused`] with the
/// nearest clear one's reason when it accepts none.
pub fn solve_position_admitted(
    arm: &Arm<f64>,
    target_m: &Vector3<f64>,
    start_q: &[f64],
    options: &IkOptions,
    admit: &dyn Fn(&[f64]) -> Result<(), String>,
) -> Result<IkSolution, IkError> {
    check(arm, target_m, start_q, options)?;
    let distance_m = (target_m - arm.base.isometry().translation.vector).norm();
    let reach_m = reach_m(arm);
    if distance_m > reach_m {
        return Err(IkError::BeyondReach {
            distance_m,
            reach_m,
        });
    }
    let chain = arm.chain();
    let settings = Settings {
        tolerance_m: options.tolerance_m,
        max_iterations: options.max_iterations,
    };
    let on_target = |l: &Local| l.error_m <= options.tolerance_m;
    let limits: Vec<[f64; 2]> = arm.joints.iter().map(|j| j.limits).collect();
    // Every pose met on the target is a candidate, not only where each solve
    // ended: when that collides, a pose it passed through may be clear.
    let within: Vec<Local> = search(
        &chain, target_m, start_q, &limits, &limits, settings, options,
    )
    .into_iter()
    .flatten()
    .collect();
    let mut candidates: Vec<Local> = within.iter().copied().filter(on_target).collect();
    // Nothing within the limits: search again with the joints free, to tell
    // limits from reach (and to catch a solution one turn away from the range).
    let mut beyond = Vec::new();
    if candidates.is_empty() {
        let free = vec![[f64::NEG_INFINITY, f64::INFINITY]; limits.len()];
        let turn = vec![[-PI, PI]; limits.len()];
        let ends = search(&chain, target_m, start_q, &free, &turn, settings, options)
            .into_iter()
            .filter_map(|path| path.last().copied());
        for local in ends.filter(on_target) {
            let q = PerJoint::from_fn(limits.len(), |i| nearest_turn(local.q[i], limits[i]));
            let violations = violations(&q, &limits);
            if violations.is_empty() {
                candidates.push(Local { q, ..local });
            } else {
                beyond.push((q, violations));
            }
        }
    }
    candidates
        .sort_by(|a, b| joint_distance(&a.q, start_q).total_cmp(&joint_distance(&b.q, start_q)));
    let mut contacts = Vec::new();
    let mut refused: Option<(String, PerJoint<f64>)> = None;
    let mut tried = 0;
    for c in &candidates {
        let contact = options
            .collisions
            .as_ref()
            .and_then(|config| config.contact(&chain.frames(&c.q, 0.0)));
        match contact {
            None => {
                tried += 1;
                match admit(&c.q) {
                    Ok(()) => {
                        return Ok(IkSolution {
                            q: c.q,
                            tool_m: chain.rigid_tool_point(&c.q),
                            error_m: c.error_m,
                            distance_rad: joint_distance(&c.q, start_q),
                        });
                    }
                    Err(reason) => {
                        refused.get_or_insert((reason, c.q));
                    }
                }
            }
            Some(contact) if !contacts.contains(&contact) => contacts.push(contact),
            Some(_) => {}
        }
    }
    if let Some((reason, q)) = refused {
        return Err(IkError::Refused { reason, q, tried });
    }
    if let Some(nearest) = candidates.first() {
        return Err(IkError::Colliding {
            contacts,
            q: nearest.q,
        });
    }
    let overshoot =
        |v: &[LimitViolation]| -> f64 { v.iter().map(|v| (v.angle_rad - v.limit_rad).abs()).sum() };
    if let Some((q, violations)) = beyond
        .into_iter()
        .min_by(|a, b| overshoot(&a.1).total_cmp(&overshoot(&b.1)))
    {
        return Err(IkError::OutsideLimits { violations, q });
    }
    // The nearest point found: no farther than where the start pose puts the tool.
    let start = solver::clamp(start_q, &limits);
    let from_start = Local {
        q: start,
        error_m: (target_m - chain.rigid_tool_point(&start)).norm(),
    };
    let best = within.into_iter().fold(
        from_start,
        |best, l| {
            if l.error_m < best.error_m { l } else { best }
        },
    );
    Err(IkError::OutOfReach {
        nearest_m: chain.rigid_tool_point(&best.q),
        residual_m: best.error_m,
        q: best.q,
    })
}

/// Refuses non-finite input and settings out of range.
fn check(
    arm: &Arm<f64>,
    target_m: &Vector3<f64>,
    start_q: &[f64],
    options: &IkOptions,
) -> Result<(), IkError> {
    if !target_m.iter().all(|x| x.is_finite()) {
        return Err(IkError::NotFinite { what: "target" });
    }
    if start_q.len() != arm.joints.len() {
        return Err(IkError::Setting {
            field: "start pose",
            expected: "one angle per joint of the arm",
            found: format!("{} angles for {} joints", start_q.len(), arm.joints.len()),
        });
    }
    if !start_q.iter().all(|x| x.is_finite()) {
        return Err(IkError::NotFinite { what: "start pose" });
    }
    if !arm.is_finite() {
        return Err(IkError::NotFinite { what: "arm" });
    }
    if !(options.tolerance_m.is_finite() && options.tolerance_m > 0.0) {
        return Err(IkError::Setting {
            field: "tolerance_m",
            expected: "a finite distance > 0 m",
            found: options.tolerance_m.to_string(),
        });
    }
    if options.max_iterations == 0 {
        return Err(IkError::Setting {
            field: "max_iterations",
            expected: "at least 1",
            found: "0".into(),
        });
    }
    if let Some(i) = arm.joints.iter().position(|j| j.limits[0] > j.limits[1]) {
        return Err(IkError::Limits { joint: i + 1 });
    }
    if let Some(config) = &options.collisions {
        config.check().map_err(IkError::Collisions)?;
    }
    Ok(())
}

/// One local solve from the start pose and one from each restart, all
/// pulled towards the start pose: the poses each went through
/// ([`solver::solve_from`]). `limits` bound the solves, `spread` the
/// restarts (finite where the limits are not).
fn search(
    chain: &model::Chain<f64>,
    target_m: &Vector3<f64>,
    start_q: &[f64],
    limits: &Limits,
    spread: &Limits,
    settings: Settings,
    options: &IkOptions,
) -> Vec<Vec<Local>> {
    let mut rng = ChaCha8Rng::seed_from_u64(RESTART_SEED);
    let n = start_q.len();
    let restarts = (0..options.restarts).map(|_| -> PerJoint<f64> {
        PerJoint::from_fn(n, |i| rng.random_range(spread[i][0]..=spread[i][1]))
    });
    std::iter::once(PerJoint::from_fn(n, |i| start_q[i]))
        .chain(restarts)
        .map(|start| solver::solve_from(chain, target_m, &start, start_q, limits, settings))
        .collect()
}

/// `angle` turned by whole turns to the representative nearest the range.
fn nearest_turn(angle: f64, [lo, hi]: [f64; 2]) -> f64 {
    let middle = 0.5 * (lo + hi);
    angle + ((middle - angle) / TAU).round() * TAU
}

/// The joints of `q` outside their limits, base to tip.
fn violations(q: &[f64], limits: &Limits) -> Vec<LimitViolation> {
    (0..q.len())
        .filter_map(|i| {
            let [lo, hi] = limits[i];
            let limit_rad = if q[i] < lo {
                lo
            } else if q[i] > hi {
                hi
            } else {
                return None;
            };
            Some(LimitViolation {
                joint: i + 1,
                angle_rad: q[i],
                limit_rad,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests;
