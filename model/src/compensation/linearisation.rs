//! The linear model of a state's error and the step it gives.

use nalgebra::{Matrix3, Vector3};

use super::Evaluation;
use super::slope::{JointColumn, Slope, dot_joints, mul_joints, tilt_column, tr_mul_joints};
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
        let n = self.qa.len();
        let qa = PerJoint::from_fn(n, |i| self.qa[i] + step[i]);
        let tilt = self.beta
            + self.tilt_offset
            + dot_joints(self.slope.tilt_gain.as_slice(), &step.as_slice()[..n]);
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
    ///
    /// The products run over the arm's joints only: the step is zero past them.
    fn step(&self, rejections: u32, damping2: T) -> Option<JointColumn<T>> {
        let n = self.qa.len();
        let mut lambda2 = self.error_m * self.error_m + damping2;
        for _ in 0..rejections {
            lambda2 *= real::<T>(4.0);
        }
        let j = &self.slope.j;
        let damped = self.slope.jjt + Matrix3::from_diagonal_element(lambda2);
        if rejections > 0 {
            let x = solve_positive_definite(&damped, &self.error)?;
            return Some(tr_mul_joints(j, &x, n));
        }
        let mut pull = self.delta;
        if self.error_m > real(HALF_PULL_ABOVE_M) {
            for p in pull.iter_mut().take(n) {
                *p *= real::<T>(0.5);
            }
        }
        let rhs = self.error + mul_joints(j, &pull, n);
        let mut step = tr_mul_joints(j, &solve_positive_definite(&damped, &rhs)?, n);
        for (s, p) in step.iter_mut().zip(&pull).take(n) {
            *s -= *p;
        }
        Some(step)
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
    use super::{HALF_PULL_ABOVE_M, Real, real, solve_positive_definite};
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

    /// The products over the arm's joints only give, bit for bit, what
    /// nalgebra's products of fixed size `N` give (for six joints: the
    /// `Matrix3x6` and `Vector6` products the solve used before arms of other
    /// sizes), near the target and far from it, with and without rejections,
    /// in f32 (the board's) and f64; the step is zero past the last joint.
    #[test]
    fn products_over_the_arms_joints_are_nalgebras_of_fixed_size_bit_for_bit() {
        products_match::<f32, 6>(1);
        products_match::<f64, 6>(2);
        products_match::<f32, 5>(3);
        products_match::<f64, 1>(4);
    }

    fn products_match<T: Real, const N: usize>(seed: u64) {
        use crate::PerJoint;
        use crate::testing::lrm_like_arm;
        use nalgebra::{SMatrix, SVector};

        let mut arm = lrm_like_arm::<T>();
        arm.joints = PerJoint::from_slice(&arm.joints[..N]).unwrap();
        arm.base_compliance = real(0.02);
        arm.base_softening = real(0.3);
        let chain = arm.chain();
        let mut rng = StdRng::seed_from_u64(seed);
        // The bits of a value (f32 widens to f64 exactly, the sign of zero kept).
        let bits = |x: T| nalgebra::try_convert::<T, f64>(x).unwrap().to_bits();
        let mut far = 0;
        for k in 0..200 {
            let q: [T; N] = core::array::from_fn(|_| real(rng.random_range(-1.6..1.6)));
            let qa: [T; N] = core::array::from_fn(|i| q[i] + real(rng.random_range(-0.05..0.05)));
            let beta = real(rng.random_range(-0.01..0.01));
            let reach = chain.statics(&qa, beta, T::zero()).tool_points[0];
            let off = if k % 2 == 0 { 1e-5 } else { 1e-2 };
            let shift = Vector3::from_fn(|_, _| real::<T>(rng.random_range(-off..off)));
            let target = reach + shift;
            let evaluation = chain
                .evaluate(&qa, beta, &target, real(0.05), real(1e-6))
                .unwrap();
            let slope = chain.slope(&evaluation);
            // J Jᵀ (J itself: `slope::tests`).
            let j: SMatrix<T, 3, N> = slope.j.fixed_columns::<N>(0).into_owned();
            let gain: SVector<T, N> = slope.tilt_gain.fixed_rows::<N>(0).into_owned();
            let jjt = Matrix3::from_fn(|r, c| j.row(r).dot(&j.row(c)));
            assert_eq!(jjt.map(bits), slope.jjt.map(bits), "J Jᵀ");
            // The step and the next state.
            let lin = evaluation.with_slope(&slope, &q);
            far += usize::from(lin.error_m > real(HALF_PULL_ABOVE_M));
            let damping2 = real::<T>(1e-12);
            for rejections in [0, 1, 3] {
                let step = lin.step(rejections, damping2).unwrap();
                let mut lambda2 = lin.error_m * lin.error_m + damping2;
                for _ in 0..rejections {
                    lambda2 *= real::<T>(4.0);
                }
                let damped = lin.slope.jjt + Matrix3::from_diagonal_element(lambda2);
                let delta: SVector<T, N> = lin.delta.fixed_rows::<N>(0).into_owned();
                let expected: SVector<T, N> = if rejections > 0 {
                    j.tr_mul(&solve_positive_definite(&damped, &lin.error).unwrap())
                } else {
                    let pull = if lin.error_m > real(HALF_PULL_ABOVE_M) {
                        delta * real::<T>(0.5)
                    } else {
                        delta
                    };
                    let rhs = lin.error + j * pull;
                    j.tr_mul(&solve_positive_definite(&damped, &rhs).unwrap()) - pull
                };
                let got: SVector<T, N> = step.fixed_rows::<N>(0).into_owned();
                assert_eq!(
                    got.map(bits),
                    expected.map(bits),
                    "step, {rejections} rejections"
                );
                assert!(step.iter().skip(N).all(|x| *x == T::zero()));
                let (qa_next, tilt) = lin.next_state(rejections, real(1e-6)).unwrap();
                let expected_tilt = lin.beta + lin.tilt_offset + gain.dot(&expected);
                assert_eq!(bits(tilt), bits(expected_tilt), "tilt");
                assert_eq!(qa_next.len(), N);
                // The tilt change of a joint move, as the board's guess takes it.
                let dqa: SVector<T, N> = SVector::from_fn(|i, _| real(1e-3 * (i as f64 - 2.5)));
                assert_eq!(
                    bits(slope.tilt_change(dqa.as_slice())),
                    bits(gain.dot(&dqa)),
                    "tilt change"
                );
            }
        }
        assert!(far > 50, "{far} states far from the target");
    }
}
