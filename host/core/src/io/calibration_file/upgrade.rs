//! Files of older schema versions read as this version's: their JSON is
//! rewritten before the typed read (the versions' history is in the
//! parent module's documentation).

use model::ServoCurve;
use serde::Deserialize;

use crate::error::{InputError, Location, Problem};

/// A servo curve as schema 1 wrote it: the pulses at -100°, 0° and +100°.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ThreePoints {
    minus100: f64,
    zero: f64,
    plus100: f64,
}

/// Rewrites the JSON of a file of schema `version` as this version's.
pub(super) fn upgrade(version: u32, value: &mut serde_json::Value) -> Result<(), InputError> {
    if version == 1 {
        upgrade_servo_curves(value)?;
    }
    // Version 2 lacks only the registration, which reads as none;
    // versions before 4 the rated payload, which reads as 0.
    if version < 5 {
        undriven_as_none(value);
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calibration_file::test_support::sample_file;
    use crate::io::calibration_file::{CalibrationFile, SCHEMA_VERSION};

    /// A joint no servo drives is written `null` and read back as none; the
    /// all-zero curve earlier versions wrote for it reads as none too.
    #[test]
    fn a_joint_without_a_servo_has_no_curve_in_every_version() {
        let mut file = sample_file();
        file.nominal.joints[0].servo = None;
        file.arm.joints[0].servo = None;
        let json = file.to_json();
        assert!(json.contains("\"servo\": null"), "{json}");
        assert_eq!(CalibrationFile::parse(&json).unwrap(), file);
        let zero = serde_json::to_string(&ServoCurve::from_three_points(0.0, 0.0, 0.0)).unwrap();
        let old = json
            .replace("\"servo\": null", &format!("\"servo\": {zero}"))
            .replace(
                &format!("\"schema_version\": {SCHEMA_VERSION}"),
                "\"schema_version\": 4",
            );
        assert!(
            old.contains("\"schema_version\": 4") && old.contains(&zero),
            "{old}"
        );
        assert_eq!(CalibrationFile::parse(&old).unwrap(), file);
    }

    #[test]
    fn schema_1_files_read_as_the_same_curves() {
        let mut file = sample_file();
        file.arm.joints[1].servo = Some(ServoCurve::from_three_points(880.5, 1640.25, 2410.125));
        let json = file.to_json();
        assert!(
            json.contains(&format!("\"schema_version\": {SCHEMA_VERSION}"))
                && json.contains("\"angles_rad\"")
        );
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
        // A key missing from the whole document is placed on its last line,
        // as in a file of the current version.
        let mut no_option = v1.clone();
        no_option.as_object_mut().unwrap().remove("option");
        no_option["arm"]["joints"][2]["servo"] =
            serde_json::json!({ "minus100": 900.0, "zero": 1650.0, "plus100": 2400.0 });
        let text = serde_json::to_string_pretty(&no_option).unwrap();
        let e = CalibrationFile::parse(&text).unwrap_err();
        assert_eq!(e.location.line, Some(text.lines().count() as u64), "{e}");
        assert!(e.to_string().contains("option"), "{e}");
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
