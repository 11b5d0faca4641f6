//! One file per `lrmcal` subcommand: its clap `Args` and its `run`.
//!
//! See `crate::cli` for how to add one.

pub mod demo;
pub mod plan;
pub mod predict;
pub mod simulate;
