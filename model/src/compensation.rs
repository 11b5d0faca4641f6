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
//! `q = qa − K τ(qa, beta)`, with `beta = k0 τ0(qa, beta)` updated alongside.
//! The arm has 6 joints for 3 equations; of all deflected configurations that
//! reach the point, the iteration converges to the one closest to the nominal
//! command — the arm ends up shaped as nearly as possible as the user asked —
//! and so does not depend on the path or the warm start:
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

use nalgebra::{Matrix3, Matrix3x6, Vector3, Vector6};

use crate::elastic::{Deflection, DeflectionError};
use crate::kinematics::{Chain, ChainFrames};
use crate::{JOINTS, Real, real};

/// How many steps in a row may fail to reduce the error before the solve stops.
const MAX_REJECTIONS: u32 = 6;
/// Above this position error (m), a step removes only half of the null-space
/// offset from the nominal shape: all of it, with the large steps far from the
/// target, makes the solve oscillate where the null space turns quickly with
/// the pose. Close to the target the steps are small and remove all of it.
const HALF_PULL_ABOVE_M: f64 = 1e-4;

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
}

impl<T: Real> Default for CompensationOptions<T> {
    /// 1 µm, λ₀ = 1 µm, 10 iterations.
    fn default() -> Self {
        Self {
            tolerance_m: real(1e-6),
            damping_m: real(1e-6),
            max_iterations: 10,
        }
    }
}

/// The result of a compensation solve.
#[derive(Clone, Copy, Debug)]
pub struct Compensation<T: Real> {
    /// Joint angles to command, rad (not yet clamped to limits).
    pub q: [T; JOINTS],
    /// The deflected state of the calibrated arm commanded with `q`.
    pub deflection: Deflection<T>,
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
    /// The state as a result: command, deflection, error.
    pub state: Compensation<T>,
    /// Load moments at the state.
    moments: [Vector3<T>; JOINTS],
    /// `k0 τ0 − beta`, rad.
    beta_residual: T,
    /// Target minus tool point, m.
    error: Vector3<T>,
    /// The tilt residual's share of the error measure, m.
    tilt_error_m: T,
}

impl<T: Real> Chain<T> {
    /// Position Jacobian of the tool point w.r.t. the deflected joint angles, m/rad.
    pub fn position_jacobian(&self, f: &ChainFrames<T>) -> Matrix3x6<T> {
        let p = f.tool_point();
        let mut j = Matrix3x6::zeros();
        for i in 0..JOINTS {
            j.set_column(i, &f.joint_axis(i).cross(&(p - f.joint_origin(i))));
        }
        j
    }

    /// The state with deflected angles `qa` and base tilt `beta`: the command
    /// that produces it, `q = qa − K τ(qa, beta)`, and how far its tool point
    /// is from `target`. One pass of kinematics and gravity, no iteration.
    pub fn evaluate(
        &self,
        qa: [T; JOINTS],
        beta: T,
        target: &Vector3<T>,
        payload_kg: T,
        tolerance_m: T,
    ) -> Result<Evaluation<T>, DeflectionError> {
        let frames = self.frames(&qa, beta);
        let moments = self.load_moments(&frames, payload_kg);
        let tau = self.torques_from_moments(&frames, &moments);
        let beta_residual = self.base_compliance * tau.base - beta;
        let error = target - frames.tool_point();
        let lever = frames.tool_point() - frames.joint_origin(0);
        let tilt_error_m = beta_residual.abs() * lever.norm();
        let error_m = error.norm() + tilt_error_m;
        if !error_m.is_finite() {
            return Err(DeflectionError::NotFinite);
        }
        let state = Compensation {
            q: core::array::from_fn(|i| qa[i] - self.links[i].compliance * tau.joints[i]),
            deflection: Deflection {
                qa,
                beta,
                frames,
                iterations: 0,
            },
            error_m,
            iterations: 0,
            converged: error_m <= tolerance_m,
        };
        Ok(Evaluation {
            state,
            moments,
            beta_residual,
            error,
            tilt_error_m,
        })
    }

