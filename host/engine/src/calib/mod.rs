//! The calibration engine (levels 2 and 3 of `docs/METHOD.md`): which error
//! parameters the measurements can identify, which poses to measure, the fit
//! itself and how good the result is.
//!
//! Four rooms, in the order a calibration goes through them:
//!
//! | folder | what it holds |
//! |---|---|
//! | [`parameters`] | what may be corrected: the registry of free parameters, each option's candidates, the rig (arm and tool points), servo knots, play |
//! | [`analysis`] | what the poses can tell: the Jacobian, the rank analysis, observability, DETMAX |
//! | [`fit`] | registration, the fit, its refresh and knot choice, validation, the stages chained for one option |
//! | [`results`] | what a run gives people and files: calibration file content, report, printed lines, the demo's study |
//!
//! [`run`] chains them into one calibration run, as `lrmcal identify` asks
//! for it, beside [`error`] and [`progress`] (how long steps report progress
//! without a terminal).
//!
//! Each stage is a plain function over `model` types so it can be tested and
//! benchmarked alone; the command line's subcommands only read files,
//! call these and write files.

pub mod analysis;
pub mod error;
pub mod fit;
pub mod parameters;
pub mod progress;
pub mod results;
pub mod run;
#[cfg(test)]
mod testing;

pub use error::CalibError;
pub use model::ModelOption;
pub use parameters::params::{ParamKey, ParamVector};
pub use parameters::targets::Rig;

/// A commanded pose under a given payload: one 3-row block of the identification Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Pose id, for messages.
    pub id: u32,
    /// Commanded joint angles, rad.
    pub q: model::PerJoint<f64>,
    /// Payload at the tool, kg.
    pub load_kg: f64,
    /// Index of the measured target in its [`Rig`] (0: the arm's tool point).
    pub target: usize,
    /// The way each joint arrived at the pose (its backlash's side).
    pub approach: model::PerJoint<model::backlash::Approach>,
}

/// A measurement as a sample of target 0; `targets::Targets::samples` gives
/// each its own target.
impl From<&lrmcal_core::dataset::Measurement> for Sample {
    fn from(m: &lrmcal_core::dataset::Measurement) -> Self {
        Sample {
            id: m.pose.id,
            q: m.pose.q,
            load_kg: m.load_kg,
            target: 0,
            approach: m.approach,
        }
    }
}

/// A camera's view as a sample of target 0: the pose it was taken at.
impl From<&lrmcal_core::camera::views::View> for Sample {
    fn from(v: &lrmcal_core::camera::views::View) -> Self {
        Sample {
            id: v.pose.id,
            q: v.pose.q,
            load_kg: v.load_kg,
            target: 0,
            approach: v.approach,
        }
    }
}
