//! The CSV reading shared by measurements, pose lists and predictions.
//!
//! Accepted: a header line naming the columns in any order, `#` comment lines
//! anywhere, blank lines, spaces around cells. Columns whose name starts with
//! [`NOTE_PREFIX`] (`note_time`, `note_rms`, …) are carried along by other
//! tools and ignored here. What happens to any other column the file kind does
//! not define is the schema's [`Extra`]: measurements and predictions refuse
//! it, listing the expected columns, so that a misspelt column cannot pass
//! unnoticed; pose lists ignore it, since any file with the pose columns (a
//! measurement file, a spreadsheet of poses) is a pose list, but still refuse
//! a column that looks like a misspelt optional one (`load` for `load_kg`),
//! which would otherwise silently turn into its default.
//!
//! This file holds the columns and the schemas of the kinds of file, the
//! reading of a whole file and the writers' number format; the header's
//! checks (`header`), a row's cells ([`Row`]), reading line by line
//! ([`LineRows`]) and the pose ids across rows ([`PoseBook`]) have files of
//! their own.

use csv::{ReaderBuilder, StringRecord, Trim};

use model::JointKind;

use crate::error::{InputError, Location, Problem};
use crate::io::record_line;

mod header;
mod line_rows;
mod pose_book;
mod row;

use header::check_header;
pub use line_rows::{LineRows, ReadError};
pub use pose_book::PoseBook;
pub use row::Row;

/// Columns starting with this are ignored by every reader.
pub const NOTE_PREFIX: &str = "note_";

/// The joint angle columns, in joint order: a file has the first `n`, one
/// per joint of its arm.
pub const Q_COLUMNS: [&str; model::MAX_JOINTS] = [
    "q1_deg", "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg", "q7_deg", "q8_deg", "q9_deg",
    "q10_deg",
];

/// The columns of a file of poses, in the order writers write them: `pose`,
/// `load_kg`, the joint columns `q1_deg` … `q10_deg` ([`Q_COLUMNS`]), then
/// the kind of file's own (`$after`).
macro_rules! pose_columns {
    ($($after:expr),* $(,)?) => {
        [
            "pose",
            "load_kg",
            $crate::io::csv_table::Q_COLUMNS[0],
            $crate::io::csv_table::Q_COLUMNS[1],
            $crate::io::csv_table::Q_COLUMNS[2],
            $crate::io::csv_table::Q_COLUMNS[3],
            $crate::io::csv_table::Q_COLUMNS[4],
            $crate::io::csv_table::Q_COLUMNS[5],
            $crate::io::csv_table::Q_COLUMNS[6],
            $crate::io::csv_table::Q_COLUMNS[7],
            $crate::io::csv_table::Q_COLUMNS[8],
            $crate::io::csv_table::Q_COLUMNS[9],
            $($after),*
        ]
    };
}
pub(crate) use pose_columns;

/// The joint columns of a prismatic joint, its value in mm, in joint order:
/// joint `i`'s column is `qi_deg` or `qi_mm`, as the joint turns or slides.
pub const Q_MM_COLUMNS: [&str; model::MAX_JOINTS] = [
    "q1_mm", "q2_mm", "q3_mm", "q4_mm", "q5_mm", "q6_mm", "q7_mm", "q8_mm", "q9_mm", "q10_mm",
];

/// The joint column of joint `i` (from 0) of `kind`: `q3_deg`, `q1_mm`.
pub fn q_column(i: usize, kind: JointKind) -> &'static str {
    match kind {
        JointKind::Revolute => Q_COLUMNS[i],
        JointKind::Prismatic => Q_MM_COLUMNS[i],
    }
}

/// The joint-angle columns that may be absent: all but the first (a file
/// of an arm of `n` joints has `q1_deg` to `qn_deg`).
const OPTIONAL_Q_COLUMNS: [&str; model::MAX_JOINTS - 1] = [
    "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg", "q7_deg", "q8_deg", "q9_deg", "q10_deg",
];

/// The position columns.
pub const XYZ_COLUMNS: [&str; 3] = ["x_mm", "y_mm", "z_mm"];

