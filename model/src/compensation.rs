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
//! with `e` the remaining position error and `λ² = |e|² + λ₀²` a damping that
//! keeps steps bounded near singular poses (Sugihara's Levenberg–Marquardt IK)
//! and fades with the error, so it does not bias the result. A step that
//! increases the error is halved (a few times at most), so near singular or
//! unreachable targets the solve ends at the closest state it found instead of
//! wandering; a warm-started servo frame almost never needs it. The base tilt is
//! solved in the same Newton step: linearising `beta = k0 τ0(qa, beta)` gives
//! `Δbeta` in terms of `Δqa`, which turns `J` and `e` into their rank-one
//! corrected forms, so both converge quadratically together.

use nalgebra::{Matrix3, Matrix3x6, Vector3, Vector6};

use crate::elastic::{Deflection, DeflectionError};
use crate::kinematics::{Chain, ChainFrames};
use crate::{JOINTS, Real, real};

/// How often a step that increased the error is halved before giving up.
const MAX_HALVINGS: u32 = 4;

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

    /// Commands that bring this (calibrated) arm's deflected tool point to `target`,
    /// keeping its deflected joint angles as close as possible to `q_nominal`.
    ///
    /// `warm` is a previous solution to start from (the previous servo frame's);
    /// without it the solve starts at the nominal command.
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
        let mut best: Option<Compensation<T>> = None;
        let mut halvings = 0;
        let mut iterations = 0;
        loop {
            let frames = self.frames(&qa, beta);
            let moments = self.load_moments(&frames, payload_kg);
            let tau = self.torques_from_moments(&frames, &moments);
            let beta_residual = self.base_compliance * tau.base - beta;
            let lever = frames.tool_point() - frames.joint_origin(0);
            let error = target - frames.tool_point();
            let error_m = error.norm() + beta_residual.abs() * lever.norm();
            if !error_m.is_finite() {
                return Err(DeflectionError::NotFinite);
            }
            let current = Compensation {
                q: core::array::from_fn(|i| qa[i] - self.links[i].compliance * tau.joints[i]),
                deflection: Deflection {
                    qa,
                    beta,
                    frames,
                    iterations,
                },
                error_m,
                iterations,
                converged: error_m <= options.tolerance_m,
            };
            if current.converged {
                return Ok(current);
            }
            // A step that makes things worse (near singular or unreachable
            // targets) is halved back towards the last accepted state; if that
            // does not help, the best state found is the answer.
            if let Some(accepted) = best
                && error_m > accepted.error_m
            {
                if halvings >= MAX_HALVINGS || iterations >= options.max_iterations {
                    return Ok(Compensation {
                        iterations,
                        ..accepted
                    });
                }
                halvings += 1;
                iterations += 1;
                let half: T = real(0.5);
                qa = core::array::from_fn(|i| (accepted.deflection.qa[i] + qa[i]) * half);
                beta = (accepted.deflection.beta + beta) * half;
                continue;
            }
            halvings = 0;
            best = Some(current);
            if iterations >= options.max_iterations {
                return Ok(current);
            }
            iterations += 1;
            // Base tilt, linearised: Δbeta = s (r + k0 ∂τ0/∂qa · Δqa).
            let g = self.gravity;
            let y0 = frames.base_tilt_axis();
            let g_cross_y0 = g.cross(&y0);
            let dtau0_dqa =
                Vector6::from_fn(|c, _| frames.joint_axis(c).cross(&moments[c]).dot(&g_cross_y0));
            let dtau0_dbeta = -y0.cross(&g).dot(&y0.cross(&moments[0]));
            let s = T::one() / (T::one() - self.base_compliance * dtau0_dbeta);
            let tilt_gain = dtau0_dqa * (s * self.base_compliance);
            let tilt_column = y0.cross(&lever);
            let j = self.position_jacobian(&frames) + tilt_column * tilt_gain.transpose();
            let error = error - tilt_column * (s * beta_residual);
            let delta = Vector6::from_fn(|i, _| qa[i] - q_nominal[i]);
            let lambda2 = error_m * error_m + options.damping_m * options.damping_m;
            let jjt = j * j.transpose() + Matrix3::identity() * lambda2;
            let solved = jjt
                .cholesky()
                .ok_or(DeflectionError::NotFinite)?
                .solve(&(error + j * delta));
            let next_delta = j.transpose() * solved;
            let step = next_delta - delta;
            qa = core::array::from_fn(|i| q_nominal[i] + next_delta[i]);
            beta += s * beta_residual + tilt_gain.dot(&step);
        }
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
