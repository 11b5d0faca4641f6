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

use std::path::Path;

use crate::param_key::ParamKey;
use model::params::ParamPart;
use model::{Arm, Frame, ModelOption, ParamId, ServoCurve};
use serde::{Deserialize, Serialize};

use super::{json, read_text};
use crate::error::{Error, InputError, Location, Problem};

/// Name of the schema, so a JSON file of another kind is recognised as such.
pub const SCHEMA: &str = "lrmcal-calibration";
/// Version of the schema this build writes (and the newest it reads).
pub const SCHEMA_VERSION: u32 = 5;
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

/// Rewrites the curve of all pulses 0 that files before schema 5 wrote for a
/// joint no servo drives as `null`, so it reads as none.
fn undriven_as_none(value: &mut serde_json::Value) {
    for arm in ["nominal", "arm"] {
        let joints = value
            .get_mut(arm)
            .and_then(|a| a.get_mut("joints"))
            .and_then(|j| j.as_array_mut());
        for joint in joints.into_iter().flatten() {
            let Some(servo) = joint.get_mut("servo") else {
                continue;
            };
            let pulses = servo.get("pulses_us").and_then(|p| p.as_array());
            if pulses.is_some_and(|p| p.iter().all(|x| x.as_f64() == Some(0.0))) {
                *servo = serde_json::Value::Null;
            }
        }
    }
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
    /// The parameter, written by its stable name (`j2.theta`, `k0`, …).
    pub name: ParamKey,
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

/// The arm's place in the measurement frame, as `lrmcal identify` found it.
///
/// A registered file's `nominal` and `arm` are both in the measurement
/// frame already (the nominal's base is the registered base, gravity is the
/// measurement frame's), so `predict`, `validate` and the board work there
/// with no conversion; this record only documents where the base was found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegistrationRecord {
    /// Whether the base was registered (false: `--no-register`, the arm file's base kept).
    pub registered: bool,
    /// The arm file's world frame in the measurement frame (m, rad): the
    /// rigid motion registration found.
    pub frame: Frame<f64>,
    /// The nominal arm's frame 0 in the measurement frame (m, rad), as
    /// registration placed it (the calibrated `arm` refines it).
    pub base: Frame<f64>,
    /// Gravity in the measurement frame, m/s².
    pub gravity: [f64; 3],
    /// RMS distance of the nominal arm from the measurements as the arm file placed it, m.
    pub before_rms_m: f64,
    /// The same after registration, over the points it kept, m.
    pub after_rms_m: f64,
    /// Poses left out of the registration as far off.
    pub trimmed: Vec<u32>,
    /// The tool point registration found with the base (frame 6, m), which
    /// replaced the arm file's in `nominal`; absent when the file's was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_m: Option<[f64; 3]>,
}

