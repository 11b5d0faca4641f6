//! Compensation: the joint commands that make the calibrated, elastically
//! deflected arm put its tool point where the nominal arm would.
//!
//! Only the tool *point* is matched: it is what the calibration identifies
//! (tool orientation parameters are not identifiable from 3D points).
//!
//! The solve works on the *deflected* joint angles `qa`, not on the commands.
//! For given `qa` and base tilt `beta` the chain is rigid, so the position
//! Jacobian is exact and cheap, and the command that produces `qa` follows
//! from the elastic equation without any inner iteration:
//! `q = qa − K τ(qa, beta)`, with `beta = k0 τ0(qa, beta)` updated alongside
//! (each spring softening as the arm says: `k (1 + s |τ|) τ` for `k τ`, the
//! one model identification fits, see `crate::elastic`).
//! A 6-joint arm has 6 unknowns for 3 equations; of all deflected
//! configurations that reach the point, the iteration converges to the one
//! closest to the nominal command — the arm ends up shaped as nearly as
//! possible as the user asked — and so does not depend on the path or the
//! warm start. It stops only once that shape has settled too (a step would
//! move no joint by more than `settle_rad`), not at the first state whose tool
//! point is within tolerance, which a warm and a cold start reach at
//! different shapes:
//!
//! `δ ← Jᵀ (J Jᵀ + λ² I)⁻¹ (e + J δ)`, `qa = q_nominal + δ`,
//!
//! a Newton step on the position that also removes the part of `δ` the
//! position does not see (far from the target only half of it, see
//! `HALF_PULL_ABOVE_M`). `e` is the remaining position
//! error and `λ² = |e|² + λ₀²` a damping that
//! keeps steps bounded near singular poses (Sugihara's Levenberg–Marquardt IK)
//! and fades with the error, so it does not bias the result. A step that
//! increases the error (near singular or unreachable targets, where the pull
//! back to the nominal shape can fight the error) is retried from the last
//! accepted state as a purely corrective, more strongly damped step, a descent
//! direction of the error (Levenberg–Marquardt); the solve thus never ends
//! worse than it started and never wanders. The base tilt is
//! solved in the same Newton step: linearising `beta = k0 τ0(qa, beta)` gives
//! `Δbeta` in terms of `Δqa`, which turns `J` and `e` into their rank-one
//! corrected forms, so both converge quadratically together.
//!
//! | file | what it holds |
//! |---|---|
//! | `mod.rs` | evaluating a state, and the solve |
//! | `slope.rs` | the Jacobian with the tilt folded in |
//! | `linearisation.rs` | the linear model of a state's error and the step it gives |

mod linearisation;
mod slope;

pub use linearisation::Linearisation;
pub use slope::Slope;

use nalgebra::Vector3;

use crate::elastic::{DeflectionError, yield_of};
use crate::kinematics::{Chain, untilt};
use crate::statics::Statics;
use crate::{PerJoint, Real, real};

/// How many steps in a row may fail to reduce the error before the solve stops.
const MAX_REJECTIONS: u32 = 6;

/// Stopping rules and damping of the compensation solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompensationOptions<T> {
    /// Converged when the tool point is this close to the target, m, counting
    /// the effect of the base tilt's remaining residual on the tool point.
    pub tolerance_m: T,
    /// Floor λ₀ of the least-squares damping, m.
    pub damping_m: T,
    /// Give up after this many iterations.
    pub max_iterations: u32,
    /// With the tool point within tolerance, the solve goes on until a step
    /// would move no deflected joint by more than this, rad (m for a
    /// prismatic joint): the null-space part of the shape has then settled
    /// too, so where the solve ends does not depend on where it started.
    pub settle_rad: T,
}

impl<T: Real> CompensationOptions<T> {
    /// Whether the step from deflected angles `qa` to `next` moves no joint
    /// by more than [`settle_rad`](Self::settle_rad).
    pub fn settles(&self, qa: &[T], next: &[T]) -> bool {
        qa.iter()
            .zip(next)
            .all(|(a, b)| (*b - *a).abs() <= self.settle_rad)
    }
}

