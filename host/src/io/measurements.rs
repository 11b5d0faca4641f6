//! Measurement files (`docs/FORMATS.md`, "Measurements"):
//! `pose,load_kg,q1_deg..q6_deg,x_mm,y_mm,z_mm`, one row per measured pose.

use std::io::Write;
use std::path::Path;

use nalgebra::Vector3;

use crate::dataset::{Measurement, Pose};
use crate::error::{Error, InputError};
use crate::io::csv_table::{
    Extra, PoseBook, Q_COLUMNS, Schema, XYZ_COLUMNS, for_each_row, format_deg, format_mm,
};
use crate::io::{atomic, read_text};

/// The columns of a measurement file, in the order they are written.
pub const COLUMNS: [&str; 11] = [
    "pose",
    "load_kg",
    Q_COLUMNS[0],
    Q_COLUMNS[1],
    Q_COLUMNS[2],
    Q_COLUMNS[3],
    Q_COLUMNS[4],
    Q_COLUMNS[5],
    XYZ_COLUMNS[0],
    XYZ_COLUMNS[1],
    XYZ_COLUMNS[2],
];

const SCHEMA: Schema = Schema {
    columns: &COLUMNS,
    optional: &[],
    extra: Extra::Refuse,
};

/// Reads a measurement file.
pub fn read(path: &Path) -> Result<Vec<Measurement>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses measurement CSV text (units converted to rad and m).
pub fn parse(text: &str) -> Result<Vec<Measurement>, InputError> {
    let mut out = Vec::new();
    let mut book = PoseBook::default();
    for_each_row(text, &SCHEMA, |row| {
        let id = row.pose_id()?;
        let load_kg = row.non_negative("load_kg", "a load >= 0 kg")?;
        let q = row.joint_angles_rad()?;
        let mut mm = [0.0; 3];
        for (v, column) in mm.iter_mut().zip(XYZ_COLUMNS) {
            *v = row.number(column, "a position in mm")?;
        }
        book.record(row, id, &q, Some(load_kg))?;
        out.push(Measurement {
            pose: Pose { id, q },
            load_kg,
            position: Vector3::from(mm) / 1000.0,
        });
        Ok(())
    })?;
    Ok(out)
}

/// Writes a measurement file atomically, with exactly the contract's header.
pub fn write(path: &Path, rows: &[Measurement]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, rows))
}

/// Writes measurement CSV to any writer.
pub fn write_to(w: &mut dyn Write, rows: &[Measurement]) -> std::io::Result<()> {
    let mut csv = csv::Writer::from_writer(w);
    csv.write_record(COLUMNS)?;
    for m in rows {
        let mut record = vec![m.pose.id.to_string(), m.load_kg.to_string()];
        record.extend(m.pose.q.iter().map(|q| format_deg(*q)));
        record.extend(m.position.iter().map(|p| format_mm(*p)));
        csv.write_record(&record)?;
    }
    csv.flush()
}
