//! The slope of a state's error: the position Jacobian with the base tilt's
//! fixed point folded in, from the state's [`Statics`] (no world frames).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::Evaluation;
use crate::elastic::yield_rate_of;
use crate::kinematics::Chain;
use crate::statics::Statics;
use crate::{MAX_JOINTS, Real};

/// `∂p/∂qa` of up to [`MAX_JOINTS`] joints, frame 0: columns past the arm's
/// last joint are zero. The products below run over the arm's joints only
/// ([`mul_joints`], [`tr_mul_joints`], [`dot_joints`]): on the MCU each
/// product with a zero column costs soft-float calls and changes nothing.
pub(super) type Jacobian<T> = SMatrix<T, 3, MAX_JOINTS>;

/// One value per joint as a column vector, zero past the arm's last joint.
pub(super) type JointColumn<T> = SVector<T, MAX_JOINTS>;

/// `Σ a_i b_i` over the joints of `b` (`a` at least as long), summed in
/// order from zero: what nalgebra's `dot` gives for a vector of six (or a row
/// of any length), bit for bit, without the terms past the arm's last joint.
/// On slices, not nalgebra's strided iterators: on the MCU those cost as much
/// as the floats.
pub(super) fn dot_joints<T: Real>(a: &[T], b: &[T]) -> T {
    let mut sum = T::zero();
    for (&a, &b) in a.iter().zip(b) {
        sum += a * b;
    }
    sum
}

/// `J p` over the first `n` columns: nalgebra's `J * p` (a column at a time,
/// `y = J₀ p₀`, then `y = J_c p_c + y`) bit for bit, without the zero columns.
pub(super) fn mul_joints<T: Real>(j: &Jacobian<T>, p: &JointColumn<T>, n: usize) -> Vector3<T> {
    let mut y = j.column(0) * p[0];
    for c in 1..n {
        for r in 0..3 {
            y[r] = j[(r, c)] * p[c] + y[r];
        }
    }
    y
}

/// `Jᵀ x` over the first `n` columns, zero past them: nalgebra's
/// `J.tr_mul(x)` (each entry `(J₀c x₀ + J₁c x₁) + J₂c x₂`) bit for bit.
pub(super) fn tr_mul_joints<T: Real>(j: &Jacobian<T>, x: &Vector3<T>, n: usize) -> JointColumn<T> {
    let mut out = JointColumn::zeros();
    for c in 0..n {
        out[c] = j[(0, c)] * x.x + j[(1, c)] * x.y + j[(2, c)] * x.z;
    }
    out
}

/// How the tool point moves with the deflected joint angles around a state,
/// the base tilt's fixed point folded in: the part of a state's linear model
/// that does not depend on the target.
#[derive(Clone, Copy, Debug)]
pub struct Slope<T: Real> {
    /// `∂p/∂qa` with the base tilt folded in, frame 0, m/rad.
    pub(super) j: Jacobian<T>,
    /// `J Jᵀ`, m².
    pub(super) jjt: Matrix3<T>,
    /// `∂beta/∂qa` of the linearised tilt.
    pub(super) tilt_gain: JointColumn<T>,
    /// `s`, how a residual of the tilt turns into a change of it.
    pub(super) tilt_scale: T,
}

impl<T: Real> Slope<T> {
    /// The change of the base tilt that goes with a change `dqa` of the deflected angles, rad.
    pub fn tilt_change(&self, dqa: &[T]) -> T {
        dot_joints(self.tilt_gain.as_slice(), dqa)
    }
}

impl<T: Real> Chain<T> {
    /// The slope at an evaluated state.
    pub fn slope(&self, evaluation: &Evaluation<T>) -> Slope<T> {
        let s = &evaluation.statics;
        let n = self.links.len();
        let (tilt_gain, tilt_scale) = self.tilt_gain(s);
        // J + (tilt column) (tilt gain)ᵀ, the arm's columns only.
        let mut j = self.jacobian(s);
        let tilt = tilt_column(s);
        for c in 0..n {
            for r in 0..3 {
                j[(r, c)] += tilt[r] * tilt_gain[c];
            }
        }
        // J Jᵀ is symmetric: six dot products, mirrored; each over the arm's
        // columns, in order from zero (nalgebra's row dot, bit for bit).
        // `J` is stored column by column: entry (r, c) is `3 c + r`.
        let entries = j.as_slice();
        let dot = |r: usize, c: usize| {
            let mut sum = T::zero();
            for k in 0..n {
                sum += entries[3 * k + r] * entries[3 * k + c];
            }
            sum
        };
        let (a01, a02, a12) = (dot(0, 1), dot(0, 2), dot(1, 2));
        #[rustfmt::skip]
        let jjt = Matrix3::new(
            dot(0, 0), a01, a02,
            a01, dot(1, 1), a12,
            a02, a12, dot(2, 2),
        );
        Slope {
            j,
            jjt,
            tilt_gain,
            tilt_scale,
        }
    }

    /// Jacobian of the tool point with the base tilt held, in frame 0:
    /// column `c` is `z × p` in joint `c`'s own frame, `(−p_y, p_x, 0)` with
    /// `p` the tool point relative to the joint (`z`, `(0, 0, 1)`, for a
    /// prismatic joint), rotated back to frame 0 (`c` rotations, the first
    /// without a `z` component).
    fn jacobian(&self, s: &Statics<T>) -> Jacobian<T> {
        let mut j = Jacobian::zeros();
        for c in 0..self.links.len() {
            let p = &s.tool_points[c];
            let prismatic = self.links[c].prismatic;
            let mut column = if prismatic {
                Vector3::z()
            } else {
                Vector3::new(-p.y, p.x, T::zero())
            };
            if let Some(k) = c.checked_sub(1) {
                column = if prismatic {
                    self.links[k].rotate_to_parent(&column, s.joint_sin_cos[k])
                } else {
                    self.links[k].rotate_to_parent_xy(-p.y, p.x, s.joint_sin_cos[k])
                };
                for k in (0..k).rev() {
                    column = self.links[k].rotate_to_parent(&column, s.joint_sin_cos[k]);
                }
            }
            j.set_column(c, &column);
        }
        j
    }

