//! Whether a calibration belongs to the arm a command is given: the
//! nominal arm it was identified from, parameter by parameter, or an arm
//! description's joints within a file's rounding.

use std::path::Path;

use model::params::ParamPart;
use model::{Arm, ParamId};

use super::CalibrationFile;
use crate::error::Error;

/// How far a length of an arm description may lie from the calibration's
/// nominal arm and still be the same arm, m: 1 µm, far below a build's
/// tolerance, above a file's numbers rounded to 6 digits.
const SAME_LENGTH_M: f64 = 1e-6;
/// The same for an angle, rad (0.0006°; `1.5708` for π/2 passes).
const SAME_ANGLE_RAD: f64 = 1e-5;
/// The same for a link's mass, kg (1 mg).
const SAME_MASS_KG: f64 = 1e-6;

impl CalibrationFile {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calibration_file::test_support::sample_file;
    use crate::io::calibration_file::{RegistrationRecord, SCHEMA_VERSION};
    use model::Frame;

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
        assert!(!err.is_access());
        let err = err.report();
        assert!(err.contains("cal.json") && err.contains("j3.a"), "{err}");
    }

    /// An arm description is the calibration's nominal arm when its joints'
    /// geometry, limits and masses are, rounded or not; the base, tool,
    /// compliances and servo curves may differ.
    #[test]
    fn an_arm_description_describes_the_nominal_arm_by_its_joints() {
        let file = sample_file();
        let path = Path::new("cal.json");
        let label = "`my.toml`";
        let mut same = file.nominal;
        // As the page's example writes π/2 and the limits: 6 digits.
        fn rounded(x: f64) -> f64 {
            (x * 1e4).round() / 1e4
        }
        same.joints[1].theta = rounded(std::f64::consts::FRAC_PI_2);
        same.joints[0].limits = same.joints[0].limits.map(rounded);
        same.base.xyz = [1.0, 2.0, 3.0];
        same.tool.xyz = [0.0, 0.0, 0.1];
        same.joints[3].compliance = 0.5;
        file.check_describes_nominal(&same, label, path).unwrap();

        let mut other = file.nominal;
        other.joints[2].a = 0.12;
        let e = file
            .check_describes_nominal(&other, label, path)
            .unwrap_err();
        assert_eq!(
            e.report(),
            "error: failed to use calibration `cal.json`: its nominal arm is not `my.toml`: joint \
             3's a differs: 120 mm in `my.toml`, 0 mm in the calibration's nominal arm; pass --arm \
             the arm description it was identified from"
        );
        let mut other = file.nominal;
        other.joints[4].alpha += 1e-4;
        let e = file
            .check_describes_nominal(&other, label, path)
            .unwrap_err()
            .report();
        assert!(
            e.contains("joint 5's alpha differs: 90.00573° in `my.toml`, 90° in"),
            "{e}"
        );
        let mut other = file.nominal;
        other.joints[5].limits[1] = 1.5;
        let e = file
            .check_describes_nominal(&other, label, path)
            .unwrap_err()
            .report();
        assert!(
            e.contains("joint 6's upper limit differs: 85.943669° in `my.toml`"),
            "{e}"
        );
        let mut other = file.nominal;
        other.joints[0].mass = 0.2;
        let e = file
            .check_describes_nominal(&other, label, path)
            .unwrap_err()
            .report();
        assert!(
            e.contains("joint 1's mass differs: 0.2 kg in `my.toml`, 0.15 kg"),
            "{e}"
        );
    }

    /// A version 2 file (no registration) still reads; a registration
    /// round trips, and lets the nominal arm's base differ from the arm
    /// file's (it is the registered base) but nothing else.
    #[test]
    fn reads_version_2_and_records_the_registration() {
        let file = sample_file();
        let v2 = file.to_json().replace(
            &format!("\"schema_version\": {SCHEMA_VERSION}"),
            "\"schema_version\": 2",
        );
        assert!(!v2.contains("registration"), "{v2}");
        // Read as this version's file (the upgrade rewrites the version).
        assert_eq!(CalibrationFile::parse(&v2).unwrap(), file);
        let arm_file = file.nominal;
        let mut registered = file.clone();
        registered.nominal.base.xyz[0] += 0.5;
        registered.nominal.base.rpy[2] += 1.0;
        let path = Path::new("cal.json");
        let e = registered.check_nominal(&arm_file, path).unwrap_err();
        assert!(e.to_string().contains("base.x"), "{e}");
        let record = RegistrationRecord {
            registered: true,
            frame: Frame {
                xyz: [0.5, 0.0, 0.0],
                rpy: [0.0, 0.0, 1.0],
            },
            base: Frame {
                xyz: [0.5, 0.0, 0.0],
                rpy: [0.0, 0.0, 1.0],
            },
            gravity: [0.0, -9.8, 0.0],
            before_rms_m: 2.0,
            after_rms_m: 0.03,
            trimmed: vec![7],
            tool_m: None,
        };
        let with = registered.clone().with_registration(record.clone());
        assert!(!with.to_json().contains("tool_m"));
        assert_eq!(CalibrationFile::parse(&with.to_json()).unwrap(), with);
        with.check_nominal(&arm_file, path).unwrap();
        let mut other = arm_file;
        other.joints[2].a += 0.01;
        let e = with.check_nominal(&other, path).unwrap_err();
        assert!(e.to_string().contains("j3.a"), "{e}");
        // A tool point registration found replaces the file's: not compared.
        let mut moved_tool = registered.clone();
        moved_tool.nominal.tool.xyz[1] += 0.13;
        let e = moved_tool
            .clone()
            .with_registration(record.clone())
            .check_nominal(&arm_file, path)
            .unwrap_err();
        assert!(e.to_string().contains("tool.y"), "{e}");
        let tool_m = Some(moved_tool.nominal.tool.xyz);
        let found = moved_tool.with_registration(RegistrationRecord { tool_m, ..record });
        assert_eq!(CalibrationFile::parse(&found.to_json()).unwrap(), found);
        found.check_nominal(&arm_file, path).unwrap();
    }
}
