//! The calibration file (JSON): what `lrmcal identify` and `lrmcal demo`
//! write, `lrmcal validate`, `predict` and `push` read, and the firmware
//! receives (the device module converts [`CalibrationFile::arm`] to `f32`).
//!
//! It carries the *full* corrected arm (nominal + identified errors, the servo
//! curves inside each joint), the nominal arm it was identified from (so a
//! mismatched arm is caught), the option, every fitted parameter with its
//! standard deviation, the poses used and the statistics. The engine fills it
//! from its results (`crate::calib::export`); this module owns the format.
//! Bump [`SCHEMA_VERSION`] on any change that an older reader would misread.
//!
//! Version 2 writes each servo curve as its knots (`angles_rad`,
//! `pulses_us`); version 1 files, whose curves are the pulses at -100°, 0° and
//! +100° (`minus100`, `zero`, `plus100`), still read, as the same curves.

use std::path::Path;

use crate::io::model_option::{ModelOption, servo_knot_from_name};
use model::{Arm, ParamId, ServoCurve};
use serde::{Deserialize, Serialize};

use super::{json, read_text};
use crate::error::{Error, InputError, Location, Problem};

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
fn upgrade_servo_curves(value: &mut serde_json::Value) -> Result<(), InputError> {
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
                InputError::new(
                    Location::key(None, format!("{arm}.joints[{}].servo", i + 1)),
                    Problem::Syntax {
                        message: format!(
                            "expected the pulses minus100, zero and plus100 of a schema-1 file: {e}"
                        ),
                    },
                )
            })?;
            let curve = ServoCurve::from_three_points(three.minus100, three.zero, three.plus100);
            *servo = serde_json::to_value(curve).expect("a servo curve always serialises");
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

/// Statistics of a set of 3D error norms, m.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorStats {
    /// Number of measurements.
    pub count: usize,
    /// Mean, m.
    pub mean_m: f64,
    /// Median, m.
    pub median_m: f64,
    /// Root mean square, m.
    pub rms_m: f64,
    /// 95th percentile (linear interpolation between order statistics), m.
    pub p95_m: f64,
    /// Largest, m.
    pub max_m: f64,
}

impl ErrorStats {
    /// Statistics of `norms` (m); all zero for an empty set.
    pub fn of(norms: &[f64]) -> Self {
        let mut v = norms.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let quantile = |p: f64| {
            if n == 0 {
                return 0.0;
            }
            let x = p * (n - 1) as f64;
            let (lo, hi) = (x.floor() as usize, x.ceil() as usize);
            v[lo] + (v[hi] - v[lo]) * (x - lo as f64)
        };
        let mean = if n == 0 {
            0.0
        } else {
            v.iter().sum::<f64>() / n as f64
        };
        let rms = if n == 0 {
            0.0
        } else {
            (v.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt()
        };
        Self {
            count: n,
            mean_m: mean,
            median_m: quantile(0.5),
            rms_m: rms,
            p95_m: quantile(0.95),
            max_m: v.last().copied().unwrap_or(0.0),
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
    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        json::to_pretty(self)
    }

    /// Parses and checks a calibration file's text.
    pub fn parse(text: &str) -> Result<Self, InputError> {
        let file: Self = json::parse_upgrading(
            text,
            SCHEMA,
            OLDEST_SCHEMA_VERSION..=SCHEMA_VERSION,
            |_, value| upgrade_servo_curves(value),
        )?;
        for (which, arm) in [("nominal", &file.nominal), ("arm", &file.arm)] {
            let compliances = arm.joints.iter().map(|j| j.compliance);
            let negative = compliances
                .enumerate()
                .map(|(i, k)| (format!("{which}.joints[{}].compliance", i + 1), k))
                .chain([(format!("{which}.base_compliance"), arm.base_compliance)])
                .find(|(_, k)| *k < 0.0);
            if let Some((key, k)) = negative {
                return Err(InputError::new(
                    Location::key(None, key),
                    Problem::OutOfRange {
                        expected: "a compliance >= 0 rad/Nm",
                        found: k.to_string(),
                    },
                ));
            }
        }
        for (i, p) in file.parameters.iter().enumerate() {
            let repeated = file.parameters[..i].iter().any(|q| q.name == p.name);
            let known =
                ParamId::from_name(&p.name).is_some() || servo_knot_from_name(&p.name).is_some();
            if !known || repeated {
                return Err(InputError::new(
                    Location::key(None, format!("parameters[{}].name", i + 1)),
                    Problem::OutOfRange {
                        expected: "a parameter name (j1.theta … j6.alpha, base.x … tool.yaw, k0 … k6, j1.servo[1] … j6.servo[9]), each once",
                        found: format!("`{}`", p.name),
                    },
                ));
            }
        }
        Ok(file)
    }

    /// Reads and checks a calibration file.
    pub fn read(path: &Path) -> Result<Self, Error> {
        Self::parse(&read_text(path)?).map_err(|e| e.in_file(path))
    }

    /// Checks that this calibration (read from `path`) was identified from `nominal`.
    pub fn check_nominal(&self, nominal: &Arm<f64>, path: &Path) -> Result<(), Error> {
        let ours = self.nominal.param_values();
        let theirs = nominal.param_values();
        for (id, (a, b)) in ParamId::all().zip(ours.iter().zip(&theirs)) {
            if (a - b).abs() > 1e-9 * (1.0 + a.abs()) {
                return Err(Error::ArmMismatch {
                    path: path.to_owned(),
                    problem: format!(
                        "it was identified from another nominal arm ({id} is {a} there, {b} here); pass the arm it was made for with --arm"
                    ),
                });
            }
        }
        Ok(())
    }
}

/// A calibration file for the unit tests of `io`.
#[cfg(test)]
pub(super) mod test_support {
    use super::*;
    use crate::io::arm_source::{DEFAULT_ARM, bundled};

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
                name: "k2".into(),
                error: 0.1,
                value: 0.1,
                std: Some(1e-3),
            }],
            at_bound: vec![],
            removed: vec!["k1".into()],
            poses_used: vec![1, 2],
            loads_kg: vec![0.0663],
            fit_residual: ErrorStats::of(&[0.001]),
            validation: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::sample_file;
    use super::*;