    /// The base tilt's response to the joints, `(∂beta/∂qa, s)`.
    ///
    /// Linearising `beta = y(τ0(qa, beta))`, `y = k0 (1 + s0 |τ0|) τ0` the
    /// base spring's yield, gives `Δbeta = s (r + y' ∂τ0/∂qa · Δqa)` with
    /// `s = 1 / (1 − y' ∂τ0/∂beta)` and `y' = k0 (1 + 2 s0 |τ0|)` its rate
    /// (`k0` for a linear spring). Turning joint `c` turns the load
    /// beyond it about its axis, so `∂τ0/∂qa_c = (z × v_c) · (g × y0)`, both
    /// in joint `c`'s frame (`g × y0` carried forward from frame 0); sliding
    /// a prismatic one moves the mass `M_c` beyond it along `z`:
    /// `M_c z · (g × y0)`.
    fn tilt_gain(&self, s: &Statics<T>) -> (JointColumn<T>, T) {
        let g0 = s.gravity0;
        let mut g_cross_y0 = Vector3::new(-g0.z, T::zero(), g0.x);
        let mut dtau0_dqa = JointColumn::zeros();
        for c in 0..self.links.len() {
            if c > 0 {
                g_cross_y0 = self.links[c - 1].rotate_to_child(&g_cross_y0, s.joint_sin_cos[c - 1]);
            }
            let v = &s.moments[c];
            dtau0_dqa[c] = if self.links[c].prismatic {
                s.mass_beyond(self, c) * g_cross_y0.z
            } else {
                v.x * g_cross_y0.y - v.y * g_cross_y0.x
            };
        }
        let n = self.links.len();
        // τ0 = (v0 × g0)_y and g0 turns with the tilt: ∂τ0/∂beta = −(y0 × g0)·(y0 × v0).
        let v0 = &s.moments[0];
        let dtau0_dbeta = -(g0.z * v0.z + g0.x * v0.x);
        let rate0 = yield_rate_of(self.base_compliance, self.base_softening, s.torques.base);
        let tilt_scale = T::one() / (T::one() - rate0 * dtau0_dbeta);
        let gain = tilt_scale * rate0;
        for d in dtau0_dqa.iter_mut().take(n) {
            *d *= gain;
        }
        (dtau0_dqa, tilt_scale)
    }
}

/// How the base tilt moves the tool point, `y0 × p` in frame 0, m/rad.
pub(super) fn tilt_column<T: Real>(statics: &Statics<T>) -> Vector3<T> {
    let p = &statics.tool_points[0];
    Vector3::new(p.z, T::zero(), -p.x)
}

#[cfg(test)]
mod tests {
    use nalgebra::{SMatrix, SVector, Vector3};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    use super::tilt_column;
    use crate::testing::lrm_like_arm;
    use crate::{MAX_JOINTS, PerJoint, Real, real};

    /// The slope worked out over the arm's joints only is nalgebra's
    /// `J + t gᵀ` of fixed size `N` (for six joints the `Matrix3x6` the solve
    /// used before arms of other sizes) bit for bit, and zero past the last
    /// joint, as is the tilt gain.
    #[test]
    fn the_slope_over_the_arms_joints_is_nalgebras_of_fixed_size_bit_for_bit() {
        slope_matches::<f32, 6>(1);
        slope_matches::<f64, 6>(2);
        slope_matches::<f32, 5>(3);
        slope_matches::<f32, 1>(4);
    }

    fn slope_matches<T: Real, const N: usize>(seed: u64) {
        let mut arm = lrm_like_arm::<T>();
        arm.joints = PerJoint::from_slice(&arm.joints[..N]).unwrap();
        arm.base_compliance = real(0.02);
        arm.base_softening = real(0.3);
        let chain = arm.chain();
        let bits = |x: T| nalgebra::try_convert::<T, f64>(x).unwrap().to_bits();
        let mut rng = StdRng::seed_from_u64(seed);
        for _ in 0..200 {
            let qa: [T; N] = core::array::from_fn(|_| real(rng.random_range(-1.6..1.6)));
            let beta = real(rng.random_range(-0.01..0.01));
            let target = Vector3::from_fn(|_, _| real::<T>(rng.random_range(-0.2..0.2)));
            let evaluation = chain
                .evaluate(&qa, beta, &target, real(0.05), real(1e-6))
                .unwrap();
            let slope = chain.slope(&evaluation);
            let s = &evaluation.statics;
            let jacobian: SMatrix<T, 3, N> = chain.jacobian(s).fixed_columns::<N>(0).into_owned();
            let gain: SVector<T, N> = slope.tilt_gain.fixed_rows::<N>(0).into_owned();
            let expected = jacobian + tilt_column(s) * gain.transpose();
            let got: SMatrix<T, 3, N> = slope.j.fixed_columns::<N>(0).into_owned();
            assert_eq!(got.map(bits), expected.map(bits));
            assert!(
                slope
                    .j
                    .columns(N, MAX_JOINTS - N)
                    .iter()
                    .all(|x| bits(*x) == 0)
            );
            assert!(slope.tilt_gain.iter().skip(N).all(|x| bits(*x) == 0));
        }
    }
}