    /// Commands that bring this (calibrated) arm's deflected tool point to `target`,
    /// keeping its deflected joint angles as close as possible to `q_nominal`.
    ///
    /// `warm` is a previous solution to start from; without it the solve
    /// starts at the nominal command.
    pub fn compensate(
        &self,
        q_nominal: &[T; JOINTS],
        target: &Vector3<T>,
        payload_kg: T,
        warm: Option<&Compensation<T>>,
        options: &CompensationOptions<T>,
    ) -> Result<Compensation<T>, DeflectionError> {
        let (mut qa, mut beta) = match warm {
            Some(w) => (w.deflection.qa, w.deflection.beta),
            None => (*q_nominal, T::zero()),
        };
        // The last accepted state and the linear model of the error around it.
        let mut accepted: Option<(Compensation<T>, Linearisation<T>)> = None;
        let mut rejections = 0;
        let mut iterations = 0;
        loop {
            let evaluation = self.evaluate(qa, beta, target, payload_kg, options.tolerance_m)?;
            let mut current = evaluation.state;
            current.iterations = iterations;
            current.deflection.iterations = iterations;
            if current.converged {
                return Ok(current);
            }
            let lin = match accepted {
                // Worse than the accepted state (near singular or unreachable
                // targets): retry from there with a more strongly damped,
                // purely corrective step; out of tries, the accepted state is the answer.
                Some((best, lin)) if current.error_m > best.error_m => {
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
                    let lin = self.linearise(&evaluation, q_nominal);
                    accepted = Some((current, lin));
                    lin
                }
            };
            iterations += 1;
            (qa, beta) = lin
                .next_state(rejections, options.damping_m)
                .ok_or(DeflectionError::NotFinite)?;
        }
    }

    /// The linear model of the tool-point error around an evaluated state,
    /// with the base tilt's fixed point folded in.
    pub fn linearise(
        &self,
        evaluation: &Evaluation<T>,
        q_nominal: &[T; JOINTS],
    ) -> Linearisation<T> {
        let state = &evaluation.state;
        let (moments, beta_residual) = (&evaluation.moments, evaluation.beta_residual);
        let frames = &state.deflection.frames;
        // Base tilt, linearised: Δbeta = s (r + k0 ∂τ0/∂qa · Δqa).
        let g = self.gravity;
        let y0 = frames.base_tilt_axis();
        let g_cross_y0 = g.cross(&y0);
        let dtau0_dqa =
            Vector6::from_fn(|c, _| frames.joint_axis(c).cross(&moments[c]).dot(&g_cross_y0));
        let dtau0_dbeta = -y0.cross(&g).dot(&y0.cross(&moments[0]));
        let s = T::one() / (T::one() - self.base_compliance * dtau0_dbeta);
        let tilt_gain = dtau0_dqa * (s * self.base_compliance);
        let tilt_offset = s * beta_residual;
        let tilt_column = y0.cross(&(frames.tool_point() - frames.joint_origin(0)));
        let (qa, beta) = (state.deflection.qa, state.deflection.beta);
        let tool_error = evaluation.error;
        Linearisation {
            j: self.position_jacobian(frames) + tilt_column * tilt_gain.transpose(),
            error: tool_error - tilt_column * tilt_offset,
            tool_error,
            tilt_error_m: evaluation.tilt_error_m,
            error_m: state.error_m,
            delta: Vector6::from_fn(|i, _| qa[i] - q_nominal[i]),
            tilt_gain,
            tilt_offset,
            qa,
            beta,
        }
    }
}

/// The error around an evaluated state as a linear function of the change in `qa`.
#[derive(Clone, Copy, Debug)]
pub struct Linearisation<T: Real> {
    /// `∂e/∂qa` with the base tilt folded in, m/rad.
    j: Matrix3x6<T>,
    /// The error to remove, with the tilt residual's share taken out, m.
    error: Vector3<T>,
    /// Target minus tool point at the state, m.
    tool_error: Vector3<T>,
    /// The tilt residual's share of `error_m`, m.
    tilt_error_m: T,
    /// The state's error measure, m.
    error_m: T,
    /// Deflected angles minus nominal command at the state, rad.
    delta: Vector6<T>,
    /// `∂beta/∂qa` of the linearised tilt.
    tilt_gain: Vector6<T>,
    /// Change of beta that settles its residual at fixed `qa`, rad.
    tilt_offset: T,
    /// The state.
    qa: [T; JOINTS],
    /// The state's base tilt, rad.
    beta: T,
}

impl<T: Real> Linearisation<T> {
    /// The state's error measure, m (as [`Compensation::error_m`]).
    pub fn error_m(&self) -> T {
        self.error_m
    }

