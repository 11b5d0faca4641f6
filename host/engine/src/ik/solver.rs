//! One local solve from one start: damped least-squares steps onto the
//! target, then steps along the solutions towards the reference pose.
//!
//! Both kinds of step come from one linear problem: of the joint angles whose
//! linearised tool point moves by `shift`, take the one nearest a reference,
//! over the joints free to move, with the joints that would leave their
//! limits held at the limit (an active set, at most one pass per joint). With the
//! current pose as reference and the error as shift it is the minimum-norm
//! correction; with the pose to stay near as reference and no shift it is
//! the move along the solutions that removes all of `q − q_ref` the tool
//! point does not see. It is zero exactly at a locally nearest solution,
//! where `q − q_ref` is normal to the solutions (`q − q_ref = Jᵀ μ`).
//!
//! The moves along the solutions are taken inside a trust region and each is
//! followed by corrections back onto the target; a move is kept only if it
//! ends on the target and nearer the reference, so the distance never grows
//! and the solve cannot wander.

use model::{Chain, PerJoint};
use nalgebra::{Matrix3, Matrix3xX, Vector3};

/// Inclusive joint ranges a solve keeps to, rad, one per joint.
pub(super) type Limits = [[f64; 2]];

/// Least damping λ₀ of the least-squares steps, m: keeps a step finite at a
/// singular pose and, squared, biases a converged solution by ~1e-11 m.
const DAMPING_FLOOR_M: f64 = 1e-6;

/// Largest change of any joint in one step, rad: beyond this the
/// linearisation says little about where the tool point goes.
const MAX_STEP_RAD: f64 = 0.5;

/// A nearest-pose step shorter than this means the solve is there, rad.
const STATIONARY_RAD: f64 = 1e-10;

/// The damping of a correction grows by this factor after each step that
/// brought the tool point no nearer, up to [`MAX_DAMPING_GAIN`].
const DAMPING_GROWTH: f64 = 10.0;

/// Beyond this gain the correction steps are too short to matter: the tool
/// point is as near the target as it gets from here.
const MAX_DAMPING_GAIN: f64 = 1e12;

/// How one local solve is run.
#[derive(Clone, Copy, Debug)]
pub(super) struct Settings {
    /// On the target when the tool point is this close, m.
    pub tolerance_m: f64,
    /// Iterations allowed for the whole local solve, each one Jacobian and
    /// one forward evaluation.
    pub max_iterations: u32,
}

/// Where one local solve ended.
#[derive(Clone, Copy, Debug)]
pub(super) struct Local {
    /// Joint angles, rad, within the limits of the solve.
    pub q: PerJoint<f64>,
    /// Distance of the tool point from the target, m.
    pub error_m: f64,
}

/// Solves from `start`: onto the target, then as near `reference` as the
/// solutions around allow. Returns the poses it went through: where the
/// corrections ended (off the target if they could not get there), then
/// each pose on the target it stepped to, nearer `reference` each time; the
/// last is the answer, the others are kept for a caller that must reject
/// some (collisions).
pub(super) fn solve_from(
    chain: &Chain<f64>,
    target: &Vector3<f64>,
    start: &[f64],
    reference: &[f64],
    limits: &Limits,
    settings: Settings,
) -> Vec<Local> {
    let mut budget = settings.max_iterations;
    let start = clamp(start, limits);
    let corrected = correct(chain, target, start, limits, settings, &mut budget);
    let mut path = vec![corrected];
    if corrected.error_m <= settings.tolerance_m {
        path.extend(approach(
            chain,
            target,
            corrected,
            reference,
            limits,
            settings,
            &mut budget,
        ));
    }
    path
}

