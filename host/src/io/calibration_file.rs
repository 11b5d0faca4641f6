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
//! Version 2 added [`CalibrationFile::registration`]; version 1 files are
//! still read (without one).

use std::path::Path;

use model::{Arm, Frame, ParamId};
use nalgebra::{Point3, Vector3};
use protocol::ModelOption;
use serde::{Deserialize, Serialize};

use super::{json, read_text};
use crate::error::{Error, InputError, Location, Problem};

/// Name of the schema, so a JSON file of another kind is recognised as such.
pub const SCHEMA: &str = "lrmcal-calibration";
/// Version of the schema this build writes and reads.
pub const SCHEMA_VERSION: u32 = 2;
/// The oldest version this build still reads.
pub const OLDEST_READ_VERSION: u32 = 1;

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
    #[serde(with = "json::model_option")]
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
    /// Where the arm stood in the measurement frame; `None` in files of
    /// version 1 and in the demo's (which measures in the arm's own frame).
    #[serde(default)]
    pub registration: Option<RegistrationRecord>,
}

/// The arm's place in the measurement frame, as `lrmcal identify` found it.
///
/// `nominal` and `arm` stay in the arm file's world frame (the board and
/// `predict` work there); `frame` carries them into the measurement frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegistrationRecord {
    /// Whether the base was registered (false: `--no-register`, the arm file's base kept).
    pub registered: bool,
    /// The arm file's world frame in the measurement frame (m, rad).
    pub frame: Frame<f64>,
    /// The calibrated arm's frame 0 in the measurement frame (m, rad): the registered base, refined by the fit.
    pub base: Frame<f64>,
    /// Gravity in the measurement frame, m/s².
    pub gravity: [f64; 3],
    /// RMS distance of the nominal arm from the measurements as the arm file placed it, m.
    pub before_rms_m: f64,
    /// The same after registration, over the points it kept, m.
    pub after_rms_m: f64,
    /// Poses left out of the registration as far off.
    pub trimmed: Vec<u32>,
}

impl RegistrationRecord {
    /// A point of the measurement frame in the arm file's world frame, m.
    pub fn to_arm_frame(&self, position: &Vector3<f64>) -> Vector3<f64> {
        self.frame
            .isometry()
            .inverse_transform_point(&Point3::from(*position))
            .coords
    }
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
        let file: Self = json::parse_versions(text, SCHEMA, OLDEST_READ_VERSION..=SCHEMA_VERSION)?;
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
            if ParamId::from_name(&p.name).is_none() || repeated {
                return Err(InputError::new(
                    Location::key(None, format!("parameters[{}].name", i + 1)),
                    Problem::OutOfRange {
                        expected: "a parameter name (j1.theta … j6.alpha, base.x … tool.yaw, k0 … k6), each once",
                        found: format!("`{}`", p.name),
                    },
                ));
            }
        }
        Ok(file)
    }

    /// The same file recording `registration`.
    pub fn with_registration(self, registration: RegistrationRecord) -> Self {
        Self {
            registration: Some(registration),
            ..self
        }
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
            registration: None,
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

    /// A version 1 file (no registration) still reads; a registration
    /// carries measured points back into the arm's frame.
    #[test]
    fn reads_version_1_and_records_the_registration() {
        let file = sample_file();
        let v1 = file
            .to_json()
            .replace("\"schema_version\": 2", "\"schema_version\": 1")
            .replace(",\n  \"registration\": null", "");
        assert!(!v1.contains("registration"), "{v1}");
        let read = CalibrationFile::parse(&v1).unwrap();
        assert_eq!(
            read,
            CalibrationFile {
                schema_version: 1,
                ..file.clone()
            }
        );
        let record = RegistrationRecord {
            registered: true,
            frame: Frame {
                xyz: [1.0, 2.0, 3.0],
                rpy: [std::f64::consts::FRAC_PI_2, 0.0, 0.0],
            },
            base: Frame::identity(),
            gravity: [0.0, -9.8, 0.0],
            before_rms_m: 2.0,
            after_rms_m: 0.03,
            trimmed: vec![7],
        };
        let with = file.with_registration(record.clone());
        assert_eq!(CalibrationFile::parse(&with.to_json()).unwrap(), with);
        // Roll 90 deg takes the arm's z to the measurement frame's -y... and back.
        let p = record.to_arm_frame(&Vector3::new(1.0, 1.0, 3.0));
        assert!((p - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-12, "{p}");
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
}