    /// The same state seen from a target moved by `target_shift` and a new
    /// nominal command: its tool point stays put, so its error is exact.
    pub fn retarget(&self, target_shift: &Vector3<T>, q_nominal: &[T; JOINTS]) -> Self {
        let tool_error = self.tool_error + target_shift;
        Self {
            error: self.error + target_shift,
            tool_error,
            error_m: tool_error.norm() + self.tilt_error_m,
            delta: Vector6::from_fn(|i, _| self.qa[i] - q_nominal[i]),
            ..*self
        }
    }

    /// The change of the base tilt that goes with a change `dqa` of the deflected angles, rad.
    pub fn tilt_change(&self, dqa: &[T; JOINTS]) -> T {
        self.tilt_gain.dot(&Vector6::from_column_slice(dqa))
    }

    /// The state to try next, deflected angles and base tilt, after one step
    /// (see [`Linearisation::step`]); `None` if the step is not finite.
    pub fn next_state(&self, rejections: u32, damping_m: T) -> Option<([T; JOINTS], T)> {
        let step = self.step(rejections, damping_m * damping_m)?;
        let qa = core::array::from_fn(|i| self.qa[i] + step[i]);
        Some((qa, self.beta + self.tilt_offset + self.tilt_gain.dot(&step)))
    }

