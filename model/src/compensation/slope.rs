//! The slope of a state's error: the position Jacobian with the base tilt's
//! fixed point folded in, and the damped inverse a step solves with.
//!
//! On the MCU a slope costs about as much as evaluating a state, so the
//! firmware builds it over several servo frames with [`SlopeBuilder`], one
//! part of similar cost per frame, and steps with the last finished one.

use nalgebra::{Matrix3, Matrix3x6, Vector3, Vector6};

use super::Evaluation;
use crate::kinematics::Chain;
use crate::statics::Statics;
use crate::{JOINTS, Real, real};

/// A slope serves a state within this of the one it was built at (largest
/// joint difference, rad) as if it were the state's own: the step may pull
/// towards the nominal shape along its null space. Further away, its null
/// space is not the state's and pulling along it would move the tool.
const NEAR_RAD: f64 = 0.01;

/// How the tool point moves with the deflected joint angles around a state,
/// the base tilt's fixed point folded in: the part of a linear model that
/// also serves nearby states (stepping with a slope a few frames old
/// converges a little slower, to the same solution).
#[derive(Clone, Copy, Debug)]
pub struct Slope<T: Real> {
    /// `∂p/∂qa` with the base tilt folded in, frame 0, m/rad.
    pub(super) j: Matrix3x6<T>,
    /// `J Jᵀ`, m².
    pub(super) jjt: Matrix3<T>,
    /// `∂beta/∂qa` of the linearised tilt.
    pub(super) tilt_gain: Vector6<T>,
    /// `s`, how a residual of the tilt turns into a change of it.
    pub(super) tilt_scale: T,
    /// The deflected angles of the state it was built at, rad.
    qa: [T; JOINTS],
}

impl<T: Real> Slope<T> {
    /// The change of the base tilt that goes with a change `dqa` of the deflected angles, rad.
    pub fn tilt_change(&self, dqa: &[T; JOINTS]) -> T {
        self.tilt_gain.dot(&Vector6::from_column_slice(dqa))
    }

    /// The deflected angles of the state it was built at, rad.
    pub fn qa(&self) -> &[T; JOINTS] {
        &self.qa
    }

    /// Whether a state with deflected angles `qa` is near enough to the
    /// slope's own to take a full step with it (see `NEAR_RAD`).
    pub fn is_near(&self, qa: &[T; JOINTS]) -> bool {
        (0..JOINTS).all(|i| (qa[i] - self.qa[i]).abs() <= real(NEAR_RAD))
    }
}

/// A slope built a part at a time, five parts of 60 to 100
/// floating-point operations: the Jacobian's columns in three (five rotations
/// each), the tilt's gain, then its fold and `J Jᵀ`.
#[derive(Clone, Copy, Debug)]
pub struct SlopeBuilder<T: Real> {
    at: Evaluation<T>,
    j: Matrix3x6<T>,
    tilt_gain: Vector6<T>,
    tilt_scale: T,
    parts_done: u8,
}

impl<T: Real> SlopeBuilder<T> {
    /// Starts the slope at an evaluated state.
    pub fn new(at: &Evaluation<T>) -> Self {
        Self {
            at: *at,
            j: Matrix3x6::zeros(),
            tilt_gain: Vector6::zeros(),
            tilt_scale: T::one(),
            parts_done: 0,
        }
    }

    /// Does the next part of the work; the slope when this was the last.
    pub fn advance(&mut self, chain: &Chain<T>) -> Option<Slope<T>> {
        match self.parts_done {
            // Column c takes c rotations: five in each pair.
            0 => self.columns(chain, [5, 0]),
            1 => self.columns(chain, [4, 1]),
            2 => self.columns(chain, [3, 2]),
            3 => self.tilt_gain(chain),
            _ => return Some(self.finish()),
        }
        self.parts_done += 1;
        None
    }

    /// Jacobian columns of the base tilt held, in frame 0: column `c` is
    /// `z × p` in joint `c`'s own frame, `(−p_y, p_x, 0)` with `p` the tool
    /// point relative to the joint, rotated back to frame 0 (`c` rotations).
    fn columns(&mut self, chain: &Chain<T>, joints: [usize; 2]) {
        let s = &self.at.statics;
        for c in joints {
            let p = &s.tool_points[c];
            let mut column = Vector3::new(-p.y, p.x, T::zero());
            for k in (0..c).rev() {
                column = chain.links[k].rotate_to_parent(&column, s.joint_sin_cos[k]);
            }
            self.j.set_column(c, &column);
        }
    }

    /// The base tilt's response to the joints.
    ///
    /// Linearising `beta = k0 τ0(qa, beta)` gives `Δbeta = s (r + k0 ∂τ0/∂qa · Δqa)`
    /// with `s = 1 / (1 − k0 ∂τ0/∂beta)`. Turning joint `c` turns the load
    /// beyond it about its axis, so `∂τ0/∂qa_c = (z × v_c) · (g × y0)`, both
    /// in joint `c`'s frame (`g × y0` carried forward from frame 0).
    fn tilt_gain(&mut self, chain: &Chain<T>) {
        let s = &self.at.statics;
        let g0 = s.gravity0;
        let mut g_cross_y0 = Vector3::new(-g0.z, T::zero(), g0.x);
        let mut dtau0_dqa = Vector6::zeros();
        for c in 0..JOINTS {
            if c > 0 {
                g_cross_y0 =
                    chain.links[c - 1].rotate_to_child(&g_cross_y0, s.joint_sin_cos[c - 1]);
            }
            let v = &s.moments[c];
            dtau0_dqa[c] = v.x * g_cross_y0.y - v.y * g_cross_y0.x;
        }
        // τ0 = (v0 × g0)_y and g0 turns with the tilt: ∂τ0/∂beta = −(y0 × g0)·(y0 × v0).
        let v0 = &s.moments[0];
        let dtau0_dbeta = -(g0.z * v0.z + g0.x * v0.x);
        let k0 = chain.base_compliance;
        self.tilt_scale = T::one() / (T::one() - k0 * dtau0_dbeta);
        self.tilt_gain = dtau0_dqa * (self.tilt_scale * k0);
    }

    /// Folds the tilt into the Jacobian and forms `J Jᵀ`.
    fn finish(&self) -> Slope<T> {
        let j = self.j + tilt_column(&self.at.statics) * self.tilt_gain.transpose();
        // Symmetric: six dot products, mirrored.
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
            tilt_gain: self.tilt_gain,
            tilt_scale: self.tilt_scale,
            qa: self.at.state.qa,
        }
    }
}

/// How the base tilt moves the tool point, `y0 × p` in frame 0, m/rad.
pub(super) fn tilt_column<T: Real>(statics: &Statics<T>) -> Vector3<T> {
    let p = &statics.tool_points[0];
    Vector3::new(p.z, T::zero(), -p.x)
}

impl<T: Real> Chain<T> {
    /// The slope at an evaluated state, built whole.
    pub fn slope(&self, evaluation: &Evaluation<T>) -> Slope<T> {
        let mut builder = SlopeBuilder::new(evaluation);
        loop {
            if let Some(slope) = builder.advance(self) {
                return slope;
            }
        }
    }
}
