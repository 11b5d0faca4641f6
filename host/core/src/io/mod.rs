//! Reading and writing the files users exchange with `lrmcal` (each described
//! in `docs/FORMATS.md`): arm descriptions (TOML, or a URDF's serial chain),
//! measurements, pose lists and predictions (CSV), and the calibration file
//! (JSON).
//!
//! Parsers take text and return an [`InputError`](crate::error::InputError)
//! naming line and key or column; the `read` functions add the file name.
//! The formats are plain data: nothing here knows the calibration engine,
//! which converts its results into them.
//! Units are converted here, at the boundary: files hold degrees and
//! millimetres, memory holds radians and metres. Writers never leave a
//! half-written file (see [`atomic`]).

pub mod arm_source;
pub mod arm_toml;
pub mod arm_urdf;
pub mod atomic;
pub mod bounds;
pub mod calibration_file;
pub(crate) mod csv_table;
pub mod json;
pub mod measurements;
pub mod model_option;
pub mod pose_list;
pub mod predictions;
pub mod urdf;
pub mod urdf_chain;

use std::path::Path;

use crate::error::{Error, InputError, Location, Problem};

/// A serde key path as messages show it: `joint[3].servo.zero`, array
/// positions counted from 1 (like the joints `j1..j6`).
pub(crate) fn key_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for segment in path.iter() {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{}]", index + 1)),
            // `toml::Spanned` wraps a value in a private map; its keys are not the user's.
            Segment::Map { key } if key.starts_with("$__") => {}
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => {}
        }
    }
    out
}

/// Reads a whole text file, naming it in the error.
///
/// A leading UTF-8 byte order mark (spreadsheets save CSV with one) is
/// dropped, so it does not become part of the first column's or key's name.
/// Bytes that are not UTF-8 are an error of the content, at their line.
pub fn read_text(path: &Path) -> Result<String, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Read {
        path: path.to_owned(),
        source,
    })?;
    text_of(bytes).map_err(|e| e.in_file(path))
}

/// `text` with every line ended by `\n`: a `\r\n` (Windows) and a lone
/// `\r` (old Mac) become `\n`.
///
/// The `csv` crate ends a record at either, but counts lines by `\n` only,
/// and only once it reads on: before this, a CRLF file's errors named the
/// line above the one at fault. CSV readers call it first, so that the same
/// file with either line ends names the same lines.
pub fn lf_line_ends(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.contains('\r') {
        return std::borrow::Cow::Borrowed(text);
    }
    std::borrow::Cow::Owned(text.replace("\r\n", "\n").replace('\r', "\n"))
}

/// The line a CSV record starts on, 1-based (0 if unknown).
///
/// The `csv` crate places a record where it began reading it: before the
/// empty lines (and the `comment` lines, when the reader has a comment
/// character) it skipped on the way, which its line count then names
/// instead of the record's own line. `text` has `\n` line ends
/// ([`lf_line_ends`]) and no byte order mark, so the position's byte is the
/// start of a line of `text`.
pub fn record_line(text: &str, position: Option<&csv::Position>, comment: Option<u8>) -> u64 {
    let Some(position) = position else {
        return 0;
    };
    let bytes = text.as_bytes();
    let mut at = usize::try_from(position.byte()).unwrap_or(usize::MAX);
    let mut line = position.line();
    loop {
        match bytes.get(at) {
            Some(b'\n') => at += 1,
            Some(&b) if Some(b) == comment => match bytes[at..].iter().position(|&b| b == b'\n') {
                Some(end) => at += end + 1,
                None => return line,
            },
            _ => return line,
        }
        line += 1;
    }
}

/// The UTF-8 byte order mark.
const BOM: &[u8] = "\u{feff}".as_bytes();

/// A file's bytes as text, without a leading byte order mark.
fn text_of(mut bytes: Vec<u8>) -> Result<String, InputError> {
    if bytes.starts_with(BOM) {
        bytes.drain(..BOM.len());
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        let line_start = before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let line = before.iter().filter(|&&b| b == b'\n').count() as u64 + 1;
        InputError::new(
            Location::line(line),
            Problem::NotUtf8 {
                byte: e.as_bytes()[at],
                column: at - line_start + 1,
            },
        )
    })
}