    /// The change of `qa` to try.
    ///
    /// First try: reach the target and move the null-space part of `δ` to zero
    /// (`δ' = Jᵀ (J Jᵀ + λ²)⁻¹ (e + J δ)`; halfway only while the error exceeds
    /// `HALF_PULL_ABOVE_M`). After `rejections` failed tries:
    /// only reduce the error, with the damping multiplied by `4^rejections`; a
    /// damped Gauss–Newton step is a descent direction of `|e|²`, so this
    /// always makes progress once small enough.
    fn step(&self, rejections: u32, damping2: T) -> Option<Vector6<T>> {
        let mut lambda2 = self.error_m * self.error_m + damping2;
        for _ in 0..rejections {
            lambda2 *= real::<T>(4.0);
        }
        // J Jᵀ + λ² I is symmetric: six dot products, mirrored.
        let dot = |r: usize, c: usize| self.j.row(r).dot(&self.j.row(c));
        let (a01, a02, a12) = (dot(0, 1), dot(0, 2), dot(1, 2));
        #[rustfmt::skip]
        let jjt = Matrix3::new(
            dot(0, 0) + lambda2, a01, a02,
            a01, dot(1, 1) + lambda2, a12,
            a02, a12, dot(2, 2) + lambda2,
        );
        let cholesky = jjt.cholesky()?;
        Some(if rejections == 0 {
            let gain = if self.error_m > real(HALF_PULL_ABOVE_M) {
                real(0.5)
            } else {
                T::one()
            };
            let pull = self.delta * gain;
            self.j.transpose() * cholesky.solve(&(self.error + self.j * pull)) - pull
        } else {
            self.j.transpose() * cholesky.solve(&self.error)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ParamId;
    use crate::test_arms::{lrm_like_arm, random_q};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// A calibrated arm: the nominal one with errors on many parameters.
    fn perturbed(rng: &mut StdRng) -> crate::Arm<f64> {
        let ids: std::vec::Vec<ParamId> = ParamId::all().collect();
        let errors: std::vec::Vec<f64> = ids
            .iter()
            .map(|id| match id.kind() {
                crate::params::ParamKind::Length => rng.random_range(-0.003..0.003),
                crate::params::ParamKind::Angle => rng.random_range(-0.03..0.03),
                crate::params::ParamKind::Compliance => rng.random_range(0.0..0.05),
            })
            .collect();
        lrm_like_arm::<f64>().with_errors(&ids, &errors)
    }

    #[test]
    fn compensated_arm_reaches_the_nominal_point() {
        let mut rng = StdRng::seed_from_u64(3);
        let nominal = lrm_like_arm::<f64>().chain();
        let calibrated = perturbed(&mut rng).chain();
        // Cold starts from the nominal command need more iterations than a servo frame's warm start.
        let opts = CompensationOptions {
            ..Default::default()
        };
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
        let calibrated = perturbed(&mut rng).chain();
        let opts = CompensationOptions {
            tolerance_m: 1e-9,
            ..Default::default()
        };
        let q0 = [0.1, 0.5, -0.3, 0.2, 0.8, 0.0];
        let q1 = [0.12, 0.52, -0.31, 0.2, 0.79, 0.01];
        let t0 = nominal
            .tool_point(&q0, 0.0, &crate::SolverOptions::default())
            .unwrap();
        let t1 = nominal
            .tool_point(&q1, 0.0, &crate::SolverOptions::default())
            .unwrap();
        let first = calibrated.compensate(&q0, &t0, 0.0, None, &opts).unwrap();
        let warm = calibrated
            .compensate(&q1, &t1, 0.0, Some(&first), &opts)
            .unwrap();
        let cold = calibrated.compensate(&q1, &t1, 0.0, None, &opts).unwrap();
        assert!(warm.converged && cold.converged);
        for i in 0..6 {
            // The stop test looks at the position only, so what is left in the
            // null space differs by micro-radians; a path-dependent solve would
            // carry the previous frame's null-space offset (milliradians).
            assert!(
                (warm.q[i] - cold.q[i]).abs() < 1e-5,
                "joint {i}: {} vs {}",
                warm.q[i],
                cold.q[i]
            );
        }
    }
}
#[cfg(test)]
mod boundary_tests {
    use super::*;
    use crate::test_arms::lrm_like_arm;

    /// Out of reach (stretched arm, calibrated upper arm 4 mm shorter, rigid so
    /// the bound is exact): the solve reports no convergence and returns the
    /// closest command, 4 mm short, not garbage.
    #[test]
    fn unreachable_target_gives_the_closest_command_and_says_so() {
        let mut rigid = lrm_like_arm::<f64>();
        rigid.base_compliance = 0.0;
        rigid.joints.iter_mut().for_each(|j| j.compliance = 0.0);
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
}

#[cfg(test)]
mod jacobian_tests {
    use super::*;
    use crate::test_arms::lrm_like_arm;

    #[test]
    fn position_jacobian_matches_finite_differences() {
        let chain = lrm_like_arm::<f64>().chain();
        let qa = [-0.8, 0.65, -1.05, 1.6, 1.37, 1.7];
        let j = chain.position_jacobian(&chain.frames(&qa, 0.03));
        let h = 1e-6;
        for c in 0..JOINTS {
            let (mut qp, mut qm) = (qa, qa);
            qp[c] += h;
            qm[c] -= h;
            let numeric = (chain.frames(&qp, 0.03).tool_point()
                - chain.frames(&qm, 0.03).tool_point())
                / (2.0 * h);
            assert!((numeric - j.column(c)).norm() < 1e-8, "joint {c}");
        }
    }
}

#[cfg(test)]
mod linearisation_tests {
    use super::*;
    use crate::test_arms::lrm_like_arm;

    /// Seen from a moved target, the linear model's error is the state's exact
    /// error there, and its tilt gain predicts how the base tilt's fixed point moves.
    #[test]
    fn retarget_and_tilt_change_match_a_fresh_evaluation() {
        let chain = lrm_like_arm::<f64>().chain();
        let (qa, payload) = ([0.3, 0.7, -0.9, 0.4, 1.1, -0.2], 0.0663);
        let beta = chain
            .deflect(&qa, payload, &crate::SolverOptions::default())
            .unwrap()
            .beta;
        let t1 = chain.frames(&qa, beta).tool_point() + Vector3::new(0.002, -0.001, 0.003);
        let t2 = t1 + Vector3::new(-0.004, 0.002, 0.001);
        let q_nominal = [0.31, 0.69, -0.9, 0.41, 1.1, -0.2];
        let at = |t: &Vector3<f64>| chain.evaluate(qa, beta, t, payload, 1e-9).unwrap();
        let lin = chain.linearise(&at(&t1), &q_nominal);
        let moved = lin.retarget(&(t2 - t1), &q_nominal);
        assert!((moved.error_m() - at(&t2).state.error_m).abs() < 1e-12);

        // Move qa a little; the base tilt's own fixed point (with qa fixed) moves by tilt_change.
        let dqa = [1e-4, -2e-4, 1.5e-4, 0.0, 1e-4, 0.0];
        let qa2: [f64; 6] = core::array::from_fn(|i| qa[i] + dqa[i]);
        let fixed_beta = |qa: &[f64; 6]| {
            let mut b = beta;
            for _ in 0..50 {
                let f = chain.frames(qa, b);
                b = chain.base_compliance * chain.gravity_torques(&f, payload).base;
            }
            b
        };
        let change = fixed_beta(&qa2) - fixed_beta(&qa);
        let predicted = lin.tilt_change(&dqa);
        // First order: what is left is second order in dqa.
        assert!(
            (change - predicted).abs() < 0.01 * change.abs(),
            "{predicted:e} vs {change:e}"
        );
    }
}