impl<T: Real> Default for CompensationOptions<T> {
    /// 1 µm, λ₀ = 1 µm, 10 iterations, shape settled to 1 µrad.
    fn default() -> Self {
        Self {
            tolerance_m: real(1e-6),
            damping_m: real(1e-6),
            max_iterations: 10,
            settle_rad: real(1e-6),
        }
    }
}

/// The result of a compensation solve.
#[derive(Clone, Copy, Debug)]
pub struct Compensation<T: Real> {
    /// Joint angles to command, rad (not yet clamped to limits).
    pub q: PerJoint<T>,
    /// The deflected joint angles of the calibrated arm commanded with `q`, rad.
    pub qa: PerJoint<T>,
    /// Its elastic base tilt, rad.
    pub beta: T,
    /// Remaining distance of the tool point from the target, m, plus the
    /// displacement the base tilt's remaining residual would cause.
    pub error_m: T,
    /// Iterations used.
    pub iterations: u32,
    /// Whether `error_m` reached the tolerance.
    pub converged: bool,
}

/// One state of the solve, evaluated: its command and its exact error, and
/// what linearising around it needs.
#[derive(Clone, Copy, Debug)]
pub struct Evaluation<T: Real> {
    /// The state as a result: command, deflected angles, error.
    pub state: Compensation<T>,
    /// The arm at the state, as each joint sees it.
    statics: Statics<T>,
    /// `k0 (1 + s0 |τ0|) τ0 − beta`, rad.
    beta_residual: T,
    /// Target minus tool point, frame 0, m.
    error: Vector3<T>,
    /// The tilt residual's share of the error measure, m.
    tilt_error_m: T,
    /// The tolerance `state.converged` was judged by, m.
    tolerance_m: T,
}

impl<T: Real> Chain<T> {
    /// The state with deflected angles `qa` and base tilt `beta`: the command
    /// that produces it, `q = qa − k (1 + s |τ|) τ` joint by joint, and how far its tool point
    /// is from `target`, given in the base frame ([`Chain::to_base`]).
    /// One sweep of [`Chain::statics`], no iteration.
    pub fn evaluate(
        &self,
        qa: &[T],
        beta: T,
        target: &Vector3<T>,
        payload_kg: T,
        tolerance_m: T,
    ) -> Result<Evaluation<T>, DeflectionError> {
        let statics = self.statics(qa, beta, payload_kg);
        let tau = statics.torques;
        let beta_residual = yield_of(self.base_compliance, self.base_softening, tau.base) - beta;
        // The tool point relative to the base, in frame 0, is also the tilt's lever.
        let lever = statics.tool_points[0];
        let error = untilt(target, statics.tilt_sin_cos) - lever;
        let tilt_error_m = beta_residual.abs() * lever.norm();
        let error_m = error.norm() + tilt_error_m;
        if !error_m.is_finite() {
            return Err(DeflectionError::NotFinite);
        }
        let state = Compensation {
            q: PerJoint::from_fn(qa.len(), |i| {
                let link = &self.links[i];
                qa[i] - yield_of(link.compliance, link.softening, tau.joints[i])
            }),
            qa: PerJoint::from_fn(qa.len(), |i| qa[i]),
            beta,
            error_m,
            iterations: 0,
            converged: error_m <= tolerance_m,
        };
        Ok(Evaluation {
            state,
            statics,
            beta_residual,
            error,
            tilt_error_m,
            tolerance_m,
        })
    }

