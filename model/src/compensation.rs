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
//! with `e` the remaining position error, `λ² = |e|² + λ₀²` a damping that
//! keeps steps bounded near singular poses (Sugihara's Levenberg–Marquardt IK)
//! and fades with the error, so it does not bias the converged command, and
//! `J = ∂p/∂q` the Jacobian of the *deflected* tool point with respect to the
//! *commanded* angles (see [`Chain::command_jacobian`]). Neglecting the
//! deflection's dependence on the command (the rigid Jacobian) makes the
//! iteration overshoot and oscillate on compliant arms with a compliant base.

use nalgebra::{Matrix3, Matrix3x6, SMatrix, Vector3, Vector6};

use crate::elastic::{Deflection, DeflectionError, SolverOptions};
use crate::kinematics::Chain;
use crate::{JOINTS, Real, real};

/// The elastic state `x = (qa_1..qa_6, beta)` has one more coordinate than the command.
const STATE: usize = JOINTS + 1;

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

/// How the deflected state and tool point move with the command.
struct CommandSensitivity<T: Real> {
    /// `∂p/∂q`, m/rad.
    position: Matrix3x6<T>,
    /// `∂x/∂q` with `x = (qa, beta)`.
    state: SMatrix<T, STATE, JOINTS>,
}

impl<T: Real> Chain<T> {
    /// Sensitivity of the deflected state and tool point to the command at `d`.
    ///
    /// The state obeys `x = (q, 0) + K τ(x)`, so `∂x/∂q = (I − K ∂τ/∂x)⁻¹ E`
    /// with `E = [I₆; 0]`. Every coordinate of `x` is a rotation about an axis
    /// (`z(i-1)` for the joints, `y0` for the base tilt). With `v_i` the load
    /// moment of joint i ([`Chain::load_moments`]), a rotation `c` that moves
    /// only part of what loads torque `t` changes it by `(a_c × v_c)·(g × z_t)`,
    /// and one that turns all of it, axis included, by `−(a_c × g)·(z_t × v_t)`.
    fn command_sensitivity(
        &self,
        d: &Deflection<T>,
        payload_kg: T,
    ) -> Option<CommandSensitivity<T>> {
        let f = &d.frames;
        let g = self.gravity;
        let moments = self.load_moments(f, payload_kg);
        // Axis, origin and load moment of each state coordinate; the base tilt
        // turns the whole arm about y0 through o0, so it shares joint 1's moment.
        let axis = |c: usize| {
            if c < JOINTS {
                f.joint_axis(c)
            } else {
                f.base_tilt_axis()
            }
        };
        let origin = |c: usize| f.joint_origin(if c < JOINTS { c } else { 0 });
        let moment = |c: usize| moments[if c < JOINTS { c } else { 0 }];
        let compliance = |c: usize| {
            if c < JOINTS {
                self.links[c].compliance
            } else {
                self.base_compliance
            }
        };
        // Coordinate c is "inside" torque t's load when turning it moves only part
        // of that load about a fixed axis: a joint at or beyond t; the base tilt
        // is outside every joint's load and inside nothing but its own axis.
        let moves_part_of = |c: usize, t: usize| c < JOINTS && (t == JOINTS || c >= t);
        let partial: [Vector3<T>; STATE] = core::array::from_fn(|c| axis(c).cross(&moment(c)));
        let whole: [Vector3<T>; STATE] = core::array::from_fn(|c| axis(c).cross(&g));
        let mut a = SMatrix::<T, STATE, STATE>::identity();
        for t in 0..STATE {
            let (z, v) = (axis(t), moment(t));
            let g_cross_z = g.cross(&z);
            let z_cross_v = z.cross(&v);
            for c in 0..STATE {
                let dtau = if moves_part_of(c, t) {
                    partial[c].dot(&g_cross_z)
                } else {
                    -whole[c].dot(&z_cross_v)
                };
                a[(t, c)] -= compliance(t) * dtau;
            }
        }
        let e = SMatrix::<T, STATE, JOINTS>::identity();
        let state = a.lu().solve(&e)?;
        let p = d.tool_point();
        let mut geometric = SMatrix::<T, 3, STATE>::zeros();
        for c in 0..STATE {
            geometric.set_column(c, &axis(c).cross(&(p - origin(c))));
        }
        Some(CommandSensitivity {
            position: geometric * state,
            state,
        })
    }

