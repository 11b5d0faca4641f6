//! The elasto-kinematic model of a 6R arm, written once and used everywhere.
//!
//! The host identifies the model in `f64`; the firmware compensates with it in
//! `f32`. Both call exactly this code, so identification and compensation can
//! never disagree about what the arm is.
//!
//! | module | what it holds |
//! |---|---|
//! | [`arm`] | the arm's parameters as plain data (DH, frames, masses, compliances, servo curves) |
//! | [`params`] | the 43 named error parameters and how they apply to an [`Arm`] |
//! | [`kinematics`] | standard DH forward kinematics of the (deflected) chain |
//! | [`statics`] | tool point and gravity torques in one sweep through the links' frames |
//! | [`elastic`] | the elastic deflection, solved by fixed-point iteration |
//! | [`compensation`] | the joint commands that make the deflected calibrated arm reach a nominal pose |
//! | [`bounds`] | the physical range of every bounded quantity, derived from the arm |
//! | [`option`] | the model options: which parameters a calibration identifies, by name |
//! | [`command`] | what a command does: the joint angles an arm stands at, its servo curves and play taken up |
//! | [`backlash`] | play in a joint's drive: where a joint settles, given the way it arrived |
//! | [`servo`] | the piecewise-linear servo curve through up to 9 knots (angle -> pulse) |
//! | [`trig`] | the f32 sine and cosine of the joint angles, fast without an FPU |
//! | `testing` | test fixtures for every crate: the LRM-like test arm, random errors (feature `testing`) |
//!
//! Conventions (`docs/FORMATS.md` for the files, `docs/METHOD.md` for the
//! model): metres, radians, kilograms, microseconds;
//! `T(i-1,i) = Rz(q_i + theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`.
#![no_std]

#[cfg(test)]
extern crate std;

pub mod arm;
pub mod backlash;
pub mod bounds;
pub mod command;
pub mod compensation;
pub mod elastic;
pub mod kinematics;
pub mod option;
pub mod params;
pub mod per_joint;
pub mod servo;
pub mod statics;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod trig;

pub use arm::{Arm, Frame, Joint, JointKind};
pub use compensation::{Compensation, CompensationOptions, Evaluation, Linearisation, Slope};
pub use elastic::{Deflection, DeflectionError, SolverOptions};
pub use kinematics::{Chain, ChainFrames};
pub use option::ModelOption;
pub use params::{MAX_PARAMS, ParamId, param_count};
pub use per_joint::{ChainVec, MAX_JOINTS, PerFrame, PerJoint};
pub use servo::ServoCurve;
pub use statics::{Statics, Torques};

/// The float type the model is generic over: `f32` on the MCU, `f64` on the host.
pub trait Real: nalgebra::RealField + Copy + Default {
    /// `(sin x, cos x)` of a joint angle as the model evaluates it: the float's
    /// own in f64, [`trig::sin_cos_f32`] in f32 (libm's f32 functions compute
    /// in f64, which costs the FPU-less MCU ten times more).
    fn joint_sin_cos(self) -> (Self, Self);
}

impl Real for f64 {
    fn joint_sin_cos(self) -> (f64, f64) {
        nalgebra::ComplexField::sin_cos(self)
    }
}

impl Real for f32 {
    fn joint_sin_cos(self) -> (f32, f32) {
        trig::sin_cos_f32(self)
    }
}

/// Zero of the model's float type (a serde default for fields added later).
pub fn zero<T: Real>() -> T {
    T::zero()
}

/// Converts an `f64` constant into the model's float type.
#[inline]
pub fn real<T: Real>(x: f64) -> T {
    nalgebra::convert(x)
}
