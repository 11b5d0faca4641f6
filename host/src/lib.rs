//! `lrmcal`: calibrate a low-cost arm from 3D tool positions.
//!
//! The command line, the top floor of the host side: each subcommand lives in
//! its own file under [`commands`] and only parses its arguments, reads files
//! (`lrmcal_core`), calls the engine (`lrmcal_engine`) and writes and prints
//! the results. The binary is a thin shell over [`main_impl`].

pub mod cli;
pub mod commands;
pub mod error;
pub mod fuzz;
pub mod plots;
pub mod progress;
pub mod report_page;

pub use cli::main_impl;
pub use error::Error;