    /// Commands that bring this (calibrated) arm's deflected tool point to
    /// `target` (world frame), keeping its deflected joint angles as close as
    /// possible to `q_nominal`.
    ///
    /// `warm` is a previous solution to start from; without it the solve
    /// starts at the nominal command.
    pub fn compensate(
        &self,
        q_nominal: &[T],
        target: &Vector3<T>,
        payload_kg: T,
        warm: Option<&Compensation<T>>,
        options: &CompensationOptions<T>,
    ) -> Result<Compensation<T>, DeflectionError> {
        let target = self.to_base(target);
        let (mut qa, mut beta) = match warm {
            Some(w) => (w.qa, w.beta),
            None => (
                PerJoint::from_fn(q_nominal.len(), |i| q_nominal[i]),
                T::zero(),
            ),
        };
        // The last accepted state and the linear model of the error around it.
        let mut accepted: Option<(Compensation<T>, Linearisation<T>)> = None;
        let mut rejections = 0;
        let mut iterations = 0;
        loop {
            let evaluation = self.evaluate(&qa, beta, &target, payload_kg, options.tolerance_m)?;
            let mut current = evaluation.state;
            current.iterations = iterations;
            let lin = match accepted {
                // Worse than the accepted state and off target (near singular or
                // unreachable targets): retry from there with a more strongly damped,
                // purely corrective step; out of tries, the accepted state is the answer.
                Some((best, lin)) if !current.converged && current.error_m > best.error_m => {
                    if rejections >= MAX_REJECTIONS || iterations >= options.max_iterations {
                        return Ok(Compensation { iterations, ..best });
                    }
                    rejections += 1;
                    lin
                }
                _ => {
                    if iterations >= options.max_iterations {
                        return Ok(current);
                    }
                    rejections = 0;
                    let slope = self.slope(&evaluation);
                    let lin = evaluation.with_slope(&slope, q_nominal);
                    accepted = Some((current, lin));
                    lin
                }
            };
            let (next_qa, next_beta) = lin
                .next_state(rejections, options.damping_m)
                .ok_or(DeflectionError::NotFinite)?;
            // On target, the step only pulls the shape towards the nominal one.
            if current.converged && options.settles(&qa, &next_qa) {
                return Ok(current);
            }
            iterations += 1;
            (qa, beta) = (next_qa, next_beta);
        }
    }
}

impl<T: Real> Evaluation<T> {
    /// The error measure of the state seen from a target moved by
    /// `target_shift` (base frame), m: `retarget(target_shift).state.error_m`.
    pub fn error_m_at(&self, target_shift: &Vector3<T>) -> T {
        self.error_at(target_shift).norm() + self.tilt_error_m
    }

    /// Target minus tool point for a target moved by `target_shift`, frame 0, m.
    fn error_at(&self, target_shift: &Vector3<T>) -> Vector3<T> {
        self.error + untilt(target_shift, self.statics.tilt_sin_cos)
    }

