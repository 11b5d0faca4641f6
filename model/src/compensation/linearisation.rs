//! The linear model of a state's error and the step it gives.

use nalgebra::{Matrix3, Vector3, Vector6};

use super::Evaluation;
use super::slope::{Slope, tilt_column};
use crate::{JOINTS, Real, real};

/// Above this position error (m), a step removes only half of the null-space
/// offset from the nominal shape: all of it, with the large steps far from the
/// target, makes the solve oscillate where the null space turns quickly with
/// the pose. Close to the target the steps are small and remove all of it.
const HALF_PULL_ABOVE_M: f64 = 1e-4;

impl<T: Real> Evaluation<T> {
    /// The linear model of the error around this state with `slope`, the
    /// state's own or one of a nearby state.
    pub fn with_slope(&self, slope: &Slope<T>, q_nominal: &[T; JOINTS]) -> Linearisation<T> {
        let state = &self.state;
        let tilt_offset = slope.tilt_scale * self.beta_residual;
        Linearisation {
            slope: *slope,
            error: self.error - tilt_column(&self.statics) * tilt_offset,
            error_m: state.error_m,
            delta: Vector6::from_fn(|i, _| state.qa[i] - q_nominal[i]),
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
    delta: Vector6<T>,
    /// Change of beta that settles its residual at fixed `qa`, rad.
    tilt_offset: T,
    /// The state.
    qa: [T; JOINTS],
    /// The state's base tilt, rad.
    beta: T,
}

impl<T: Real> Linearisation<T> {
    /// The state to try next, deflected angles and base tilt, after one step
    /// (see `step` below); `None` if the step is not finite.
    pub fn next_state(&self, rejections: u32, damping_m: T) -> Option<([T; JOINTS], T)> {
        let step = self.step(rejections, damping_m * damping_m)?;
        let qa = core::array::from_fn(|i| self.qa[i] + step[i]);
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
    fn step(&self, rejections: u32, damping2: T) -> Option<Vector6<T>> {
        let mut lambda2 = self.error_m * self.error_m + damping2;
        for _ in 0..rejections {
            lambda2 *= real::<T>(4.0);
        }
        let j = &self.slope.j;
        let cholesky = (self.slope.jjt + Matrix3::from_diagonal_element(lambda2)).cholesky()?;
        if rejections > 0 {
            return Some(j.tr_mul(&cholesky.solve(&self.error)));
        }
        let pull = if self.error_m > real(HALF_PULL_ABOVE_M) {
            self.delta * real::<T>(0.5)
        } else {
            self.delta
        };
        Some(j.tr_mul(&cholesky.solve(&(self.error + j * pull))) - pull)
    }
}
