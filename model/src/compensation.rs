//! Compensation: the joint commands that make the calibrated, elastically
//! deflected arm put its tool point where the nominal arm would.
//!
//! Only the tool *point* is matched. It is what the calibration identifies (tool
//! orientation parameters are not identifiable from 3D points), and a 3×3
//! solve per iteration fits the MCU's budget. The arm has 6 joints for 3
//! equations; of all commands that reach the point, the iteration converges to
//! the one closest (in joint space) to the nominal command, so the solution
//! does not depend on the path or on the warm start:
//!
//! `δ ← Jᵀ (J Jᵀ + λ² I)⁻¹ (e + J δ)`, `q = q_nominal + δ`,
//!
//! with `J` the position Jacobian of the deflected chain (the coupling of the
//! deflection to the command is neglected: it only slows convergence), `e` the
//! remaining position error and `λ² = |e|² + λ₀²` a damping that keeps steps
//! bounded near singular poses (Sugihara's Levenberg–Marquardt IK) and fades as
//! the error does, so it does not bias the converged command.

use nalgebra::{Matrix3, Matrix3x6, Vector3, Vector6};

use crate::elastic::{Deflection, DeflectionError, SolverOptions};
use crate::kinematics::Chain;
use crate::{JOINTS, Real, real};

/// Stopping rules and damping of the compensation solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompensationOptions<T> {
    /// Converged when the tool point is this close to the target, m.
    pub tolerance_m: T,
    /// Floor λ₀ of the least-squares damping, m.
    pub damping_m: T,
    /// Give up after this many iterations.
    pub max_iterations: u32,
    /// Options of the inner deflection solve.
    pub deflection: SolverOptions<T>,
}

impl<T: Real> Default for CompensationOptions<T> {
    /// 1 µm, λ₀ = 1 µm, 10 iterations.
    fn default() -> Self {
        Self {
            tolerance_m: real(1e-6),
            damping_m: real(1e-6),
            max_iterations: 10,
            deflection: SolverOptions::default(),
        }
    }
}

/// The result of a compensation solve.
#[derive(Clone, Copy, Debug)]
pub struct Compensation<T: Real> {
    /// Joint angles to command, rad (not yet clamped to limits).
    pub q: [T; JOINTS],
    /// The deflected state of the calibrated arm at `q`.
    pub deflection: Deflection<T>,
    /// Remaining distance of the tool point from the target, m.
    pub error_m: T,
    /// Iterations used.
    pub iterations: u32,
    /// Whether `error_m` reached the tolerance.
    pub converged: bool,
}

impl<T: Real> Chain<T> {
    /// Position Jacobian of the tool point w.r.t. the actual joint angles, at the given state.
    pub fn position_jacobian(&self, d: &Deflection<T>) -> Matrix3x6<T> {
        let p = d.tool_point();
        let mut j = Matrix3x6::zeros();
        for i in 0..JOINTS {
            let col = d.frames.joint_axis(i).cross(&(p - d.frames.joint_origin(i)));
            j.set_column(i, &col);
        }
        j
    }

    /// Commands that bring this (calibrated) arm's deflected tool point to `target`,
    /// staying as close as possible to `q_nominal`.
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
        let (mut q, mut guess) = match warm {
            Some(w) => (w.q, (w.deflection.qa, w.deflection.beta)),
            None => (*q_nominal, (*q_nominal, T::zero())),
        };
        let mut iterations = 0;
        loop {
            let deflection = self.deflect_from(&q, payload_kg, guess, &options.deflection)?;
            let error = target - deflection.tool_point();
            let error_m = error.norm();
            let converged = error_m <= options.tolerance_m;
            if converged || iterations >= options.max_iterations {
                return Ok(Compensation { q, deflection, error_m, iterations, converged });
            }
            iterations += 1;
            let j = self.position_jacobian(&deflection);
            let delta = Vector6::from_fn(|i, _| q[i] - q_nominal[i]);
            let rhs = error + j * delta;
            let lambda2 = error_m * error_m + options.damping_m * options.damping_m;
            let jjt = j * j.transpose() + Matrix3::identity() * lambda2;
            let Some(solved) = jjt.cholesky().map(|c| c.solve(&rhs)) else {
                return Err(DeflectionError::NotFinite);
            };
            let next_delta = j.transpose() * solved;
            let step: [T; JOINTS] = core::array::from_fn(|i| q_nominal[i] + next_delta[i] - q[i]);
            guess = (core::array::from_fn(|i| deflection.qa[i] + step[i]), deflection.beta);
            q = core::array::from_fn(|i| q[i] + step[i]);
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
        let opts = CompensationOptions { max_iterations: 60, ..Default::default() };
        for _ in 0..500 {
            let q: [f64; 6] = random_q(&mut rng);
            let target = nominal.tool_point(&q, 0.0663, &opts.deflection).unwrap();
            let c = calibrated.compensate(&q, &target, 0.0663, None, &opts).unwrap();
            if !c.converged {
                for it in [0u32, 1, 2, 3, 4, 5, 6, 8, 10, 15, 20, 30] {
                    let o = CompensationOptions { max_iterations: it, ..opts };
                    let c = calibrated.compensate(&q, &target, 0.0663, None, &o).unwrap();
                    let sv = calibrated.position_jacobian(&c.deflection).singular_values();
                    std::println!("{it} {:e} {:?} {:?} {:?}", c.error_m, sv.as_slice(), c.q, c.deflection.qa);
                }
            }
            assert!(c.converged, "error {} m after {} iterations at {q:?}", c.error_m, c.iterations);
        }
    }

    #[test]
    fn warm_start_gives_the_same_command_as_a_cold_start() {
        let mut rng = StdRng::seed_from_u64(4);
        let nominal = lrm_like_arm::<f64>().chain();
        let calibrated = perturbed(&mut rng).chain();
        let opts = CompensationOptions { tolerance_m: 1e-9, max_iterations: 60, ..Default::default() };
        let q0 = [0.1, 0.5, -0.3, 0.2, 0.8, 0.0];
        let q1 = [0.12, 0.52, -0.31, 0.2, 0.79, 0.01];
        let t0 = nominal.tool_point(&q0, 0.0, &opts.deflection).unwrap();
        let t1 = nominal.tool_point(&q1, 0.0, &opts.deflection).unwrap();
        let first = calibrated.compensate(&q0, &t0, 0.0, None, &opts).unwrap();
        let warm = calibrated.compensate(&q1, &t1, 0.0, Some(&first), &opts).unwrap();
        let cold = calibrated.compensate(&q1, &t1, 0.0, None, &opts).unwrap();
        assert!(warm.converged && cold.converged);
        for i in 0..6 {
            assert!((warm.q[i] - cold.q[i]).abs() < 1e-6, "joint {i}: {} vs {}", warm.q[i], cold.q[i]);
        }
    }
}