    /// The same state seen from a target moved by `target_shift` (base
    /// frame): its tool point stays put, so its error there is exact.
    pub fn retarget(&self, target_shift: &Vector3<T>) -> Self {
        let error = self.error_at(target_shift);
        let error_m = error.norm() + self.tilt_error_m;
        Self {
            state: Compensation {
                error_m,
                converged: error_m <= self.tolerance_m,
                ..self.state
            },
            error,
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ParamId;
    use crate::testing::TEST_ARM_JOINTS as JOINTS;
    use crate::testing::{ErrorSizes, lrm_like_arm, random_errors, random_q, rigid_lrm_like_arm};
    use rand::{SeedableRng, rngs::StdRng};

    /// A calibrated arm: the nominal one with errors on every parameter.
    fn perturbed(rng: &mut StdRng) -> crate::Arm<f64> {
        let ids: std::vec::Vec<ParamId> = ParamId::all(6).collect();
        lrm_like_arm::<f64>().with_errors(&ids, &random_errors(rng, &ErrorSizes::CALIBRATED))
    }

    #[test]
    fn compensated_arm_reaches_the_nominal_point() {
        let mut rng = StdRng::seed_from_u64(3);
        let nominal = lrm_like_arm::<f64>().chain();
        let calibrated = perturbed(&mut rng).chain();
        let opts = CompensationOptions::default();
        let mut solved = 0;
        while solved < 500 {
            let q: [f64; 6] = random_q(&mut rng);
            // Reachable: a straight elbow puts the nominal point at the edge of
            // the workspace, which a slightly shorter calibrated arm cannot reach.
            if q[2].abs() < 0.3 {
                continue;
            }
            solved += 1;
            let target = nominal
                .tool_point(&q, 0.0663, &crate::SolverOptions::default())
                .unwrap();
            let c = calibrated
                .compensate(&q, &target, 0.0663, None, &opts)
                .unwrap();
            assert!(
                c.converged,
                "error {} m after {} iterations at {q:?}",
                c.error_m, c.iterations
            );
        }
    }

    /// An arm with a compliant lift (a prismatic joint) and Hayati's twists,
    /// off by errors on every DH parameter and compliance, reaches the
    /// nominal point too: the slope's prismatic column and tilt response.
    #[test]
    fn a_lift_arm_with_twists_reaches_the_nominal_point() {
        use crate::testing::{LIFT_ARM_JOINTS, lift_arm, random_lift_q};
        let mut rng = StdRng::seed_from_u64(4);
        let nominal_arm = lift_arm::<f64>();
        let ids: std::vec::Vec<ParamId> = ParamId::all(LIFT_ARM_JOINTS).collect();
        let errors: std::vec::Vec<f64> = ids
            .iter()
            .map(|id| match id.kind() {
                crate::params::ParamKind::Compliance => 0.0,
                _ => rand::Rng::random_range(&mut rng, -2e-3..2e-3),
            })
            .collect();
        let mut calibrated = nominal_arm.with_errors(&ids, &errors);
        calibrated.joints[0].compliance = 5e-4;
        let (nominal, calibrated) = (nominal_arm.chain(), calibrated.chain());
        let opts = CompensationOptions::default();
        let mut solved = 0;
        while solved < 200 {
            let q: [f64; LIFT_ARM_JOINTS] = random_lift_q(&mut rng);
            if q[3].abs() < 0.3 {
                continue;
            }
            solved += 1;
            let target = nominal
                .tool_point(&q, 0.0663, &crate::SolverOptions::default())
                .unwrap();
            let c = calibrated
                .compensate(&q, &target, 0.0663, None, &opts)
                .unwrap();
            assert!(
                c.converged,
                "error {} m after {} iterations at {q:?}",
                c.error_m, c.iterations
            );
            let reached = calibrated
                .tool_point(&c.q, 0.0663, &crate::SolverOptions::default())
                .unwrap();
            assert!((reached - target).norm() < 2e-6, "{q:?}");
        }
    }

    /// The calibrated arm with every spring, the base's too, softening by `s` 1/Nm.
    fn softened(mut arm: crate::Arm<f64>, s: f64) -> crate::Arm<f64> {
        arm.base_softening = s;
        arm.joints.iter_mut().for_each(|j| j.softening = s);
        arm
    }

    /// With softening springs the commands put the softened arm, deflected as
    /// `crate::elastic` (identification's model) deflects it, on the target;
    /// a compensation for linear springs misses it.
    #[test]
    fn softened_arm_commanded_by_its_compensation_reaches_the_target() {
        let mut rng = StdRng::seed_from_u64(11);
        let nominal = lrm_like_arm::<f64>().chain();
        let arm = perturbed(&mut rng);
        let soft = softened(arm, 0.8).chain();
        let linear = arm.chain();
        let opts = CompensationOptions {
            tolerance_m: 1e-9,
            ..Default::default()
        };
        let solver = crate::SolverOptions {
            tolerance: 1e-13,
            ..Default::default()
        };
        let (mut solved, mut worst_linear) = (0, 0.0f64);
        while solved < 200 {
            let q: [f64; 6] = random_q(&mut rng);
            if q[2].abs() < 0.3 {
                continue;
            }
            solved += 1;
            let target = nominal.tool_point(&q, 0.0663, &solver).unwrap();
            let c = soft.compensate(&q, &target, 0.0663, None, &opts).unwrap();
            assert!(c.converged, "{q:?}: {c:?}");
            let reached = soft.tool_point(&c.q, 0.0663, &solver).unwrap();
            assert!(
                (reached - target).norm() < 1e-8,
                "{q:?}: {reached} vs {target}"
            );
            let l = linear.compensate(&q, &target, 0.0663, None, &opts).unwrap();
            let missed = soft.tool_point(&l.q, 0.0663, &solver).unwrap();
            worst_linear = worst_linear.max((missed - target).norm());
        }
        assert!(
            worst_linear > 1e-4,
            "linear springs' commands miss by {worst_linear:e} m"
        );
    }

    /// At zero softening the command is `qa − k τ` bit for bit, as it was for
    /// linear springs; any softening changes it where there is torque.
    #[test]
    fn zero_softening_is_the_linear_spring_bit_for_bit() {
        let arm = lrm_like_arm::<f64>();
        let (qa, beta, payload) = ([0.3, 0.7, -0.9, 0.4, 1.1, -0.2], 0.01, 0.0663);
        let target = Vector3::new(0.2, 0.1, 0.3);
        let linear = arm.chain();
        let state = linear.evaluate(&qa, beta, &target, payload, 1e-6).unwrap();
        let tau = linear.statics(&qa, beta, payload).torques;
        for (i, (joint, q)) in arm.joints.iter().zip(state.state.q).enumerate() {
            let expected = qa[i] - joint.compliance * tau.joints[i];
            assert_eq!(q.to_bits(), expected.to_bits(), "joint {i}");
        }
        assert_eq!(
            state.beta_residual.to_bits(),
            (arm.base_compliance * tau.base - beta).to_bits()
        );
        let soft = softened(arm, 1e-3).chain();
        let softened_state = soft.evaluate(&qa, beta, &target, payload, 1e-6).unwrap();
        // Joints under torque (joint 1's axis is vertical: none on it).
        for i in (0..JOINTS).filter(|&i| tau.joints[i].abs() > 1e-6) {
            assert_ne!(softened_state.state.q[i], state.state.q[i], "joint {i}");
        }
        assert_ne!(softened_state.beta_residual, state.beta_residual);
    }

    /// Whatever the pose (stretched, singular wrist, out of reach), the answer
    /// is never further from the target than the nominal command was.
    #[test]
    fn compensation_never_ends_worse_than_it_started() {
        let mut rng = StdRng::seed_from_u64(9);
        let nominal = lrm_like_arm::<f64>().chain();
        let calibrated = perturbed(&mut rng).chain();
        let opts = CompensationOptions::default();
        for k in 0..500 {
            let mut q: [f64; 6] = random_q(&mut rng);
            if k % 3 == 0 {
                q[2] = 0.0; // straight elbow: the edge of the workspace
            }
            if k % 5 == 0 {
                q[4] = 0.0; // wrist singularity
            }
            let target = nominal
                .tool_point(&q, 0.0663, &crate::SolverOptions::default())
                .unwrap();
            let start = CompensationOptions {
                max_iterations: 0,
                ..opts
            };
            let initial = calibrated
                .compensate(&q, &target, 0.0663, None, &start)
                .unwrap();
            let c = calibrated
                .compensate(&q, &target, 0.0663, None, &opts)
                .unwrap();
            assert!(
                c.error_m <= initial.error_m,
                "{q:?}: {} > {}",
                c.error_m,
                initial.error_m
            );
        }
    }

    #[test]
    fn warm_start_gives_the_same_command_as_a_cold_start() {
        let mut rng = StdRng::seed_from_u64(4);
        let nominal = lrm_like_arm::<f64>().chain();
        let perturbed = perturbed(&mut rng);
        let opts = CompensationOptions::default();
        let q0 = [0.1, 0.5, -0.3, 0.2, 0.8, 0.0];
        let q1 = [0.12, 0.52, -0.31, 0.2, 0.79, 0.01];
        let t0 = nominal
            .tool_point(&q0, 0.0, &crate::SolverOptions::default())
            .unwrap();
        let t1 = nominal
            .tool_point(&q1, 0.0, &crate::SolverOptions::default())
            .unwrap();
        // Also with the parallel shoulder and elbow twisted (Hayati's β).
        for beta in [0.0, 0.004, -0.01] {
            let mut arm = perturbed;
            arm.joints[1].beta = beta;
            let calibrated = arm.chain();
            let first = calibrated.compensate(&q0, &t0, 0.0, None, &opts).unwrap();
            let warm = calibrated
                .compensate(&q1, &t1, 0.0, Some(&first), &opts)
                .unwrap();
            let cold = calibrated.compensate(&q1, &t1, 0.0, None, &opts).unwrap();
            assert!(warm.converged && cold.converged);
            for i in 0..6 {
                // Both end once the shape has settled to `settle_rad`; stopping at
                // the first state on target would keep the previous solution's
                // null-space offset (tens of microradians here).
                assert!(
                    (warm.q[i] - cold.q[i]).abs() < 1e-5,
                    "β {beta}, joint {i}: {} vs {}",
                    warm.q[i],
                    cold.q[i]
                );
            }
        }
    }

    /// Out of reach (stretched arm, calibrated upper arm 4 mm shorter, rigid so
    /// the bound is exact): the solve reports no convergence and returns the
    /// closest command, 4 mm short, not garbage.
    #[test]
    fn unreachable_target_gives_the_closest_command_and_says_so() {
        let rigid = rigid_lrm_like_arm();
        let nominal = rigid.chain();
        let mut short = rigid;
        short.joints[1].a -= 0.004;
        let short = short.chain();
        let q = [0.3, 0.8, 0.0, 0.0, 0.0, 0.0];
        let target = nominal.rigid_tool_point(&q);
        let c = short
            .compensate(&q, &target, 0.0, None, &CompensationOptions::default())
            .unwrap();
        assert!(!c.converged);
        assert!(
            (c.error_m - 0.004).abs() < 1e-4,
            "closest approach {:e} m",
            c.error_m
        );
        assert!(c.q.iter().zip(&q).all(|(a, b)| (a - b).abs() < 0.2));
    }

    /// With a stiff base the slope is the position Jacobian: each column is
    /// how the tool point moves in frame 0 when its joint turns.
    #[test]
    fn slope_of_a_stiff_base_is_the_jacobian() {
        let mut arm = lrm_like_arm::<f64>();
        arm.base_compliance = 0.0;
        let chain = arm.chain();
        let (qa, beta) = ([-0.8, 0.65, -1.05, 1.6, 1.37, 1.7], 0.03);
        let evaluation = chain
            .evaluate(&qa, beta, &Vector3::zeros(), 0.05, 1e-6)
            .unwrap();
        let j = chain.slope(&evaluation).j;
        let in_frame0 = |qa: &[f64; 6]| chain.statics(qa, beta, 0.05).tool_points[0];
        let h = 1e-6;
        for c in 0..JOINTS {
            let (mut qp, mut qm) = (qa, qa);
            qp[c] += h;
            qm[c] -= h;
            let numeric = (in_frame0(&qp) - in_frame0(&qm)) / (2.0 * h);
            assert!((numeric - j.column(c)).norm() < 1e-8, "joint {c}");
        }
    }

    /// Seen from a moved target, a state's error is the one a fresh evaluation
    /// there gives, and its slope's tilt gain predicts how the base tilt's fixed
    /// point moves, with linear, softening and stiffening springs.
    #[test]
    fn retarget_and_tilt_change_match_a_fresh_evaluation() {
        for s in [0.0, 0.8, -0.05] {
            retarget_and_tilt_change_with_softening(s);
        }
    }

    fn retarget_and_tilt_change_with_softening(softening: f64) {
        let chain = softened(lrm_like_arm::<f64>(), softening).chain();
        let (qa, payload) = ([0.3, 0.7, -0.9, 0.4, 1.1, -0.2], 0.0663);
        let beta = chain
            .deflect(&qa, payload, &crate::SolverOptions::default())
            .unwrap()
            .beta;
        let t1 = chain.frames(&qa, beta).tool_point() + Vector3::new(0.002, -0.001, 0.003);
        let t2 = t1 + Vector3::new(-0.004, 0.002, 0.001);
        let at = |t: &Vector3<f64>| {
            chain
                .evaluate(&qa, beta, &chain.to_base(t), payload, 1e-9)
                .unwrap()
        };
        let moved = at(&t1).retarget(&(chain.to_base(&t2) - chain.to_base(&t1)));
        assert!((moved.state.error_m - at(&t2).state.error_m).abs() < 1e-12);

        // Move qa a little; the base tilt's own fixed point (with qa fixed) moves by tilt_change.
        let dqa = [1e-4, -2e-4, 1.5e-4, 0.0, 1e-4, 0.0];
        let qa2: [f64; 6] = core::array::from_fn(|i| qa[i] + dqa[i]);
        let fixed_beta = |qa: &[f64; 6]| {
            let mut b = beta;
            for _ in 0..50 {
                let tau0 = chain.gravity_torques(qa, b, payload).base;
                b = yield_of(chain.base_compliance, chain.base_softening, tau0);
            }
            b
        };
        let change = fixed_beta(&qa2) - fixed_beta(&qa);
        let predicted = chain.slope(&at(&t1)).tilt_change(&dqa);
        // First order: what is left is second order in dqa.
        assert!(
            (change - predicted).abs() < 0.01 * change.abs(),
            "softening {softening}: {predicted:e} vs {change:e}"
        );
    }
}
