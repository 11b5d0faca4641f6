//! One joint's servo curve written into an arm file in place: the rest of
//! the file (its comments, its layout, the order of its keys) stays as the
//! user wrote it, which rewriting the whole description would lose.

use std::path::Path;

use model::ServoCurve;
use toml_edit::{Array, DocumentMut, InlineTable, Item, Value};

use super::parse;
use super::raw::degrees_of;
use crate::error::{Error, InputError, Location, Problem};
use crate::io::{atomic, read_text};

/// `text` (an arm file) with the `servo` of joint `joint` (0-based) set to
/// `curve`, as knots; nothing else changes. Refused, naming the key, when
/// the text does not read as an arm with that joint, or when the edited
/// text would not read back as the same arm with the new curve.
pub fn with_servo(text: &str, joint: usize, curve: &ServoCurve<f64>) -> Result<String, InputError> {
    let mut description = parse(text)?;
    let key = format!("joint[{}].servo", joint + 1);
    let invalid = |message: String| {
        InputError::new(
            Location::key(None, key.clone()),
            Problem::Invalid { message },
        )
    };
    if joint >= description.arm.joints.len() {
        return Err(invalid(format!(
            "a joint of the arm's {}, found joint {}",
            description.arm.joints.len(),
            joint + 1
        )));
    }
    let mut document: DocumentMut = text
        .parse()
        .map_err(|e| invalid(format!("a TOML document: {e}")))?;
    let table = document
        .get_mut("joint")
        .and_then(Item::as_array_of_tables_mut)
        .and_then(|joints| joints.get_mut(joint))
        .ok_or_else(|| invalid("a `[[joint]]` table for each joint".into()))?;
    let angles: Array = curve.angles_rad().iter().map(|&a| degrees_of(a)).collect();
    let pulses: Array = curve.pulses_us().iter().copied().collect();
    // The curve keeps the form it was written in: a `[joint.servo]` table
    // stays one; otherwise it is an inline table on the joint's own line.
    match table.get_mut("servo") {
        Some(Item::Table(servo)) => {
            servo.clear();
            servo.insert("angles_deg", Item::Value(Value::Array(angles)));
            servo.insert("pulses_us", Item::Value(Value::Array(pulses)));
        }
        _ => {
            let mut knots = InlineTable::new();
            knots.insert("angles_deg", Value::Array(angles));
            knots.insert("pulses_us", Value::Array(pulses));
            table.insert("servo", Item::Value(Value::InlineTable(knots)));
        }
    }
    let edited = document.to_string();
    // The edit must mean exactly the new curve and nothing else.
    description.arm.joints[joint].servo = Some(*curve);
    match parse(&edited) {
        Ok(read) if read == description => Ok(edited),
        _ => Err(invalid(
            "a curve that reads back as written; the file is left as it was".into(),
        )),
    }
}

/// Writes `curve` as the servo curve of joint `joint` (0-based) of the arm
/// file at `path`, in place ([`with_servo`]), atomically.
pub fn write_servo(path: &Path, joint: usize, curve: &ServoCurve<f64>) -> Result<(), Error> {
    let text = read_text(path)?;
    let edited = with_servo(&text, joint, curve).map_err(|e| e.in_file(path))?;
    atomic::write(path, |w| w.write_all(edited.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const BUNDLED: &str = include_str!("../../../arms/lrm.toml");

    fn five_knots() -> ServoCurve<f64> {
        let angles = [-100.0f64, -50.0, 0.0, 50.0, 100.0].map(f64::to_radians);
        ServoCurve::new(&angles, &[905.0, 1270.5, 1652.0, 2031.0, 2396.0]).unwrap()
    }

    /// Only joint 3's `servo` line changes: every comment and every other
    /// line of the bundled arm file stays, and the file reads back as the
    /// arm with the new curve.
    #[test]
    fn only_the_joints_servo_line_changes() {
        let edited = with_servo(BUNDLED, 2, &five_knots()).unwrap();
        let (before, after): (Vec<&str>, Vec<&str>) =
            (BUNDLED.lines().collect(), edited.lines().collect());
        assert_eq!(before.len(), after.len());
        let changed: Vec<usize> = (0..before.len())
            .filter(|&i| before[i] != after[i])
            .collect();
        assert_eq!(changed.len(), 1, "{changed:?}");
        assert!(
            after[changed[0]]
                .starts_with("servo = { angles_deg = [-100.0, -50.0, 0.0, 50.0, 100.0]"),
            "{}",
            after[changed[0]]
        );
        let read = parse(&edited).unwrap();
        assert_eq!(read.arm.joints[2].servo, Some(five_knots()));
        let mut expected = parse(BUNDLED).unwrap();
        expected.arm.joints[2].servo = Some(five_knots());
        assert_eq!(read, expected);
    }

    /// A curve written as the three points of earlier files, or as a
    /// sub-table, becomes knots; a joint the arm lacks is refused by key.
    #[test]
    fn other_forms_become_knots_and_a_missing_joint_is_refused() {
        let three = BUNDLED.replacen(
            "servo = { angles_deg = [-100.0, 0.0, 100.0], pulses_us = [900.0, 1650.0, 2400.0] }",
            "servo = { minus100 = 900.0, zero = 1650.0, plus100 = 2400.0 }",
            1,
        );
        let edited = with_servo(&three, 0, &five_knots()).unwrap();
        assert!(!edited.contains("minus100"));
        assert_eq!(
            parse(&edited).unwrap().arm.joints[0].servo,
            Some(five_knots())
        );
        let e = with_servo(BUNDLED, 6, &five_knots())
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint[7].servo") && e.contains("6"), "{e}");
    }
}
