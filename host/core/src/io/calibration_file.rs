//! The calibration file (JSON): what `lrmcal identify` and `lrmcal demo`
//! write, `lrmcal validate`, `predict` and `push` read, and the firmware
//! receives (the device module converts [`CalibrationFile::arm`] to `f32`).
//!
//! It carries the *full* corrected arm (nominal + identified errors, the servo
//! curves inside each joint), the nominal arm it was identified from (so a
//! mismatched arm is caught), the option, every fitted parameter with its
//! standard deviation, the poses used and the statistics, and, when the
//! measurements named several targets (or the tool was re-taught), every
//! target's tool point: the board compensates one of them
//! ([`CalibrationFile::for_target`]), with the nominal arm standing where the
//! calibrated one does ([`CalibrationFile::board_arms`]). The engine fills it from its
//! results (`lrmcal_engine::calib::results::export`); this module owns the format.
//! Bump [`SCHEMA_VERSION`] on any change that an older reader would misread.
//!
//! Version 2 writes each servo curve as its knots (`angles_rad`,
//! `pulses_us`); version 1 files, whose curves are the pulses at -100°, 0° and
//! +100° (`minus100`, `zero`, `plus100`), still read, as the same curves.
//! Version 3 adds [`CalibrationFile::registration`]; files of versions 1
//! and 2 read without one. Version 4 gives the arms their rated payload
//! (`rated_payload_kg`, the load the physical bounds of `model::bounds` hold
//! up to; files of earlier versions read with 0) and means the servo curves
//! for every reader: a calibrated curve says where the nominal curve's pulse
//! really goes (`model::command`). Version 5 writes `"servo": null` for a
//! joint no servo of ours drives (an arm moved by its own controller), where
//! earlier versions wrote a curve of all pulses 0: such a curve reads as none.
//!
//! This file holds the file's top-level type and how it serves a target and
//! the board; the records it is made of ([`FittedParam`], [`ErrorStats`],
//! …), the reading and checking of its text (`read`), the upgrade of older
//! versions (`upgrade`) and the checks against the arm a command is given
//! (`nominal`) have files of their own.

use model::{Arm, ModelOption};
use serde::{Deserialize, Serialize};

use super::json;

mod nominal;
mod parts;
mod read;
mod upgrade;

pub use parts::{ErrorStats, FittedParam, RegistrationRecord, TargetTool, ValidationSummary};

/// Name of the schema, so a JSON file of another kind is recognised as such.
pub const SCHEMA: &str = "lrmcal-calibration";
/// Version of the schema this build writes (and the newest it reads).
pub const SCHEMA_VERSION: u32 = 5;
/// The oldest version this build reads.
pub const OLDEST_SCHEMA_VERSION: u32 = 1;

/// The calibration of one arm for one model option.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// [`SCHEMA_VERSION`] of the writer.
    pub schema_version: u32,
    /// Model option that was identified.
    #[serde(with = "crate::io::model_option")]
    pub option: ModelOption,
    /// The nominal arm the errors are relative to.
    pub nominal: Arm<f64>,
    /// The corrected arm: nominal + identified errors, servo curves included.
    pub arm: Arm<f64>,
    /// Every fitted parameter.
    pub parameters: Vec<FittedParam>,
    /// Compliances held at zero by the non-negativity constraint.
    pub at_bound: Vec<String>,
    /// Candidate parameters held at their nominal values: removed by the
    /// rank analysis and not fitted by its refresh at the estimate.
    pub removed: Vec<String>,
    /// Ids of the poses the fit used.
    pub poses_used: Vec<u32>,
    /// Payloads of the measurements the fit used, kg.
    pub loads_kg: Vec<f64>,
    /// Residual of the fit on its own measurements (3D error norm), m.
    pub fit_residual: ErrorStats,
    /// Whether the fit converged. `lrmcal identify` writes no calibration of
    /// a fit that did not, and `push` refuses a file that says so; true in
    /// files written before it was recorded.
    #[serde(default = "converged_when_unrecorded")]
    pub converged: bool,
    /// Validation on held-out measurements, when there were any.
    pub validation: Option<ValidationSummary>,
    /// The measured targets, in the order the measurements named them; absent
    /// for one unnamed target (the arm's tool point). The first is the
    /// arm's tool point and what the board compensates unless
    /// `lrmcal push --target` names another.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<TargetTool>,
    /// Where `identify` found the arm's base in the measurement frame, and
    /// from what; `None` in files of versions 1 and 2 and in the demo's
    /// (which measures in the arm file's own frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub registration: Option<RegistrationRecord>,
    /// The name of the arm it was made for (the arm file's `name`, the
    /// bundled arm's, the URDF's robot); absent in files written before it
    /// was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arm_name: Option<String>,
    /// Its joints' names, base to tip, one per joint (the arm file's, the
    /// URDF's): what `export --urdf`, `move` and the page call them without
    /// the arm file; empty in files written before they were recorded.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joint_names: Vec<String>,
}

