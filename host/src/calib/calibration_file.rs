//! The calibration file (JSON): what `lrmcal identify` and `lrmcal demo`
//! write, `lrmcal validate` and `lrmcal predict` read, and the firmware
//! receives (the protocol crate converts [`CalibrationFile::arm`] to `f32`).
//!
//! It carries the *full* corrected arm (nominal + identified errors, the servo
//! curves inside each joint), the nominal arm it was identified from (so a
//! mismatched arm is caught), the option, every fitted parameter with its
//! standard deviation, the poses used and the statistics. Bump
//! [`SCHEMA_VERSION`] on any change that an older reader would misread.

use std::path::Path;

use model::{Arm, ParamId};
use serde::{Deserialize, Serialize};

use super::identify::{Estimate, Identified};
use super::validate::ErrorStats;
use super::{CalibError, ModelOption, ParamKey, ParamVector};

/// Name of the schema, so a JSON file of another kind is recognised as such.
pub const SCHEMA: &str = "lrmcal-calibration";
/// Version of the schema this build writes and reads.
pub const SCHEMA_VERSION: u32 = 1;

/// One fitted parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedParam {
    /// Stable parameter name (`j2.theta`, `k0`, …).
    pub name: String,
    /// Identified correction, SI units (m, rad, rad/Nm).
    pub error: f64,
    /// Nominal + correction, SI units.
    pub value: f64,
    /// One standard deviation of the correction; null when held at a bound.
    pub std: Option<f64>,
}

impl From<&Estimate> for FittedParam {
    fn from(e: &Estimate) -> Self {
        Self {
            name: e.id.name().into(),
            error: e.error,
            value: e.value,
            std: e.std,
        }
    }
}

/// The calibration of one arm for one model option.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// [`SCHEMA_VERSION`] of the writer.
    pub schema_version: u32,
    /// Model option that was identified.
    pub option: ModelOption,
    /// The nominal arm the errors are relative to.
    pub nominal: Arm<f64>,
    /// The corrected arm: nominal + identified errors, servo curves included.
    pub arm: Arm<f64>,
    /// Every fitted parameter.
    pub parameters: Vec<FittedParam>,
    /// Compliances held at zero by the non-negativity constraint.
    pub at_bound: Vec<String>,
    /// Candidate parameters left out as unidentifiable.
    pub removed: Vec<String>,
    /// Ids of the poses the fit used.
    pub poses_used: Vec<u32>,
    /// Payloads of the measurements the fit used, kg.
    pub loads_kg: Vec<f64>,
    /// Residual of the fit on its own measurements (3D error norm), m.
    pub fit_residual: ErrorStats,
    /// Validation on held-out measurements, when there were any.
    pub validation: Option<ValidationSummary>,
}

/// Before/after statistics on held-out measurements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationSummary {
    /// Payload of the validation measurements, kg.
    pub load_kg: f64,
    /// Nominal model.
    pub before: ErrorStats,
    /// Calibrated model.
    pub after: ErrorStats,
}