    /// `∂p/∂q`: how the deflected tool point moves with the commanded angles, m/rad.
    pub fn command_jacobian(&self, d: &Deflection<T>, payload_kg: T) -> Option<Matrix3x6<T>> {
        self.command_sensitivity(d, payload_kg).map(|s| s.position)
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
                return Ok(Compensation {
                    q,
                    deflection,
                    error_m,
                    iterations,
                    converged,
                });
            }
            iterations += 1;
            let sensitivity = self
                .command_sensitivity(&deflection, payload_kg)
                .ok_or(DeflectionError::NotFinite)?;
            let j = sensitivity.position;
            let delta = Vector6::from_fn(|i, _| q[i] - q_nominal[i]);
            let lambda2 = error_m * error_m + options.damping_m * options.damping_m;
            let jjt = j * j.transpose() + Matrix3::identity() * lambda2;
            let solved = jjt
                .cholesky()
                .ok_or(DeflectionError::NotFinite)?
                .solve(&(error + j * delta));
            let step = j.transpose() * solved - delta;
            let state_step = sensitivity.state * step;
            guess = (
                core::array::from_fn(|i| deflection.qa[i] + state_step[i]),
                deflection.beta + state_step[JOINTS],
            );
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
        let opts = CompensationOptions {
            max_iterations: 60,
            ..Default::default()
        };
        for _ in 0..500 {
            let q: [f64; 6] = random_q(&mut rng);
            let target = nominal.tool_point(&q, 0.0663, &opts.deflection).unwrap();
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

    #[test]
    fn warm_start_gives_the_same_command_as_a_cold_start() {
        let mut rng = StdRng::seed_from_u64(4);
        let nominal = lrm_like_arm::<f64>().chain();
        let calibrated = perturbed(&mut rng).chain();
        let opts = CompensationOptions {
            tolerance_m: 1e-9,
            max_iterations: 60,
            ..Default::default()
        };
        let q0 = [0.1, 0.5, -0.3, 0.2, 0.8, 0.0];
        let q1 = [0.12, 0.52, -0.31, 0.2, 0.79, 0.01];
        let t0 = nominal.tool_point(&q0, 0.0, &opts.deflection).unwrap();
        let t1 = nominal.tool_point(&q1, 0.0, &opts.deflection).unwrap();
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
mod jacobian_tests {
    use super::*;
    use crate::test_arms::lrm_like_arm;

    #[test]
    fn command_jacobian_matches_finite_differences_of_the_deflected_arm() {
        let mut arm = lrm_like_arm::<f64>();
        arm.base_compliance = 0.08;
        let chain = arm.chain();
        let opts = SolverOptions {
            tolerance: 1e-15,
            max_iterations: 200,
        };
        let q = [-0.8, 0.65, -1.05, 1.6, 1.37, 1.7];
        let load = 0.0663;
        let d = chain.deflect(&q, load, &opts).unwrap();
        let j = chain.command_jacobian(&d, load).unwrap();
        let h = 1e-6;
        for c in 0..JOINTS {
            let (mut qp, mut qm) = (q, q);
            qp[c] += h;
            qm[c] -= h;
            let numeric = (chain.tool_point(&qp, load, &opts).unwrap()
                - chain.tool_point(&qm, load, &opts).unwrap())
                / (2.0 * h);
            let diff = (numeric - j.column(c)).norm();
            assert!(
                diff < 1e-7,
                "joint {c}: analytic {:?} numeric {numeric:?}",
                j.column(c)
            );
        }
    }
}
