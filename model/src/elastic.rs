//! Elastic deflection: `qa_i = q_i + k_i tau_i(qa, beta)` and
//! `beta = k0 tau0(qa, beta)`, solved together by fixed-point iteration.
//!
//! **Springs that are not linear.** A servo's gear train and horn take up
//! their play and bend further as the load grows, so a joint's compliance
//! may depend on its torque: `k_i (1 + s_i |tau_i|)` with the softening
//! `s_i` of [`crate::kinematics::Link::softening`] (1/Nm; negative when the
//! joint stiffens). With every `s_i` zero, the default, the map is the
//! linear one bit for bit.
//!
//! The torques depend on the deflected pose, so the deflection is iterated from
//! `qa = q, beta = 0` until the largest change of any angle falls below the
//! tolerance. For realistic compliances the map is a strong contraction
//! (3–6 iterations in f64); if it is not, the solver says so instead of
//! returning a pose that does not satisfy its own equation.
//!
//! **Convergence test, scaled to the problem.** Both tolerances are relative
//! to the size of the angles (`max(1 rad, |q|)`: an angle of 7 rad carries
//! seven times the rounding of one of 1 rad). The iteration has converged when
//! a step is below [`SolverOptions::tolerance`], or when it is below the
//! looser [`SolverOptions::floor_tolerance`] and the iteration cannot or need
//! not go further: either the step stopped shrinking (it is rounding noise:
//! a compliant wrist loaded through long links stalls near 1e-13 rad in f64,
//! where no more digits exist to win), or the contraction observed over the
//! last two steps, `r`, bounds the remaining distance to the fixed point,
//! `step · r / (1 − r)`, below that tolerance.

use nalgebra::Vector3;

use crate::kinematics::{Chain, ChainFrames};
use crate::{PerJoint, Real, real};

/// Stopping rules of the deflection solver (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverOptions<T> {
    /// Converged when no angle changes by more than this times the angle
    /// scale `max(1, |q|)` in one iteration, rad.
    pub tolerance: T,
    /// Converged, too, when the last step is below this times the angle
    /// scale and has stopped shrinking or the observed contraction puts the
    /// fixed point within it, rad.
    pub floor_tolerance: T,
    /// Give up after this many iterations.
    pub max_iterations: u32,
}

impl<T: Real> Default for SolverOptions<T> {
    /// 32 machine epsilons (about 7e-15 rad in f64, 4e-6 rad in f32), a floor
    /// of `eps^(3/4)` (2e-12 rad in f64, 6e-6 rad in f32) and 60 iterations.
    fn default() -> Self {
        let eps = T::default_epsilon();
        Self {
            tolerance: eps * real(32.0),
            floor_tolerance: eps.powf(real(0.75)),
            max_iterations: 60,
        }
    }
}

impl<T: Real> SolverOptions<T> {
    /// Whether an iteration whose last step was `step` after a step of
    /// `previous` (none on the first) has converged for angles of size
    /// `scale` (≥ 1): see the module docs.
    fn converged(&self, step: T, previous: Option<T>, scale: T) -> bool {
        if step <= self.tolerance * scale {
            return true;
        }
        let floor = self.floor_tolerance * scale;
        let Some(previous) = previous.filter(|_| step <= floor) else {
            return false;
        };
        let r = step / previous;
        r >= T::one() || step * r / (T::one() - r) <= floor
    }
}

/// The deflected state of the arm for one command and payload.
#[derive(Clone, Copy, Debug)]
pub struct Deflection<T: Real> {
    /// Actual (deflected) joint angles, rad.
    pub qa: PerJoint<T>,
    /// Elastic tilt of the base about y0, rad.
    pub beta: T,
    /// Frames of the deflected chain.
    pub frames: ChainFrames<T>,
    /// Iterations used.
    pub iterations: u32,
}

impl<T: Real> Deflection<T> {
    /// The measured point of the deflected arm, world frame, m.
    pub fn tool_point(&self) -> Vector3<T> {
        self.frames.tool_point()
    }
}

/// Why the deflection could not be solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DeflectionError {
    /// The iteration did not settle within the allowed iterations.
    NotConverged {
        /// Iterations run.
        iterations: u32,
        /// Largest angle change in the last iteration, rad (as f64 for reporting).
        last_step: f64,
    },
    /// An input or intermediate value was not finite.
    NotFinite,
}

