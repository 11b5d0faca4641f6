//! One file per `lrmcal` subcommand: its clap `Args` and its `run`, and the
//! helpers they share.
//!
//! See `crate::cli` for how to add one.

use std::path::Path;

use crate::error::Error;
use crate::io::atomic;

pub mod compensation;
pub mod demo;
pub mod detach;
pub mod export;
pub mod flash;
pub mod home;
pub mod identify;
pub mod import_tracker;
pub mod measure;
pub mod move_;
pub mod payload;
pub mod plan;
pub mod ports;
pub mod predict;
pub mod pull;
pub mod push;
pub mod select;
pub mod servo_tune;
pub mod simulate;
pub mod status;
pub mod validate;

/// Writes a text file (JSON, a report) whole or not at all (see [`atomic`]).
pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), Error> {
    atomic::write(path, |w| w.write_all(text.as_bytes()))
}
