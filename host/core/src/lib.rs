//! The ground floor of lrmcal's host side: what the other floors exchange and
//! what users exchange with them.
//!
//! | module | what it holds |
//! |---|---|
//! | [`dataset`] | poses, measurements and predictions as the engine uses them (SI units) |
//! | [`param_key`] | the names of the quantities a calibration may correct |
//! | [`camera`] | the camera as the instrument: intrinsics and their files, the AprilTag board, whether the camera sees it, the camera setup file |
//! | [`collision`] | the arm's collision bodies: as described, and placed on the arm |
//! | [`io`] | every file format users exchange with lrmcal, read and written |
//! | [`error`] | a file that could not be read, written or used, and where its content is wrong |
//!
//! Nothing here fits, plans or prints: the engine above computes, the command
//! line above it talks to the user.

pub mod camera;
pub mod collision;
pub mod dataset;
pub mod error;
pub mod io;
pub mod param_key;

pub use error::Error;