impl core::fmt::Display for DeflectionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotConverged {
                iterations,
                last_step,
            } => write!(
                f,
                "elastic deflection did not converge in {iterations} iterations (last step {last_step:.3e} rad): compliance or load too large"
            ),
            Self::NotFinite => f.write_str("elastic deflection met a non-finite value"),
        }
    }
}

/// The angle a spring of compliance `k` and softening `s` yields under
/// torque `tau`: `k (1 + s |tau|) tau`, exactly `k tau` when `s` is zero.
pub(crate) fn yield_of<T: Real>(k: T, s: T, tau: T) -> T {
    if s == T::zero() {
        k * tau
    } else {
        k * (T::one() + s * tau.abs()) * tau
    }
}

/// How fast that angle grows with the torque, `d/dtau [k (1 + s |tau|) tau]
/// = k (1 + 2 s |tau|)`, exactly `k` when `s` is zero.
pub(crate) fn yield_rate_of<T: Real>(k: T, s: T, tau: T) -> T {
    if s == T::zero() {
        k
    } else {
        k * (T::one() + (s + s) * tau.abs())
    }
}

impl<T: Real> Chain<T> {
    /// Deflection for commanded angles `q` (rad) and payload `payload_kg`, from `qa = q, beta = 0`.
    pub fn deflect(
        &self,
        q: &[T],
        payload_kg: T,
        options: &SolverOptions<T>,
    ) -> Result<Deflection<T>, DeflectionError> {
        let start = PerJoint::from_fn(q.len(), |i| q[i]);
        self.deflect_from(q, payload_kg, (start, T::zero()), options)
    }

    /// Deflection as [`Chain::deflect`], iterating from a guess `(qa, beta)`,
    /// e.g. the previous servo frame's solution.
    pub fn deflect_from(
        &self,
        q: &[T],
        payload_kg: T,
        (mut qa, mut beta): (PerJoint<T>, T),
        options: &SolverOptions<T>,
    ) -> Result<Deflection<T>, DeflectionError> {
        if self.is_rigid() {
            let frames = self.frames(q, T::zero());
            return Ok(Deflection {
                qa: PerJoint::from_fn(q.len(), |i| q[i]),
                beta: T::zero(),
                frames,
                iterations: 0,
            });
        }
        let scale = q.iter().fold(T::one(), |m, v| m.max(v.abs()));
        let mut last_step = T::zero();
        let mut previous = None;
        for iteration in 1..=options.max_iterations {
            let (next_qa, next_beta) = self.elastic_map(q, &qa, beta, payload_kg);
            last_step = (next_beta - beta).abs();
            for (n, o) in next_qa.iter().zip(&qa) {
                last_step = last_step.max((*n - *o).abs());
            }
            if !last_step.is_finite() {
                return Err(DeflectionError::NotFinite);
            }
            qa = next_qa;
            beta = next_beta;
            if options.converged(last_step, previous, scale) {
                let frames = self.frames(&qa, beta);
                return Ok(Deflection {
                    qa,
                    beta,
                    frames,
                    iterations: iteration,
                });
            }
            previous = Some(last_step);
        }
        Err(DeflectionError::NotConverged {
            iterations: options.max_iterations,
            last_step: nalgebra::try_convert(last_step).unwrap_or(f64::NAN),
        })
    }

    /// Whether no joint and not the base yields: the deflection is then nothing,
    /// and one pass of forward kinematics is the whole answer.
    pub fn is_rigid(&self) -> bool {
        self.base_compliance == T::zero() && self.links.iter().all(|l| l.compliance == T::zero())
    }

    /// One application of the fixed-point map: `(q + k tau, k0 tau0)` at the
    /// deflected angles `qa` and base tilt `beta` (`k (1 + s |tau|)` for `k`
    /// where a spring softens, see the module docs).
    pub fn elastic_map(&self, q: &[T], qa: &[T], beta: T, payload_kg: T) -> (PerJoint<T>, T) {
        let tau = self.gravity_torques(qa, beta, payload_kg);
        let qa = PerJoint::from_fn(self.links.len(), |i| {
            let link = &self.links[i];
            q[i] + yield_of(link.compliance, link.softening, tau.joints[i])
        });
        (
            qa,
            yield_of(self.base_compliance, self.base_softening, tau.base),
        )
    }