    #[test]
    fn round_trips_and_checks_its_nominal_arm() {
        let file = sample_file();
        let json = file.to_json();
        assert!(json.contains("\"option\": \"elastic\""), "{json}");
        let back = CalibrationFile::parse(&json).unwrap();
        assert_eq!(back, file);
        let path = Path::new("cal.json");
        assert!(back.check_nominal(&file.nominal, path).is_ok());
        let mut other = file.nominal;
        other.joints[2].a += 0.01;
        let err = back.check_nominal(&other, path).unwrap_err();
        assert_eq!(err.exit_code(), crate::error::exit_codes::INVALID_INPUT);
        let err = err.report();
        assert!(err.contains("cal.json") && err.contains("j3.a"), "{err}");
    }

    /// Each refusal names the key (and the line, where the JSON text has one).
    #[test]
    fn rejects_other_schemas_versions_and_bad_values() {
        let json = sample_file().to_json();
        let refused = |text: &str| CalibrationFile::parse(text).unwrap_err().to_string();
        let e = refused("{\"a\": 1}");
        assert!(e.contains("key `schema`") && e.contains(SCHEMA), "{e}");
        let e = refused(&json.replace("\"schema_version\": 2", "\"schema_version\": 9"));
        assert!(e.contains("key `schema_version`") && e.contains('9'), "{e}");
        let e = refused(&json.replacen("\"k2\"", "\"k9\"", 1));
        assert!(
            e.contains("key `parameters[1].name`") && e.contains("k9"),
            "{e}"
        );
        let e = refused(&json.replacen("\"compliance\": 0.1", "\"compliance\": -0.1", 1));
        assert!(e.contains("key `arm.joints[2].compliance`"), "{e}");
        let e = refused(&json.replacen("\"elastic\"", "\"rigid\"", 1));
        assert!(
            e.contains("key `option`") && e.contains("rigid") && e.contains("line 4"),
            "{e}"
        );
        let e = refused(&json.replacen("\"mean_m\"", "\"mean_mm\"", 1));
        assert!(e.contains("key `fit_residual.mean_mm`"), "{e}");
        let e = refused(&json[..json.len() / 2]);
        assert!(e.contains("not JSON"), "{e}");
        // JSON has no NaN or infinity; a number too large for f64 is refused.
        let e = refused(&json.replacen("0.1", "1e999", 1));
        assert!(e.contains("not JSON") && e.contains("number"), "{e}");
    }

    #[test]
    fn statistics_of_a_known_set() {
        let s = ErrorStats::of(&[4.0, 1.0, 3.0, 2.0, 5.0]);
        assert_eq!(s.count, 5);
        assert!((s.mean_m - 3.0).abs() < 1e-12);
        assert!((s.median_m - 3.0).abs() < 1e-12);
        assert!((s.rms_m - 11f64.sqrt()).abs() < 1e-12);
        assert!((s.p95_m - 4.8).abs() < 1e-12);
        assert_eq!(s.max_m, 5.0);
        assert_eq!(ErrorStats::of(&[]).count, 0);
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
        let text = serde_json::to_string_pretty(&v1).unwrap();
        assert!(text.contains("\"minus100\": 880.5"), "{text}");
        assert_eq!(CalibrationFile::parse(&text).unwrap(), file);

        v1["arm"]["joints"][2]["servo"] = serde_json::json!({ "minus100": 900.0, "zero": 1650.0 });
        let text = serde_json::to_string_pretty(&v1).unwrap();
        let e = CalibrationFile::parse(&text).unwrap_err().to_string();
        assert!(
            e.contains("arm.joints[3].servo") && e.contains("plus100"),
            "{e}"
        );
        // A schema-2 file must hold knots: the three points alone are refused.
        v1["schema_version"] = 2.into();
        v1["arm"]["joints"][2]["servo"] =
            serde_json::json!({ "minus100": 900.0, "zero": 1650.0, "plus100": 2400.0 });
        let e = CalibrationFile::parse(&serde_json::to_string(&v1).unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("minus100"), "{e}");
    }
}
