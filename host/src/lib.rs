//! `lrmcal`: calibrate a low-cost arm from 3D tool positions.
//!
//! The binary is a thin shell over [`main_impl`]; each subcommand lives in its
//! own file under [`commands`], file formats under [`io`].

pub mod calib;
pub mod cli;
pub mod commands;
pub mod dataset;
pub mod device;
pub mod error;
pub mod fuzz;
pub mod ik;
pub mod io;
pub mod plan;
pub mod scale;
pub mod sim;
pub mod tracker;

pub use cli::main_impl;
pub use error::Error;
