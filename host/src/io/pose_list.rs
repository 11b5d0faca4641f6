//! Pose lists (`docs/FORMATS.md`, "Pose lists"): candidates and selections,
//! `pose[,load_kg],q1_deg..q6_deg`.

use std::io::Write;
use std::path::Path;

use crate::dataset::{Pose, PoseRow};
use crate::error::{Error, InputError};
use crate::io::csv_table::{PoseBook, Q_COLUMNS, Schema, for_each_row, format_deg};
use crate::io::{atomic, read_text};

/// The columns of a pose list, in the order they are written (`load_kg` only if any row has one).
pub const COLUMNS: [&str; 8] = [
    "pose",
    "load_kg",
    Q_COLUMNS[0],
    Q_COLUMNS[1],
    Q_COLUMNS[2],
    Q_COLUMNS[3],
    Q_COLUMNS[4],
    Q_COLUMNS[5],
];

const SCHEMA: Schema = Schema {
    columns: &COLUMNS,
    optional: &["load_kg"],
};

/// Reads a pose list.
pub fn read(path: &Path) -> Result<Vec<PoseRow>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses pose-list CSV text (angles converted to rad).
///
/// A measurement file is not a pose list (its `x_mm..z_mm` columns are rejected).
pub fn parse(text: &str) -> Result<Vec<PoseRow>, InputError> {
    let mut out = Vec::new();
    let mut book = PoseBook::default();
    for_each_row(text, &SCHEMA, |row| {
        let id = row.pose_id()?;
        let load_kg = if row.has("load_kg") {
            Some(row.non_negative("load_kg", "a load >= 0 kg")?)
        } else {
            None
        };
        let q = row.joint_angles_rad()?;
        book.record(row, id, &q, load_kg)?;
        out.push(PoseRow {
            pose: Pose { id, q },
            load_kg,
        });
        Ok(())
    })?;
    Ok(out)
}

/// Writes a pose list atomically; the `load_kg` column is written when any row has a load.
///
/// A row without a load in a list that has the column is written with load 0.
pub fn write(path: &Path, rows: &[PoseRow]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, rows))
}

/// Writes pose-list CSV to any writer.
pub fn write_to(w: &mut dyn Write, rows: &[PoseRow]) -> std::io::Result<()> {
    let with_load = rows.iter().any(|r| r.load_kg.is_some());
    let mut csv = csv::Writer::from_writer(w);
    let columns: Vec<&str> = COLUMNS
        .iter()
        .copied()
        .filter(|&c| with_load || c != "load_kg")
        .collect();
    csv.write_record(&columns)?;
    for r in rows {
        let mut record = vec![r.pose.id.to_string()];
        if with_load {
            record.push(r.load_kg.unwrap_or(0.0).to_string());
        }
        record.extend(r.pose.q.iter().map(|q| format_deg(*q)));
        csv.write_record(&record)?;
    }
    csv.flush()
}
