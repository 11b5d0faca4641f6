//! The linear model of a state's error and the step it gives.

use nalgebra::{Matrix3, Vector3};

use super::Evaluation;
use super::slope::{JointColumn, Slope, tilt_column};
use crate::{PerJoint, Real, real};

/// Above this position error (m), a step removes only half of the null-space
/// offset from the nominal shape: all of it, with the large steps far from the
/// target, makes the solve oscillate where the null space turns quickly with
/// the pose. Close to the target the steps are small and remove all of it.
const HALF_PULL_ABOVE_M: f64 = 1e-4;

impl<T: Real> Evaluation<T> {
    /// The linear model of the error around this state with `slope`, the
    /// state's own or one of a nearby state.
    pub fn with_slope(&self, slope: &Slope<T>, q_nominal: &[T]) -> Linearisation<T> {
        let state = &self.state;
        let tilt_offset = slope.tilt_scale * self.beta_residual;
        Linearisation {
            slope: *slope,
            error: self.error - tilt_column(&self.statics) * tilt_offset,
            error_m: state.error_m,
            delta: JointColumn::from_fn(|i, _| {
                if i < state.qa.len() {
                    state.qa[i] - q_nominal[i]
                } else {
                    T::zero()
                }
            }),
            tilt_offset,
            qa: state.qa,
            beta: state.beta,
        }
    }
}

/// The error around an evaluated state as a linear function of the change in `qa`.
#[derive(Clone, Copy, Debug)]
pub struct Linearisation<T: Real> {
    /// How the error changes.
    slope: Slope<T>,
    /// The error to remove, with the tilt residual's share taken out, frame 0, m.
    error: Vector3<T>,
    /// The state's error measure, m.
    error_m: T,
    /// Deflected angles minus nominal command at the state, rad.
    delta: JointColumn<T>,
    /// Change of beta that settles its residual at fixed `qa`, rad.
    tilt_offset: T,
    /// The state.
    qa: PerJoint<T>,
    /// The state's base tilt, rad.
    beta: T,
}

impl<T: Real> Linearisation<T> {
    /// The state to try next, deflected angles and base tilt, after one step
    /// (see `step` below); `None` if the step is not finite.
    pub fn next_state(&self, rejections: u32, damping_m: T) -> Option<(PerJoint<T>, T)> {
        let step = self.step(rejections, damping_m * damping_m)?;
        let qa = PerJoint::from_fn(self.qa.len(), |i| self.qa[i] + step[i]);
        let tilt = self.beta + self.tilt_offset + self.slope.tilt_gain.dot(&step);
        Some((qa, tilt))
    }

    /// The change of `qa` to try.
    ///
    /// First try: reach the target and move the null-space part of `δ` to zero
    /// (`δ' = Jᵀ (J Jᵀ + λ²)⁻¹ (e + J δ)`, `λ² = |e|² + λ₀²`; halfway only
    /// while the error exceeds `HALF_PULL_ABOVE_M`). After `rejections` failed tries: only
    /// reduce the error, with the damping multiplied by `4^rejections`; a
    /// damped Gauss–Newton step is a descent direction of `|e|²`, so this
    /// always makes progress once small enough.
    fn step(&self, rejections: u32, damping2: T) -> Option<JointColumn<T>> {
        let mut lambda2 = self.error_m * self.error_m + damping2;
        for _ in 0..rejections {
            lambda2 *= real::<T>(4.0);
        }
        let j = &self.slope.j;
        let damped = self.slope.jjt + Matrix3::from_diagonal_element(lambda2);
        if rejections > 0 {
            return Some(j.tr_mul(&solve_positive_definite(&damped, &self.error)?));
        }
        let pull = if self.error_m > real(HALF_PULL_ABOVE_M) {
            self.delta * real::<T>(0.5)
        } else {
            self.delta
        };
        let rhs = self.error + j * pull;
        Some(j.tr_mul(&solve_positive_definite(&damped, &rhs)?) - pull)
    }
}

/// `x` with `a x = b` for a symmetric positive definite 3 × 3 `a`, by its
/// `L D Lᵀ` factorisation written out: three divisions and about twenty
/// operations, where a general Cholesky factorisation and its two triangular
/// solves take three square roots, six divisions and loops (7,500 of the
/// 27,000 cycles of a compensation step on the MCU). `None` if `a` is not positive definite (or not finite).
fn solve_positive_definite<T: Real>(a: &Matrix3<T>, b: &Vector3<T>) -> Option<Vector3<T>> {
    let positive = |d: T| (d > T::zero()).then(|| T::one() / d);
    let r0 = positive(a.m11)?;
    let (l10, l20) = (a.m21 * r0, a.m31 * r0);
    let r1 = positive(a.m22 - l10 * a.m21)?;
    let t = a.m32 - l20 * a.m21;
    let l21 = t * r1;
    let r2 = positive(a.m33 - l20 * a.m31 - l21 * t)?;
    // L y = b, then Lᵀ x = D⁻¹ y.
    let y1 = b.y - l10 * b.x;
    let y2 = b.z - l20 * b.x - l21 * y1;
    let x2 = y2 * r2;
    let x1 = y1 * r1 - l21 * x2;
    let x0 = b.x * r0 - l10 * x1 - l20 * x2;
    Some(Vector3::new(x0, x1, x2))
}

#[cfg(test)]
mod tests {
    use super::solve_positive_definite;
    use nalgebra::{Matrix3, Vector3};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// The same solution as nalgebra's Cholesky, for random positive definite
    /// matrices from well to badly conditioned; none for indefinite ones.
    #[test]
    fn solves_like_a_cholesky_factorisation() {
        let mut rng = StdRng::seed_from_u64(5);
        for k in 0..1000 {
            let m = Matrix3::<f64>::from_fn(|_, _| rng.random_range(-0.3..0.3));
            let a = m * m.transpose() + Matrix3::identity() * 10f64.powi(-(k % 10));
            let b = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
            let expected = a.cholesky().unwrap().solve(&b);
            let x = solve_positive_definite(&a, &b).unwrap();
            assert!(
                (x - expected).norm() <= 1e-9 * expected.norm(),
                "{x} vs {expected}"
            );
            assert!((a * x - b).norm() < 1e-9);
        }
        let indefinite = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0));
        assert!(solve_positive_definite(&indefinite, &Vector3::x()).is_none());
        let not_finite = Matrix3::from_diagonal_element(f64::NAN);
        assert!(solve_positive_definite(&not_finite, &Vector3::x()).is_none());
    }
}
