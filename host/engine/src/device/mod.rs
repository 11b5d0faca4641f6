//! Talking to the board: the serial (or TCP) link, the typed client with one
//! method per endpoint of the `protocol` table, the conversion of a
//! calibration file into the payload the board stores, what a board
//! holding a calibration will command (`commanded`), and a board in memory
//! (`memory`: the firmware library behind a link) where no hardware is.
//!
//! Data flow: `lrmcal <device command>` → [`open`] → [`Client`] →
//! `protocol` frames → [`Link`] → board.

pub mod calibration;
pub mod client;
pub mod commanded;
pub mod link;
pub mod memory;

pub use client::{Client, ClientError, CommsError};
pub use link::{Link, open};
