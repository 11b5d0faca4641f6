//! The calibration engine (levels 2 and 3 of `docs/METHOD.md`): which error
//! parameters the measurements can identify, which poses to measure, the fit
//! itself and how good the result is.
//!
//! | module | stage |
//! |---|---|
//! | [`params`] | the free parameters: typed keys and the registry of their values |
//! | [`option`] | the candidate parameters of each model option |
//! | [`jacobian`] | d(measured point)/d(parameters, joint angles), exact through the elastic model |
//! | [`servo_knots`] | each servo's own curve between its tuned points: the knot offsets |
//! | [`backlash`] | each joint's play, from the order the poses were visited |
//! | `joint_columns` | the Jacobian columns of knots and play, from one joint-angle column per joint |
//! | [`identifiability`] | the largest identifiable parameter subset, by rank analysis |
//! | [`observability`] | column scaling and the observability indices O1..O5 |
//! | [`detmax`] | D-optimal pose selection by Mitchell's DETMAX exchange |
//! | [`identify`] | Levenberg–Marquardt fit in named steps: active set for bounds, robust option |
//! | [`refresh`] | the rank analysis again at the estimate, and the fit with what it adds |
//! | [`knot_choice`] | the servo curves' knot spacing whose fit best predicts the poses it leaves out |
//! | [`validate`] | error statistics before/after on held-out poses |
//! | [`registration`] | the arm's base in the tracker's frame, from the measurements (closed form, trimmed) |
//! | [`checks`] | measurements that cannot be right, poses that are not candidates |
//! | [`targets`] | several measured targets per pose: one arm, a tool point each |
//! | [`pipeline`] | select → identify → validate for one option |
//! | [`study`] | the demo's study of one arm: every option, both cross-load directions, the experiments |
//! | [`experiments`] | DETMAX against random selections, O1 and the error against the number of poses |
//! | [`export`] | the results as the file formats of `lrmcal_core::io` hold them (calibration file) |
//! | [`report`] | the machine-readable report, schema header included |
//! | [`summary`] | the paper-style table and the lines the commands print |
//! | [`progress`] | how long steps report progress without a terminal |
//!
//! Each stage is a plain function over `model` types so it can be tested and
//! benchmarked alone; the command line's subcommands only read files,
//! call these and write files.

pub mod backlash;
pub mod checks;
pub mod detmax;
pub mod error;
pub mod experiments;
pub mod export;
pub mod identifiability;
pub mod identify;
pub mod jacobian;
mod joint_columns;
pub mod knot_choice;
pub mod observability;
pub mod option;
pub mod params;
pub mod pipeline;
pub mod progress;
pub mod refresh;
pub mod registration;
pub mod report;
pub mod servo_knots;
pub mod study;
pub mod summary;
pub mod targets;
#[cfg(test)]
mod testing;
pub mod tool_only;
pub mod validate;

pub use error::CalibError;
pub use params::{ParamKey, ParamVector};
pub use protocol::ModelOption;
pub use targets::Rig;

/// A commanded pose under a given payload: one 3-row block of the identification Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Pose id, for messages.
    pub id: u32,
    /// Commanded joint angles, rad.
    pub q: [f64; model::JOINTS],
    /// Payload at the tool, kg.
    pub load_kg: f64,
    /// Index of the measured target in its [`Rig`] (0: the arm's tool point).
    pub target: usize,
    /// The way each joint arrived at the pose (its backlash's side).
    pub approach: [model::backlash::Approach; model::JOINTS],
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