/// Damped least-squares (Levenberg–Marquardt) corrections of the tool point
/// onto the target from `q`, each the smallest joint change that does it.
///
/// The damping `λ² = g (|e|² + λ₀²)` fades with the error `e` (Sugihara's
/// choice), so near the target the steps are Newton steps; a step that does
/// not bring the tool point nearer is retried ten times more damped.
fn correct(
    chain: &Chain<f64>,
    target: &Vector3<f64>,
    q: PerJoint<f64>,
    limits: &Limits,
    settings: Settings,
    budget: &mut u32,
) -> Local {
    let mut best = Local {
        q,
        error_m: (target - chain.rigid_tool_point(&q)).norm(),
    };
    let mut gain = 1.0;
    // The linearisation at `best`, kept while steps from it are retried.
    let mut slope = None;
    while best.error_m > settings.tolerance_m && *budget > 0 && gain <= MAX_DAMPING_GAIN {
        *budget -= 1;
        let (tool, j) = slope.get_or_insert_with(|| position_jacobian(chain, &best.q));
        let (tool, j) = (*tool, &*j);
        let e = target - tool;
        let damping_sq = gain * (e.norm_squared() + DAMPING_FLOOR_M * DAMPING_FLOOR_M);
        let next = within_step(
            &best.q,
            nearest_step(j, &best.q, &e, &best.q, damping_sq, limits),
            MAX_STEP_RAD,
        );
        let error_m = (target - chain.rigid_tool_point(&next)).norm();
        if error_m < best.error_m {
            best = Local { q: next, error_m };
            slope = None;
            gain = (gain / DAMPING_GROWTH).max(1.0);
        } else {
            gain *= DAMPING_GROWTH;
        }
    }
    best
}

/// From a pose on the target, steps along the solutions towards
/// `reference`: a nearest-pose step inside the trust region, then
/// [`correct`] back onto the target. A step is kept if it ends on the target
/// and nearer `reference`, and the region grows; else the region shrinks.
/// Returns the poses kept, in order.
fn approach(
    chain: &Chain<f64>,
    target: &Vector3<f64>,
    on_target: Local,
    reference: &[f64],
    limits: &Limits,
    settings: Settings,
    budget: &mut u32,
) -> Vec<Local> {
    let mut kept = Vec::new();
    let mut current = on_target;
    let mut distance = joint_distance(&current.q, reference);
    let mut radius = MAX_STEP_RAD;
    while *budget > 0 && radius >= STATIONARY_RAD {
        *budget -= 1;
        // Along the solutions only (no shift of the tool point): a correction
        // of the error left within the tolerance would move the pose by more
        // than the last gains in distance are worth.
        let (_, j) = position_jacobian(chain, &current.q);
        let step = nearest_step(
            &j,
            &current.q,
            &Vector3::zeros(),
            reference,
            DAMPING_FLOOR_M * DAMPING_FLOOR_M,
            limits,
        );
        if max_change(&current.q, &step) < STATIONARY_RAD {
            break;
        }
        let stepped = within_step(&current.q, step, radius);
        let tried = correct(chain, target, stepped, limits, settings, budget);
        let tried_distance = joint_distance(&tried.q, reference);
        if tried.error_m <= settings.tolerance_m && tried_distance < distance {
            current = tried;
            distance = tried_distance;
            kept.push(current);
            radius = (radius * 2.0).min(MAX_STEP_RAD);
        } else {
            radius /= 4.0;
        }
    }
    kept
}

/// The joint angles nearest `reference` whose linearised tool point moves by
/// `shift` from the one at `q`, over the joints free to move; a joint that
/// would leave its limits is held at the limit and the rest solved again.
///
/// `j` is the position Jacobian at `q`; the free joints' change from the
/// reference is the damped minimum-norm `u = J_Fᵀ (J_F J_Fᵀ + λ² I)⁻¹ r` with
/// `r = shift + J_F (q_F − ref_F) − J_X (held_X − q_X)`.
fn nearest_step(
    j: &Matrix3xX<f64>,
    q: &[f64],
    shift: &Vector3<f64>,
    reference: &[f64],
    damping_sq: f64,
    limits: &Limits,
) -> PerJoint<f64> {
    let n = q.len();
    let mut held = PerJoint::splat(n, false);
    let mut next = PerJoint::from_fn(n, |i| q[i]);
    // Each pass either holds one more joint or ends; the last has none free.
    for _ in 0..=n {
        let mut free_j = j.clone();
        let mut rhs = *shift;
        for i in 0..n {
            if held[i] {
                rhs -= j.column(i) * (next[i] - q[i]);
                free_j.column_mut(i).fill(0.0);
            } else {
                rhs += j.column(i) * (q[i] - reference[i]);
            }
        }
        let normal = &free_j * free_j.transpose() + Matrix3::identity() * damping_sq;
        let Some(factor) = normal.cholesky() else {
            // Only a non-finite Jacobian gets here: stay put.
            return PerJoint::from_fn(n, |i| q[i]);
        };
        let u = free_j.transpose() * factor.solve(&rhs);
        let mut newly_held = false;
        for i in 0..n {
            if held[i] {
                continue;
            }
            let [lo, hi] = limits[i];
            let v = reference[i] + u[i];
            next[i] = v.clamp(lo, hi);
            if next[i] != v {
                held[i] = true;
                newly_held = true;
            }
        }
        if !newly_held {
            break;
        }
    }
    next
}