    /// Largest violation of the fixed-point equation by a solution, rad.
    pub fn fixed_point_residual(&self, q: &[T], payload_kg: T, d: &Deflection<T>) -> T {
        let (qa, beta) = self.elastic_map(q, &d.qa, d.beta, payload_kg);
        qa.iter()
            .zip(&d.qa)
            .fold((beta - d.beta).abs(), |m, (a, b)| m.max((*a - *b).abs()))
    }

    /// The measured point of the deflected arm, world frame, m.
    pub fn tool_point(
        &self,
        q: &[T],
        payload_kg: T,
        options: &SolverOptions<T>,
    ) -> Result<Vector3<T>, DeflectionError> {
        if self.is_rigid() {
            return Ok(self.rigid_tool_point(q));
        }
        self.deflect(q, payload_kg, options).map(|d| d.tool_point())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::TEST_ARM_JOINTS as JOINTS;
    use crate::testing::{lrm_like_arm, random_q, rigid_lrm_like_arm};
    use rand::{SeedableRng, rngs::StdRng};

    #[test]
    fn solution_satisfies_its_fixed_point_equation() {
        let chain = lrm_like_arm::<f64>().chain();
        let mut rng = StdRng::seed_from_u64(7);
        for _ in 0..200 {
            let q = random_q(&mut rng);
            for load in [0.0, 0.0663] {
                let d = chain.deflect(&q, load, &SolverOptions::default()).unwrap();
                assert!(chain.fixed_point_residual(&q, load, &d) < 1e-9);
                assert!(d.iterations < 20, "took {} iterations", d.iterations);
            }
        }
    }

    #[test]
    fn deflection_moves_the_tool_down_under_load() {
        let chain = lrm_like_arm::<f64>().chain();
        let q = [0.0, 0.6, -0.4, 0.0, 0.3, 0.0];
        let opts = SolverOptions::default();
        let light = chain.tool_point(&q, 0.0, &opts).unwrap();
        let heavy = chain.tool_point(&q, 0.0663, &opts).unwrap();
        let rigid = chain.rigid_tool_point(&q);
        assert!(light.z < rigid.z, "own weight must sag the arm");
        assert!(heavy.z < light.z, "a payload must sag it further");
    }

    #[test]
    fn rigid_arm_takes_the_shortcut_and_matches_the_iteration() {
        let chain = rigid_lrm_like_arm().chain();
        assert!(chain.is_rigid());
        let q = [0.2, 0.9, -0.5, 0.4, -0.7, 0.1];
        let d = chain
            .deflect(&q, 0.0663, &SolverOptions::default())
            .unwrap();
        assert_eq!(d.iterations, 0);
        assert_eq!(d.tool_point(), chain.frames(&q, 0.0).tool_point());
        assert!((d.tool_point() - chain.rigid_tool_point(&q)).norm() < 1e-15);
        assert!(chain.fixed_point_residual(&q, 0.0663, &d) == 0.0);
        assert!(!lrm_like_arm::<f64>().chain().is_rigid());
    }

    /// A softening spring yields more under the same torque, and the
    /// solution still satisfies its own (nonlinear) equation.
    #[test]
    fn softening_springs_yield_more_and_satisfy_their_equation() {
        let arm = lrm_like_arm();
        let linear: Chain<f64> = arm.chain();
        let mut soft = linear;
        for link in &mut soft.links {
            link.softening = 0.3;
        }
        soft.base_softening = 0.3;
        let opts = SolverOptions::default();
        let mut rng = StdRng::seed_from_u64(5);
        for _ in 0..20 {
            let q: [f64; JOINTS] = random_q(&mut rng);
            let a = linear.deflect(&q, 0.0663, &opts).unwrap();
            let b = soft.deflect(&q, 0.0663, &opts).unwrap();
            assert!(soft.fixed_point_residual(&q, 0.0663, &b) < 1e-12);
            // Joint 2 carries the most torque: its sag grows.
            assert!((b.qa[1] - q[1]).abs() > (a.qa[1] - q[1]).abs());
        }
    }

    #[test]
    fn huge_compliance_reports_non_convergence() {
        let mut arm = lrm_like_arm::<f64>();
        for j in &mut arm.joints {
            j.compliance = 50.0;
        }
        let chain = arm.chain();
        let err = chain.deflect(
            &[0.0, 0.6, -0.4, 0.0, 0.3, 0.0],
            1.0,
            &SolverOptions::default(),
        );
        assert!(matches!(
            err,
            Err(DeflectionError::NotConverged { .. } | DeflectionError::NotFinite)
        ));
    }

    /// The test is relative to the angles and accepts a step at the rounding
    /// floor once it stops shrinking or the contraction bounds what is left.
    #[test]
    fn convergence_test_scales_and_accepts_the_rounding_floor() {
        let o = SolverOptions::<f64>::default();
        // A step of 2e-13 rad that no longer shrinks is as good as f64 gets.
        assert!(o.converged(2e-13, Some(1.9e-13), 1.0));
        assert!(o.converged(2e-13, Some(1e-12), 1.0), "contracting by 0.2");
        // Slow contraction: 0.95 per step leaves 19 steps' worth to go.
        assert!(!o.converged(2e-13, Some(2e-13 / 0.95), 1.0));
        assert!(o.converged(2e-13, Some(2e-13 / 0.95), 7.0 * 4.0));
        // Far above the floor, stalling is divergence, not convergence.
        assert!(!o.converged(1e-6, Some(1e-6), 7.0));
        assert!(!o.converged(2e-13, None, 1.0));
        assert!(
            o.converged(4e-14, None, 7.0),
            "7 rad carries 7 times the rounding"
        );
        assert!(!o.converged(4e-14, None, 1.0));
    }

    /// A soft wrist carrying little torque, at industrial joint angles of
    /// several radians, converges.
    #[test]
    fn soft_wrist_at_large_angles_converges() {
        let mut arm = lrm_like_arm::<f64>();
        for j in &mut arm.joints[3..] {
            j.compliance = 0.5;
        }
        let chain = arm.chain();
        let q = [6.9, -5.8, 6.1, -6.2, 4.0, 6.9];
        let d = chain.deflect(&q, 0.0, &SolverOptions::default()).unwrap();
        assert!(chain.fixed_point_residual(&q, 0.0, &d) < 1e-11);
    }

    #[test]
    fn warm_start_reaches_the_same_solution() {
        let chain = lrm_like_arm::<f64>().chain();
        let q = [0.2, 0.9, -0.5, 0.4, -0.7, 0.1];
        let opts = SolverOptions::default();
        let cold = chain.deflect(&q, 0.0663, &opts).unwrap();
        let warm = chain
            .deflect_from(&q, 0.0663, (cold.qa, cold.beta), &opts)
            .unwrap();
        assert!(warm.iterations <= 2);
        assert!((warm.tool_point() - cold.tool_point()).norm() < 1e-12);
    }
}

#[cfg(test)]
mod precision_tests {
    use super::*;
    use crate::testing::{lrm_like_arm, random_q};
    use rand::{SeedableRng, rngs::StdRng};

    /// The firmware runs this model in f32: it must agree with the host's f64
    /// to well under the calibration's accuracy.
    #[test]
    fn f32_model_agrees_with_f64_within_10_micrometres() {
        let arm64 = lrm_like_arm::<f64>();
        let (c64, c32) = (arm64.chain(), arm64.map(|x| x as f32).chain());
        let mut rng = StdRng::seed_from_u64(11);
        let mut worst = 0.0f64;
        for k in 0..1000 {
            let q: [f64; 6] = random_q(&mut rng);
            let load = if k % 2 == 0 { 0.0 } else { 0.0663 };
            let p64 = c64.tool_point(&q, load, &SolverOptions::default()).unwrap();
            let p32 = c32
                .tool_point(&q.map(|x| x as f32), load as f32, &SolverOptions::default())
                .unwrap();
            worst = worst.max((p64 - p32.map(f64::from)).norm());
        }
        assert!(worst < 1e-5, "worst f32/f64 difference {worst:e} m");
    }
}
