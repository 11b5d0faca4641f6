//! Measurement files (`docs/FORMATS.md`, "Measurements"):
//! `pose,load_kg,q1_deg..q6_deg,x_mm,y_mm,z_mm`, one row per measured pose,
//! and an optional `target` column naming the measured target when several
//! are measured at each pose (a file without it measures one).

use std::io::Write;
use std::path::Path;

use model::{JointKind, PerJoint};
use nalgebra::Vector3;

use crate::dataset::{
    MAX_TARGETS, Measurement, Pose, TARGET_NAME_MAX, TargetName, from_home, visiting_order,
};
use crate::error::{Error, InputError, Problem};
use crate::io::csv_table::{
    Extra, PoseBook, Schema, XYZ_COLUMNS, for_each_row, format_joint, format_mm, pose_columns,
    q_column,
};
use crate::io::{atomic, read_text};

/// The optional column naming the measured target.
pub const TARGET_COLUMN: &str = "target";

/// The columns of a measurement file, in the order they are written
/// ([`TARGET_COLUMN`] last, when the rows name targets).
pub const COLUMNS: [&str; 16] = pose_columns!(
    XYZ_COLUMNS[0],
    XYZ_COLUMNS[1],
    XYZ_COLUMNS[2],
    TARGET_COLUMN
);

const SCHEMA: Schema = Schema {
    columns: &COLUMNS,
    optional: &[TARGET_COLUMN],
    extra: Extra::Refuse,
};

/// A measurement and the line of the file it was read from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ListedMeasurement {
    /// 1-based line in the file.
    pub line: u64,
    /// The row.
    pub measurement: Measurement,
    /// How the file gives each joint: `qi_deg` revolute, `qi_mm` prismatic.
    pub units: PerJoint<JointKind>,
}

/// Reads a measurement file.
pub fn read(path: &Path) -> Result<Vec<Measurement>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Reads a measurement file, keeping each row's line for later messages
/// (the joint-limit check of its poses).
pub fn read_listed(path: &Path) -> Result<Vec<ListedMeasurement>, Error> {
    parse_listed(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// The measurements of `listed`, in the file's order.
pub fn unlisted(listed: &[ListedMeasurement]) -> Vec<Measurement> {
    listed.iter().map(|l| l.measurement).collect()
}

/// Parses measurement CSV text (units converted to rad and m).
pub fn parse(text: &str) -> Result<Vec<Measurement>, InputError> {
    Ok(unlisted(&parse_listed(text)?))
}

/// Parses measurement CSV text (units converted to rad and m), with each
/// row's line.
pub fn parse_listed(text: &str) -> Result<Vec<ListedMeasurement>, InputError> {
    let mut out = Vec::new();
    let mut lines = Vec::new();
    let mut book = PoseBook::default();
    let mut targets: Vec<TargetName> = Vec::new();
    for_each_row(text, &SCHEMA, |row| {
        let target = match row.text(TARGET_COLUMN) {
            None => None,
            Some(name) => {
                let name =
                    target_name(name).map_err(|problem| row.error(TARGET_COLUMN, problem))?;
                if !targets.contains(&name) {
                    if targets.len() == MAX_TARGETS {
                        return Err(row.error(
                            TARGET_COLUMN,
                            Problem::Invalid {
                                message: format!(
                                    "`{name}` is a target too many: a file names at most {MAX_TARGETS}"
                                ),
                            },
                        ));
                    }
                    targets.push(name);
                }
                Some(name)
            }
        };
        let id = row.pose_id()?;
        let load_kg = row.non_negative("load_kg", "a load >= 0 kg")?;
        let q = row.joint_angles_rad()?;
        let mut mm = [0.0; 3];
        for (v, column) in mm.iter_mut().zip(XYZ_COLUMNS) {
            *v = row.number(column, "a position in mm")?;
        }
        book.record(row, id, &q, Some(load_kg), target)?;
        lines.push((row.line, row.joint_units()));
        out.push(Measurement {
            pose: Pose { id, q },
            load_kg,
            position: Vector3::from(mm) / 1000.0,
            pixel: None,
            target,
            approach: from_home(q.len()),
        });
        Ok(())
    })?;
    // The rows are in the order the poses were visited (the format's contract).
    visiting_order(&mut out);
    Ok(lines
        .into_iter()
        .zip(out)
        .map(|((line, units), measurement)| ListedMeasurement {
            line,
            measurement,
            units,
        })
        .collect())
}

/// Writes a measurement file atomically, with exactly the contract's header;
/// `kinds` are the arm's joints' (a revolute joint's column is `qi_deg`, a
/// prismatic one's `qi_mm`).
pub fn write(path: &Path, rows: &[Measurement], kinds: &[JointKind]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, rows, kinds))
}

/// Writes measurement CSV to any writer; the `target` column only when a
/// row names its target, so a one-target file keeps the plain header.
pub fn write_to(
    w: &mut dyn Write,
    rows: &[Measurement],
    kinds: &[JointKind],
) -> std::io::Result<()> {
    let named = rows.iter().any(|m| m.target.is_some());
    let mut columns = vec!["pose", "load_kg"];
    columns.extend(kinds.iter().enumerate().map(|(i, &k)| q_column(i, k)));
    columns.extend(XYZ_COLUMNS);
    if named {
        columns.push(TARGET_COLUMN);
    }
    let mut csv = csv::Writer::from_writer(w);
    csv.write_record(&columns)?;
    for m in rows {
        let mut record = vec![m.pose.id.to_string(), m.load_kg.to_string()];
        record.extend(
            kinds
                .iter()
                .zip(&m.pose.q)
                .map(|(&k, &q)| format_joint(k, q)),
        );
        record.extend(m.position.iter().map(|p| format_mm(*p)));
        if named {
            record.push(m.target.map(|t| t.to_string()).unwrap_or_default());
        }
        csv.write_record(&record)?;
    }
    csv.flush()
}

/// A target name from a cell: not empty, at most [`TARGET_NAME_MAX`] bytes,
/// letters, digits, `_`, `-` and `.` only (it becomes part of messages and
/// of the calibration file's target list).
fn target_name(cell: &str) -> Result<TargetName, Problem> {
    let fits = !cell.is_empty()
        && cell
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
    match TargetName::from(cell) {
        Ok(name) if fits => Ok(name),
        _ => Err(Problem::Invalid {
            message: format!(
                "expected a target name (1 to {TARGET_NAME_MAX} letters, digits, `_`, `-` or `.`), found `{cell}`"
            ),
        }),
    }
}
