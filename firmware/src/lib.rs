//! The firmware's hardware-independent logic, tested on the host.
//!
//! The embassy binary (`main.rs`, `board/`) only moves bytes and time in and
//! out of a [`Device`]: it feeds USB bytes through a
//! [`protocol::FrameReader`] into [`Device::handle_frame`], calls
//! [`Device::servo_frame`] every 20 ms, and implements the two small traits
//! [`ServoBus`] (PWM outputs) and [`FlashStorage`] (the two calibration
//! sectors). Neither call waits on I/O or panics, whatever the bytes; the
//! one slow step is `calib/commit` / `calib/erase`, which erase and program
//! one 4 KiB flash sector inside `handle_frame` (tens of ms on the RP2040,
//! during which the PWM hardware keeps the last pulses).
//!
//! | module | what it holds |
//! |---|---|
//! | [`app`] | [`Device`] (the context): state, start-up, the servo frame (with the backlash offset), rules the handlers share |
//! | `handlers` | one function per endpoint of the `protocol` table |
//! | `dispatch` | the dispatch table and [`Device::handle_frame`]: frames in, replies out |
//! | [`servo`] | the servo bus trait, joint and pulse limits, angle → pulse |
//! | [`motion`] | speed/acceleration-limited, synchronised joint motion |
//! | [`compensator`] | one Newton step of compensation per servo frame, with fallback |
//! | [`storage`] | two flash slots with sequence number and CRC |
//! | [`config`] | limits and tuning with their defaults |
//! | `float` | float comparisons and rounding on the bits, where a float comparison would be a call |
//! | `soft_float` | IEEE single-precision add/sub/mul for the Cortex-M0+ (common case in Thumb assembly), linked in place of the compiler's on the MCU |
//! | `sim` | the board without hardware: a recording servo bus and a flash that can lose power (feature `sim`, which the host's in-memory board uses) |
//! | `fuzz` | generated cases played against the device on those doubles, with the invariants checked (feature `fuzz`, for tests only) |
//!
//! Start-up: every channel starts limp (no pulses), so power-on never jerks
//! the arm. The first `motion/move`, `motion/home` or `servo/attach` assumes
//! the arm rests at the calibration's home pose (all zeros without a
//! calibration) and moves smoothly from there: park the arm at home
//! (`lrmcal home`, then `lrmcal detach`) before switching it off.
//!
//! Joints and channels: the board drives the calibration's arm, of 1 to
//! [`CHANNELS`] joints, joint `i` on channel `i`; without a calibration, an
//! arm of [`CHANNELS`] joints on the data-sheet curve (as before arms of any
//! other size existed). The channels past the arm's last joint are always
//! limp: moves, `motion/home` and attaching all leave them alone, attaching
//! one or a raw pulse on one is refused (`UnusedChannel`), and a calibration
//! of fewer joints makes them limp as it is applied. Joint vectors (targets,
//! positions, corrections) are [`PerChannel`]s of the arm's length; what is
//! per channel (servo curves, limits, pulses) stays a `[_; CHANNELS]` array.
#![cfg_attr(not(any(test, feature = "sim")), no_std)]

pub mod app;
pub mod compensator;
pub mod config;
mod dispatch;
mod float;
#[cfg(any(test, feature = "fuzz"))]
pub mod fuzz;
mod handlers;
pub mod motion;
pub mod servo;
#[cfg(any(test, feature = "sim"))]
pub mod sim;
#[cfg(any(test, target_os = "none"))]
mod soft_float;
pub mod storage;
#[cfg(test)]
mod tests;

pub use app::{Device, SystemAction};
pub use config::Config;
/// The board's servo channels, and one value per joint of the arm it drives.
pub use protocol::{CHANNELS, PerChannel};
pub use servo::ServoBus;
pub use storage::FlashStorage;
