//! Reading and writing the files users exchange with `lrmcal`
//! (shared/CONTRACTS.md): arm descriptions (TOML), measurements, pose lists and
//! predictions (CSV).
//!
//! Parsers take text and return an [`InputError`](crate::error::InputError)
//! naming line and key or column; the `read` functions add the file name.
//! Units are converted here, at the boundary: files hold degrees and
//! millimetres, memory holds radians and metres. Writers never leave a
//! half-written file (see [`atomic`]).

pub mod arm_source;
pub mod arm_toml;
pub mod atomic;
mod csv_table;
pub mod measurements;
pub mod pose_list;
pub mod predictions;
pub mod urdf;

use std::path::Path;

use crate::error::Error;

/// Reads a whole text file, naming it in the error.
pub(crate) fn read_text(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|source| Error::Read {
        path: path.to_owned(),
        source,
    })
}