impl CalibrationFile {
    /// Assembles the file from an identification.
    pub fn new(
        nominal: &Arm<f64>,
        identified: &Identified,
        removed: &[ParamKey],
        poses_used: Vec<u32>,
        loads_kg: Vec<f64>,
        fit_residual: ErrorStats,
        validation: Option<ValidationSummary>,
    ) -> Self {
        Self {
            schema: SCHEMA.into(),
            schema_version: SCHEMA_VERSION,
            option: identified.option,
            nominal: *nominal,
            arm: identified.arm,
            parameters: identified.estimates.iter().map(FittedParam::from).collect(),
            at_bound: identified
                .diagnostics
                .at_bound
                .iter()
                .map(|p| p.name().into())
                .collect(),
            removed: removed.iter().map(|p| p.name().into()).collect(),
            poses_used,
            loads_kg,
            fit_residual,
            validation,
        }
    }

    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        // Serialising plain numbers, strings and vectors cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Parses and checks a calibration file's text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, CalibError> {
        let err = |message: String| CalibError::Json {
            path: path.to_owned(),
            message,
        };
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| err(format!("not JSON: {e}")))?;
        let schema = value.get("schema").and_then(|s| s.as_str());
        if schema != Some(SCHEMA) {
            return Err(err(format!(
                "expected \"schema\": \"{SCHEMA}\", found {schema:?}"
            )));
        }
        let version = value.get("schema_version").and_then(|v| v.as_u64());
        if version != Some(SCHEMA_VERSION as u64) {
            return Err(err(format!(
                "schema_version {version:?} is not the version {SCHEMA_VERSION} this lrmcal reads"
            )));
        }
        let file: Self = serde_json::from_str(text).map_err(|e| err(e.to_string()))?;
        if !file.arm.is_finite() || !file.nominal.is_finite() {
            return Err(err("an arm holds a non-finite number".into()));
        }
        let negative =
            file.arm.joints.iter().any(|j| j.compliance < 0.0) || file.arm.base_compliance < 0.0;
        if negative {
            return Err(err(
                "a compliance is negative; expected every compliance >= 0".into(),
            ));
        }
        ParamVector::<ParamKey>::from_named(
            file.parameters.iter().map(|p| (p.name.as_str(), p.error)),
        )
        .map_err(|e| err(e.to_string()))?;
        Ok(file)
    }

    /// Reads and checks a calibration file.
    pub fn read(path: &Path) -> Result<Self, CalibError> {
        let text = std::fs::read_to_string(path).map_err(|source| CalibError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Checks that this calibration was identified from `nominal`.
    pub fn check_nominal(&self, nominal: &Arm<f64>, path: &Path) -> Result<(), CalibError> {
        let ours = self.nominal.param_values();
        let theirs = nominal.param_values();
        for (id, (a, b)) in ParamId::all().zip(ours.iter().zip(&theirs)) {
            if (a - b).abs() > 1e-9 * (1.0 + a.abs()) {
                return Err(CalibError::ArmMismatch {
                    file: path.display().to_string(),
                    problem: format!(
                        "it was identified from another nominal arm ({id} is {a} there, {b} here); pass the arm it was made for with --arm"
                    ),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::identify::{Diagnostics, Estimate};
    use crate::calib::testing::rigid_nominal;

    fn sample_file() -> CalibrationFile {
        let nominal = rigid_nominal();
        let k2 = ParamId::from_name("k2").unwrap();
        let identified = Identified {
            option: ModelOption::Elastic,
            arm: nominal.with_errors(&[k2], &[0.1]),
            estimates: vec![Estimate {
                id: k2.into(),
                error: 0.1,
                value: 0.1,
                std: Some(1e-3),
            }],
            diagnostics: Diagnostics {
                termination: "Converged".into(),
                converged: true,
                evaluations: 3,
                active_set_rounds: 1,
                irls_rounds: 1,
                at_bound: vec![],
                rms_before_m: 0.01,
                rms_after_m: 0.001,
                sigma_m: 0.001,
                condition: 1.0,
            },
            fit_residual: ErrorStats::of(&[0.001]),
            outliers: vec![],
        };
        let stats = ErrorStats::of(&[0.001]);
        CalibrationFile::new(
            &nominal,
            &identified,
            &[],
            vec![1, 2],
            vec![0.0663],
            stats,
            None,
        )
    }

    #[test]
    fn round_trips_and_checks_its_nominal_arm() {
        let file = sample_file();
        let path = Path::new("cal.json");
        let back = CalibrationFile::parse(&file.to_json(), path).unwrap();
        assert_eq!(back, file);
        assert!(back.check_nominal(&rigid_nominal(), path).is_ok());
        let mut other = rigid_nominal();
        other.joints[2].a += 0.01;
        let err = back.check_nominal(&other, path).unwrap_err().to_string();
        assert!(err.contains("cal.json") && err.contains("j3.a"), "{err}");
    }

    #[test]
    fn rejects_other_schemas_versions_and_bad_values() {
        let path = Path::new("cal.json");
        let json = sample_file().to_json();
        let e = CalibrationFile::parse("{\"a\": 1}", path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("schema") && e.contains("cal.json"), "{e}");
        let e = CalibrationFile::parse(
            &json.replace("\"schema_version\": 1", "\"schema_version\": 9"),
            path,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("schema_version"), "{e}");
        let e = CalibrationFile::parse(&json.replacen("\"k2\"", "\"k9\"", 1), path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("k9"), "{e}");
        let e = CalibrationFile::parse(&json[..json.len() / 2], path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not JSON"), "{e}");
    }
}