/// One measured target of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetTool {
    /// The name the measurement file gave it.
    pub name: String,
    /// Its tool point in frame 6 (the tool frame's parent) of the corrected arm, m.
    pub tool_m: [f64; 3],
    /// Residual of the fit on its own measurements (3D error norm), m.
    pub fit_residual: ErrorStats,
    /// The corrected arm's error on its held-out measurements, when there were any, m.
    pub validation_after: Option<ErrorStats>,
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
            |version, value| {
                if version == 1 {
                    upgrade_servo_curves(value)?;
                }
                // Version 2 lacks only the registration, which reads as none;
                // versions before 4 the rated payload, which reads as 0.
                if version < 5 {
                    undriven_as_none(value);
                }
                Ok(())
            },
        )?;
        // Both arms of the same joints, at least one.
        let joints = file.nominal.joints.len();
        if joints == 0 || file.arm.joints.len() != joints {
            return Err(InputError::new(
                Location::key(None, "arm.joints"),
                Problem::Invalid {
                    message: format!(
                        "expected the calibrated arm to have the nominal arm's joints (1 to {}), \
                         found {} and {joints}",
                        model::MAX_JOINTS,
                        file.arm.joints.len()
                    ),
                },
            ));
        }
        // The joints' names, when recorded: one per joint, none empty.
        let names = &file.joint_names;
        if !names.is_empty() && (names.len() != joints || names.iter().any(|n| n.trim().is_empty()))
        {
            return Err(InputError::new(
                Location::key(None, "joint_names"),
                Problem::Invalid {
                    message: format!(
                        "expected one name per joint of the arm ({joints}), none empty, found {} ({})",
                        names.len(),
                        names.join(", ")
                    ),
                },
            ));
        }
        // Both arms' rated payloads, and their compliances, softenings and
        // plays within the physical bounds worked out from the nominal arm
        // (`model::bounds`): what the fit keeps to and the board checks.
        for (which, arm) in [("nominal", &file.nominal), ("arm", &file.arm)] {
            if !(arm.rated_payload_kg.is_finite() && arm.rated_payload_kg >= 0.0) {
                return Err(InputError::new(
                    Location::key(None, format!("{which}.rated_payload_kg")),
                    Problem::OutOfRange {
                        expected: "a payload >= 0 kg",
                        found: arm.rated_payload_kg.to_string(),
                    },
                ));
            }
            super::bounds::check(&file.nominal, arm, which, None, false)?;
        }
        for (i, p) in file.parameters.iter().enumerate() {
            let repeated = file.parameters[..i].iter().any(|q| q.name == p.name);
            // A further target's tool point names a target the file lists.
            let known = match p.name {
                ParamKey::TargetTool { target, .. } => usize::from(target) < file.targets.len(),
                key => key.fits(joints),
            };
            if !known || repeated {
                let n = joints;
                return Err(InputError::new(
                    Location::key(None, format!("parameters[{}].name", i + 1)),
                    Problem::Invalid {
                        message: format!(
                            "expected a parameter name of this arm of {n} joints (j1.theta … \
                             j{n}.alpha, base.x … tool.yaw, k0 … k{n}, j1.servo[1] … \
                             j{n}.servo[9], j1.backlash … j{n}.backlash, s0 … s{n}, tool[N].x … \
                             tool[N].z of a listed target), each once, found `{}`",
                            p.name
                        ),
                    },
                ));
            }
        }
        for (i, t) in file.targets.iter().enumerate() {
            let problem = if t.name.is_empty() {
                Some("a name".to_string())
            } else if file.targets[..i].iter().any(|u| u.name == t.name) {
                Some(format!("a name not used before, found `{}` again", t.name))
            } else if !t.tool_m.iter().all(|v| v.is_finite()) {
                Some("finite coordinates in m".to_string())
            } else {
                None
            };
            if let Some(message) = problem {
                return Err(InputError::new(
                    Location::key(None, format!("targets[{}]", i + 1)),
                    Problem::Invalid {
                        message: format!("expected {message}"),
                    },
                ));
            }
        }
        if let Some(first) = file.targets.first()
            && first.tool_m != file.arm.tool.xyz
        {
            return Err(InputError::new(
                Location::key(None, "targets[1].tool_m"),
                Problem::Invalid {
                    message: "the first target is the arm's tool point: expected arm.tool.xyz"
                        .into(),
                },
            ));
        }
        Ok(file)
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

    /// Reads and checks a calibration file.
    pub fn read(path: &Path) -> Result<Self, Error> {
        Self::parse(&read_text(path)?).map_err(|e| e.in_file(path))
    }

    /// Checks that this calibration (read from `path`) was identified from
    /// `nominal`. A registered file's nominal base is where registration
    /// found it, not the arm file's, so the base is not compared then; nor
    /// the tool point when registration found that too.
    pub fn check_nominal(&self, nominal: &Arm<f64>, path: &Path) -> Result<(), Error> {
        if self.nominal.joints.len() != nominal.joints.len() {
            return Err(Error::ArmMismatch {
                path: path.to_owned(),
                problem: format!(
                    "it calibrates an arm of {} joints, the arm given has {}",
                    self.nominal.joints.len(),
                    nominal.joints.len()
                ),
            });
        }
        let ours: Vec<f64> = self.nominal.param_values().collect();
        let theirs: Vec<f64> = nominal.param_values().collect();
        let registered = self.registration.as_ref().is_some_and(|r| r.registered);
        let tool_found = self
            .registration
            .as_ref()
            .is_some_and(|r| r.tool_m.is_some());
        for (id, (a, b)) in ParamId::of(nominal).zip(ours.iter().zip(&theirs)) {
            let moved = match id.part() {
                ParamPart::Base { .. } => registered,
                ParamPart::Tool { axis } => tool_found && axis < 3,
                _ => false,
            };
            if moved {
                continue;
            }
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

/// How far a length of an arm description may lie from the calibration's
/// nominal arm and still be the same arm, m: 1 µm, far below a build's
/// tolerance, above a file's numbers rounded to 6 digits.
const SAME_LENGTH_M: f64 = 1e-6;
/// The same for an angle, rad (0.0006°; `1.5708` for π/2 passes).
const SAME_ANGLE_RAD: f64 = 1e-5;
/// The same for a link's mass, kg (1 mg).
const SAME_MASS_KG: f64 = 1e-6;

impl CalibrationFile {
    /// Checks that `arm`, the arm description called `label` (`bundled arm
    /// `lrm``, a path), describes this calibration's (read from `path`)
    /// nominal arm: each joint's DH `theta`, `d`, `a`, `alpha`, its limits and
    /// its link's mass, within 1 µm, 1e-5 rad and 1 mg. What a calibration
    /// may rightly find elsewhere is not compared: the base and tool (found
    /// by registration, re-taught after a tool change), the compliances and
    /// the servo curves (which `servo-tune` may since have measured anew).
    pub fn check_describes_nominal(
        &self,
        arm: &Arm<f64>,
        label: &str,
        path: &Path,
    ) -> Result<(), Error> {
        use crate::io::csv_table::format_fixed;
        let mm = |m: f64| format!("{} mm", format_fixed(m * 1e3, 6));
        let deg = |rad: f64| format!("{}°", format_fixed(rad.to_degrees(), 6));
        let kg = |kg: f64| format!("{} kg", format_fixed(kg, 6));
        type Show<'a> = &'a dyn Fn(f64) -> String;
        for (i, (ours, theirs)) in self.nominal.joints.iter().zip(&arm.joints).enumerate() {
            let fields: [(&str, f64, f64, f64, Show); 7] = [
                ("theta", ours.theta, theirs.theta, SAME_ANGLE_RAD, &deg),
                ("d", ours.d, theirs.d, SAME_LENGTH_M, &mm),
                ("a", ours.a, theirs.a, SAME_LENGTH_M, &mm),
                ("alpha", ours.alpha, theirs.alpha, SAME_ANGLE_RAD, &deg),
                (
                    "lower limit",
                    ours.limits[0],
                    theirs.limits[0],
                    SAME_ANGLE_RAD,
                    &deg,
                ),
                (
                    "upper limit",
                    ours.limits[1],
                    theirs.limits[1],
                    SAME_ANGLE_RAD,
                    &deg,
                ),
                ("mass", ours.mass, theirs.mass, SAME_MASS_KG, &kg),
            ];
            for (name, ours, theirs, tolerance, show) in fields {
                if (ours - theirs).abs() > tolerance {
                    return Err(Error::ArmMismatch {
                        path: path.to_owned(),
                        problem: format!(
                            "its nominal arm is not {label}: joint {}'s {name} differs: {} in \
                             {label}, {} in the calibration's nominal arm; pass --arm the arm \
                             description it was identified from",
                            i + 1,
                            show(theirs),
                            show(ours)
                        ),
                    });
                }
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