/// What a file written before convergence was recorded says of it: only
/// converged fits are pushed since.
fn converged_when_unrecorded() -> bool {
    true
}

impl CalibrationFile {
    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        json::to_pretty(self)
    }

    /// The calibration as it serves the target called `name` (the first
    /// without one): both arms carry that target's tool point, so the board
    /// puts that target where the nominal arm's tool point would be. A file
    /// without targets is itself, and refuses any name.
    pub fn for_target(&self, name: Option<&str>) -> Result<Self, String> {
        let chosen = match name {
            None => self.targets.first(),
            Some(name) => Some(self.targets.iter().find(|t| t.name == name).ok_or_else(|| {
                if self.targets.is_empty() {
                    format!(
                        "it has no target `{name}`: it was identified from measurements without a \
                         `target` column, so it has the one tool point; leave out --target"
                    )
                } else {
                    let names: Vec<&str> = self.targets.iter().map(|t| t.name.as_str()).collect();
                    format!(
                        "it has no target `{name}`; its targets are {}",
                        names.join(", ")
                    )
                }
            })?),
        };
        let mut file = self.clone();
        if let Some(target) = chosen {
            file.nominal.tool.xyz = target.tool_m;
            file.arm.tool.xyz = target.tool_m;
        }
        Ok(file)
    }

    /// The nominal and calibrated arms the board gets: the calibrated arm,
    /// and the nominal arm standing on the calibrated arm's base. The board
    /// makes the real arm put its tool where this nominal arm would: the
    /// arm's geometry, stiffness and servos are what it corrects, while
    /// where the arm stands is a fact of the setup that the fit found, not
    /// an error for the joints to make up. The file's own nominal arm stands
    /// where registration put it (a rigid fit of a deflected arm, centimetres
    /// low when the arm sags) or where the arm file said: right for the
    /// error before calibration, wrong as the place the joints reach from.
    /// Only the base moves: the physical bounds the board checks do not
    /// depend on it, so the board works out the bounds every reader does.
    pub fn board_arms(&self) -> (Arm<f64>, Arm<f64>) {
        let mut nominal = self.nominal;
        nominal.base = self.arm.base;
        (nominal, self.arm)
    }

    /// The joints' names it records, or `joint_1` … for a file that holds none.
    pub fn joint_names_or_numbered(&self) -> Vec<String> {
        if self.joint_names.is_empty() {
            (1..=self.arm.joints.len())
                .map(|i| format!("joint_{i}"))
                .collect()
        } else {
            self.joint_names.clone()
        }
    }

    /// The same file, knowing the arm it was made for: its name and its
    /// joints' names (one per joint).
    pub fn for_arm(self, name: &str, joint_names: &[String]) -> Self {
        Self {
            arm_name: Some(name.to_owned()),
            joint_names: joint_names.to_vec(),
            ..self
        }
    }

    /// The same file recording `registration`.
    pub fn with_registration(self, registration: RegistrationRecord) -> Self {
        Self {
            registration: Some(registration),
            ..self
        }
    }
}

/// A calibration file for the unit tests of `io`.
#[cfg(test)]
pub(super) mod test_support {
    use super::*;
    use crate::io::arm_source::{DEFAULT_ARM, bundled};
    use crate::param_key::ParamKey;

    /// A calibration of the bundled arm whose joint 2 compliance was identified.
    pub fn sample_file() -> CalibrationFile {
        let nominal = bundled(DEFAULT_ARM).unwrap().arm;
        let mut arm = nominal;
        arm.joints[1].compliance = 0.1;
        CalibrationFile {
            schema: SCHEMA.into(),
            schema_version: SCHEMA_VERSION,
            option: ModelOption::Elastic,
            nominal,
            arm,
            parameters: vec![FittedParam {
                name: ParamKey::from_name("k2").unwrap(),
                error: 0.1,
                value: 0.1,
                std: Some(1e-3),
            }],
            at_bound: vec![],
            removed: vec!["k1".into()],
            poses_used: vec![1, 2],
            loads_kg: vec![0.0663],
            fit_residual: ErrorStats::of(&[0.001]),
            converged: true,
            validation: None,
            registration: None,
            targets: vec![],
            arm_name: None,
            joint_names: vec![],
        }
    }
}

#[cfg(test)]
mod tests;
