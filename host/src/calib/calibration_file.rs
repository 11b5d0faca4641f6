//! The calibration file (JSON): what `lrmcal identify` and `lrmcal demo`
//! write, `lrmcal validate` and `lrmcal predict` read, and the firmware
//! receives (the protocol crate converts [`CalibrationFile::arm`] to `f32`).
//!
//! It carries the *full* corrected arm (nominal + identified errors, the servo
//! curves inside each joint), the nominal arm it was identified from (so a
//! mismatched arm is caught), the option, every fitted parameter with its
//! standard deviation, the poses used and the statistics. Bump
//! [`SCHEMA_VERSION`] on any change that an older reader would misread.
//!
//! Version 2 writes each servo curve as its knots (`angles_rad`,
//! `pulses_us`); version 1 files, whose curves are the pulses at -100°, 0° and
//! +100° (`minus100`, `zero`, `plus100`), still read, as the same curves.

use std::path::Path;

use model::{Arm, ParamId, ServoCurve};
use serde::{Deserialize, Serialize};

use super::identify::{Estimate, Identified};
use super::validate::ErrorStats;
use super::{CalibError, ModelOption};

/// Name of the schema, so a JSON file of another kind is recognised as such.
pub const SCHEMA: &str = "lrmcal-calibration";
/// Version of the schema this build writes (and the newest it reads).
pub const SCHEMA_VERSION: u32 = 2;
/// The oldest version this build reads.
pub const OLDEST_SCHEMA_VERSION: u32 = 1;

/// A servo curve as schema 1 wrote it: the pulses at -100°, 0° and +100°.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ThreePoints {
    minus100: f64,
    zero: f64,
    plus100: f64,
}

/// Rewrites the servo curves of a schema-1 file's two arms as knots, so the
/// rest of it reads like a schema-2 file.
fn upgrade_servo_curves(value: &mut serde_json::Value) -> Result<(), String> {
    for arm in ["nominal", "arm"] {
        let joints = value
            .get_mut(arm)
            .and_then(|a| a.get_mut("joints"))
            .and_then(|j| j.as_array_mut());
        // Missing pieces are reported by the typed read that follows.
        for (i, joint) in joints.into_iter().flatten().enumerate() {
            let Some(servo) = joint.get_mut("servo") else {
                continue;
            };
            let three: ThreePoints = serde_json::from_value(servo.take()).map_err(|e| {
                format!(
                    "{arm}.joints[{}].servo: expected the pulses minus100, zero and plus100 of a schema-1 file: {e}",
                    i + 1
                )
            })?;
            let curve = ServoCurve::from_three_points(three.minus100, three.zero, three.plus100);
            *servo = serde_json::to_value(curve).map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

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
        removed: &[ParamId],
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
        let file: Self = match version {
            Some(v) if v == u64::from(SCHEMA_VERSION) => {
                serde_json::from_str(text).map_err(|e| err(e.to_string()))?
            }
            Some(1) => {
                let mut value = value;
                upgrade_servo_curves(&mut value).map_err(err)?;
                if let Some(v) = value.get_mut("schema_version") {
                    *v = SCHEMA_VERSION.into();
                }
                serde_path_to_error::deserialize(value)
                    .map_err(|e| err(format!("{}: {}", e.path(), e.inner())))?
            }
            _ => {
                return Err(err(format!(
                    "schema_version {version:?} is not one of the versions {OLDEST_SCHEMA_VERSION} to {SCHEMA_VERSION} this lrmcal reads"
                )));
            }
        };
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
        for p in &file.parameters {
            if ParamId::from_name(&p.name).is_none() {
                return Err(err(format!("unknown parameter name `{}`", p.name)));
            }
        }
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
                id: k2,
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
            &json.replace("\"schema_version\": 2", "\"schema_version\": 9"),
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

    #[test]
    fn schema_1_files_read_as_the_same_curves() {
        let mut file = sample_file();
        file.arm.joints[1].servo = ServoCurve::from_three_points(880.5, 1640.25, 2410.125);
        let json = file.to_json();
        assert!(json.contains("\"schema_version\": 2") && json.contains("\"angles_rad\""));
        // The same file as schema 1 wrote it: each curve as its three pulses.
        let mut v1: serde_json::Value = serde_json::from_str(&json).unwrap();
        v1["schema_version"] = 1.into();
        for arm in ["nominal", "arm"] {
            for joint in v1[arm]["joints"].as_array_mut().unwrap() {
                let p = joint["servo"]["pulses_us"].clone();
                joint["servo"] =
                    serde_json::json!({ "minus100": p[0], "zero": p[1], "plus100": p[2] });
            }
        }
        let path = Path::new("old.json");
        let text = serde_json::to_string_pretty(&v1).unwrap();
        assert!(text.contains("\"minus100\": 880.5"), "{text}");
        assert_eq!(CalibrationFile::parse(&text, path).unwrap(), file);

        v1["arm"]["joints"][2]["servo"] = serde_json::json!({ "minus100": 900.0, "zero": 1650.0 });
        let text = serde_json::to_string_pretty(&v1).unwrap();
        let e = CalibrationFile::parse(&text, path).unwrap_err().to_string();
        assert!(
            e.contains("old.json") && e.contains("arm.joints[3].servo") && e.contains("plus100"),
            "{e}"
        );
        // A schema-2 file must hold knots: the three points alone are refused.
        v1["schema_version"] = 2.into();
        v1["arm"]["joints"][2]["servo"] =
            serde_json::json!({ "minus100": 900.0, "zero": 1650.0, "plus100": 2400.0 });
        let e = CalibrationFile::parse(&serde_json::to_string(&v1).unwrap(), path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("minus100"), "{e}");
    }
}
