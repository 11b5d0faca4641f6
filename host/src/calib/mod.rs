//! The calibration engine (levels 2 and 3 of `docs/METHOD.md`): which error
//! parameters the measurements can identify, which poses to measure, the fit
//! itself and how good the result is.
//!
//! | module | stage |
//! |---|---|
//! | [`option`] | the three model options and their candidate parameters |
//! | [`jacobian`] | d(measured point)/d(error parameters), through the elastic model |
//! | [`identifiability`] | the largest identifiable parameter subset, by rank analysis |
//! | [`observability`] | column scaling and the observability indices O1..O5 |
//! | [`detmax`] | D-optimal pose selection by Mitchell's DETMAX exchange |
//! | [`identify`] | Levenberg–Marquardt fit with non-negative compliances, robust option |
//! | [`validate`] | error statistics before/after on held-out poses |
//! | [`checks`] | measurements that cannot be right, poses that are not candidates |
//! | [`export`] | the results as the file formats of `crate::io` hold them (calibration file) |
//! | [`report`] | the machine-readable report and the paper-style table |
//! | [`plots`] | the figures a person looks at first (SVG + PNG) |
//! | [`pipeline`] | select → identify → validate for one option, as the demo runs it |
//!
//! Each stage is a plain function over `model` types so it can be tested and
//! benchmarked alone; the subcommands in `crate::commands` only read files,
//! call these and write files.

pub mod checks;
pub mod detmax;
pub mod error;
pub mod export;
pub mod identifiability;
pub mod identify;
pub mod jacobian;
pub mod observability;
pub mod option;
pub mod pipeline;
pub mod plots;
pub mod report;
#[cfg(test)]
mod testing;
pub mod validate;

pub use error::CalibError;
pub use option::ModelOption;

/// A commanded pose under a given payload: one 3-row block of the identification Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Pose id, for messages.
    pub id: u32,
    /// Commanded joint angles, rad.
    pub q: [f64; model::JOINTS],
    /// Payload at the tool, kg.
    pub load_kg: f64,
}

impl From<&crate::dataset::Measurement> for Sample {
    fn from(m: &crate::dataset::Measurement) -> Self {
        Sample {
            id: m.pose.id,
            q: m.pose.q,
            load_kg: m.load_kg,
        }
    }
}
