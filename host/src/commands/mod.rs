//! One file per `lrmcal` subcommand: its clap `Args` and its `run`; what
//! several share is in [`helpers`].
//!
//! See `crate::cli` for how to add one.

pub mod compensation;
pub mod demo;
pub mod detach;
pub mod detect;
pub mod device_args;
pub mod emulator;
pub mod export;
pub mod flash;
pub mod helpers;
pub mod home;
pub mod identify;
pub mod import_tracker;
pub mod measure;
pub mod move_;
pub mod payload;
pub mod plan;
pub mod ports;
pub mod predict;
pub mod print_board;
pub mod pull;
pub mod push;
pub mod report;
pub mod select;
pub mod servo_tune;
pub mod simulate;
pub mod status;
pub mod validate;
