//! The slope of a state's error: the position Jacobian with the base tilt's
//! fixed point folded in, from the state's [`Statics`] (no world frames).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::Evaluation;
use crate::elastic::yield_rate_of;
use crate::kinematics::Chain;
use crate::statics::Statics;
use crate::{MAX_JOINTS, Real};

/// `∂p/∂qa` of up to [`MAX_JOINTS`] joints, frame 0: columns past the arm's
/// last joint are zero, so they change no product.
pub(super) type Jacobian<T> = SMatrix<T, 3, MAX_JOINTS>;

/// One value per joint as a column vector, zero past the arm's last joint.
pub(super) type JointColumn<T> = SVector<T, MAX_JOINTS>;

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
        dqa.iter()
            .zip(self.tilt_gain.iter())
            .fold(T::zero(), |sum, (&d, &g)| sum + g * d)
    }
}

impl<T: Real> Chain<T> {
    /// The slope at an evaluated state.
    pub fn slope(&self, evaluation: &Evaluation<T>) -> Slope<T> {
        let s = &evaluation.statics;
        let (tilt_gain, tilt_scale) = self.tilt_gain(s);
        let j = self.jacobian(s) + tilt_column(s) * tilt_gain.transpose();
        // J Jᵀ is symmetric: six dot products, mirrored.
        let dot = |r: usize, c: usize| j.row(r).dot(&j.row(c));
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
                s.masses[c] * g_cross_y0.z
            } else {
                v.x * g_cross_y0.y - v.y * g_cross_y0.x
            };
        }
        // τ0 = (v0 × g0)_y and g0 turns with the tilt: ∂τ0/∂beta = −(y0 × g0)·(y0 × v0).
        let v0 = &s.moments[0];
        let dtau0_dbeta = -(g0.z * v0.z + g0.x * v0.x);
        let rate0 = yield_rate_of(self.base_compliance, self.base_softening, s.torques.base);
        let tilt_scale = T::one() / (T::one() - rate0 * dtau0_dbeta);
        (dtau0_dqa * (tilt_scale * rate0), tilt_scale)
    }
}

/// How the base tilt moves the tool point, `y0 × p` in frame 0, m/rad.
pub(super) fn tilt_column<T: Real>(statics: &Statics<T>) -> Vector3<T> {
    let p = &statics.tool_points[0];
    Vector3::new(p.z, T::zero(), -p.x)
}