/// The tool point and its Jacobian at `q`, world frame: column `i` is
/// `zᵢ₋₁ × (p − oᵢ₋₁)`, joint `i` turning about the `z` axis of frame `i − 1`
/// through its origin (standard DH), the frames being the model's own.
pub(super) fn position_jacobian(chain: &Chain<f64>, q: &[f64]) -> (Vector3<f64>, Matrix3xX<f64>) {
    let frames = chain.frames(q, 0.0);
    let tool = frames.tool_point();
    let mut j = Matrix3xX::zeros(q.len());
    for (i, frame) in frames.frames[..q.len()].iter().enumerate() {
        let axis = frame.rotation.matrix().column(2).into_owned();
        j.set_column(i, &axis.cross(&(tool - frame.translation.vector)));
    }
    (tool, j)
}

/// `to`, or the point on the way from `from` to it where no joint has
/// changed by more than `max_rad`. Within the limits if both ends are.
fn within_step(from: &[f64], to: PerJoint<f64>, max_rad: f64) -> PerJoint<f64> {
    let change = max_change(from, &to);
    if change <= max_rad {
        return to;
    }
    let s = max_rad / change;
    PerJoint::from_fn(to.len(), |i| from[i] + (to[i] - from[i]) * s)
}

/// The largest change of any one joint from `a` to `b`, rad.
fn max_change(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Euclidean distance between two poses in joint space, rad.
pub(super) fn joint_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Each angle clamped into its joint's limits.
pub(super) fn clamp(q: &[f64], limits: &Limits) -> PerJoint<f64> {
    PerJoint::from_fn(q.len(), |i| q[i].clamp(limits[i][0], limits[i][1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_support::bundled_arm;
    use approx::assert_relative_eq;
    use model::testing::TEST_ARM_JOINTS as JOINTS;

    /// The analytic Jacobian is the central difference of the model's tool point.
    #[test]
    fn jacobian_matches_central_differences() {
        let chain = bundled_arm().chain();
        let q = [0.3, -0.7, 1.1, 0.4, -0.9, 2.0];
        let (tool, j) = position_jacobian(&chain, &q);
        assert_relative_eq!(tool, chain.rigid_tool_point(&q), epsilon = 1e-15);
        let h = 1e-6;
        for i in 0..JOINTS {
            let (mut plus, mut minus) = (q, q);
            plus[i] += h;
            minus[i] -= h;
            let column =
                (chain.rigid_tool_point(&plus) - chain.rigid_tool_point(&minus)) / (2.0 * h);
            assert_relative_eq!(j.column(i).into_owned(), column, epsilon = 1e-9);
        }
    }

    /// A step that would take a joint past its limit holds it there and
    /// still moves the linearised tool point by the shift with the others.
    #[test]
    fn a_held_joint_leaves_the_shift_to_the_others() {
        let chain = bundled_arm().chain();
        let q = [0.2, 0.5, 0.8, 0.1, 0.6, 0.0];
        let (_, j) = position_jacobian(&chain, &q);
        let shift = Vector3::new(0.0, 0.03, 0.0);
        let free = nearest_step(&j, &q, &shift, &q, 1e-16, &[[-3.0, 3.0]; JOINTS]);
        // Joint 1 (the base yaw) does most of a sideways shift; forbid it to move.
        assert!((free[0] - q[0]).abs() > 0.01);
        let mut limits = [[-3.0, 3.0]; JOINTS];
        limits[0] = [q[0] - 1e-3, q[0] + 1e-3];
        let held = nearest_step(&j, &q, &shift, &q, 1e-16, &limits);
        assert!(limits[0].contains(&held[0]), "{held:?}");
        let dq = nalgebra::Vector6::from_fn(|i, _| held[i] - q[i]);
        assert_relative_eq!(j * dq, shift, epsilon = 1e-9);
    }
}