/// The columns of one kind of file.
pub struct Schema {
    /// Every column, in the order writers write them.
    pub columns: &'static [&'static str],
    /// Those of `columns` that may be absent, besides the joint columns
    /// after the first (`OPTIONAL_Q_COLUMNS`: an arm has as many as it has joints).
    pub optional: &'static [&'static str],
    /// What to do with other columns.
    pub extra: Extra,
}

impl Schema {
    /// The columns of `columns` that may be absent: `optional` and the joint
    /// columns after the first.
    fn optional_columns(&self) -> impl Iterator<Item = &'static str> + '_ {
        let joints = OPTIONAL_Q_COLUMNS
            .iter()
            .filter(|c| self.columns.contains(c));
        self.optional.iter().chain(joints).copied()
    }
}

/// What a reader does with a column its kind of file does not define.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extra {
    /// Refuse it, listing the expected columns.
    Refuse,
    /// Ignore it, unless it looks like an optional column misspelt or in
    /// another unit (`laod_kg`, `payload_g` for `load_kg`): that must not silently
    /// become the optional column's default.
    Ignore,
}

impl Schema {
    /// The columns for messages, the joint angles as one run `q1_deg..qn_deg`.
    fn expected(&self) -> String {
        let mut names: Vec<&str> = Vec::new();
        for c in self.columns {
            if Q_COLUMNS[1..].contains(c) {
                continue;
            }
            names.push(if *c == Q_COLUMNS[0] {
                "q1_deg..qn_deg (one per joint)"
            } else {
                c
            });
        }
        names.join(",")
    }
}

/// Calls `each` for every data row of `text`, after checking the header against
/// `schema`. Returns the number of rows; a file without rows is an error.
pub fn for_each_row(
    text: &str,
    schema: &Schema,
    mut each: impl FnMut(&Row<'_>) -> Result<(), InputError>,
) -> Result<usize, InputError> {
    // Every leading byte order mark: a file saved by tools that each add one.
    let mut text = crate::io::lf_line_ends(text.trim_start_matches('\u{feff}'));
    // The `csv` crate reads a last `#` line without a line end as a record,
    // not a comment.
    if !text.is_empty() && !text.ends_with('\n') {
        text.to_mut().push('\n');
    }
    let mut reader = ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(Trim::All)
        // Field counts are checked here, to name the line and both counts.
        .flexible(true)
        .from_reader(text.as_bytes());
    let header_record = reader.headers().map_err(csv_error)?.clone();
    let header_line = record_line(&text, header_record.position(), Some(b'#')).max(1);
    let header = check_header(&header_record, header_line, schema)?;
    let mut record = StringRecord::new();
    let mut rows = 0;
    while reader.read_record(&mut record).map_err(csv_error)? {
        let line = record_line(&text, record.position(), Some(b'#'));
        header.check_width(&record, line)?;
        each(&Row {
            header: &header,
            record: &record,
            line,
        })?;
        rows += 1;
    }
    if rows == 0 {
        return Err(InputError::new(
            Location::line(header_line),
            Problem::NoRows,
        ));
    }
    Ok(rows)
}

fn csv_error(error: csv::Error) -> InputError {
    let line = error.position().map(|p| p.line());
    InputError::new(
        Location { line, field: None },
        Problem::Syntax {
            message: error.to_string(),
        },
    )
}

/// A number with at most `decimals` decimals, trailing zeros dropped, never `-0`.
///
/// Files are read by people and spreadsheets: `540` beats `539.9999999999999`,
/// and 1e-6 mm or 1e-9 deg is far below anything a tracker or servo resolves.
pub fn format_fixed(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        &text
    };
    if text == "-0" {
        "0".to_owned()
    } else {
        text.to_owned()
    }
}

/// Millimetres as written to files (1 nm resolution).
pub fn format_mm(value_m: f64) -> String {
    format_fixed(value_m * 1000.0, 6)
}

/// Degrees as written to files (1e-9 deg resolution).
pub fn format_deg(value_rad: f64) -> String {
    format_fixed(value_rad.to_degrees(), 9)
}

/// A joint value for its column: a revolute joint's in degrees
/// ([`format_deg`]), a prismatic one's in mm to the nanometre.
pub fn format_joint(kind: JointKind, value: f64) -> String {
    match kind {
        JointKind::Revolute => format_deg(value),
        JointKind::Prismatic => format_fixed(value * 1e3, 6),
    }
}
