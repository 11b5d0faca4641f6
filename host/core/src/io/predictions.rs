//! Prediction files (`docs/FORMATS.md`, "Predictions"): `pose,x_mm,y_mm,z_mm`.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use nalgebra::Vector3;

use crate::dataset::Prediction;
use crate::error::{Error, InputError, Problem};
use crate::io::csv_table::{Extra, Schema, XYZ_COLUMNS, for_each_row, format_mm};
use crate::io::{atomic, read_text};

/// The columns of a prediction file, in the order they are written.
pub const COLUMNS: [&str; 4] = ["pose", XYZ_COLUMNS[0], XYZ_COLUMNS[1], XYZ_COLUMNS[2]];

const SCHEMA: Schema = Schema {
    columns: &COLUMNS,
    optional: &[],
    extra: Extra::Refuse,
};

/// Reads a prediction file.
pub fn read(path: &Path) -> Result<Vec<Prediction>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses prediction CSV text (positions converted to m); pose ids must be unique.
pub fn parse(text: &str) -> Result<Vec<Prediction>, InputError> {
    let mut out = Vec::new();
    let mut first_line = HashMap::new();
    for_each_row(text, &SCHEMA, |row| {
        let pose = row.pose_id()?;
        if let Some(&first_line) = first_line.get(&pose) {
            return Err(row.error("pose", Problem::DuplicatePoseId { pose, first_line }));
        }
        first_line.insert(pose, row.line);
        let mut mm = [0.0; 3];
        for (v, column) in mm.iter_mut().zip(XYZ_COLUMNS) {
            *v = row.number(column, "a position in mm")?;
        }
        out.push(Prediction {
            pose,
            position: Vector3::from(mm) / 1000.0,
        });
        Ok(())
    })?;
    Ok(out)
}

/// Writes a prediction file atomically, with exactly the contract's header.
pub fn write(path: &Path, rows: &[Prediction]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, rows))
}

/// Writes prediction CSV to any writer.
pub fn write_to(w: &mut dyn Write, rows: &[Prediction]) -> std::io::Result<()> {
    let mut csv = csv::Writer::from_writer(w);
    csv.write_record(COLUMNS)?;
    for p in rows {
        let mut record = vec![p.pose.to_string()];
        record.extend(p.position.iter().map(|x| format_mm(*x)));
        csv.write_record(&record)?;
    }
    csv.flush()
}
