//! The binary's context: the library's [`Device`] on this board, shared by
//! the tasks, and the system actions the library asks for.
//!
//! The library does all the deciding (dispatch, motion, compensation,
//! storage); the binary only owns the hardware and the clock.

use core::cell::RefCell;

use embassy_rp::rom_data;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::ThreadModeRawMutex;
use embassy_time::Instant;
use firmware::{Config, Device, SystemAction};
use protocol::FirmwareVersion;

use crate::board::flash::CalibrationFlash;
use crate::board::servo_pwm::ServoPwm;

/// The firmware library's device on this board's servo outputs and flash.
pub type Board = Device<ServoPwm, CalibrationFlash>;

/// The device as the tasks share it. All tasks run on the one thread-mode
/// executor, so the lock is never contended; each call into the device is
/// synchronous and finishes before another task can run.
pub type SharedBoard = Mutex<ThreadModeRawMutex, RefCell<Board>>;

/// Runs `f` on the device.
pub fn with_board<R>(board: &SharedBoard, f: impl FnOnce(&mut Board) -> R) -> R {
    board.lock(|cell| f(&mut cell.borrow_mut()))
}

/// Microseconds since boot: the library's clock.
pub fn now_us() -> u64 {
    Instant::now().as_micros()
}

/// The library's configuration with this build's version.
pub fn config() -> Config {
    Config {
        firmware: FirmwareVersion {
            major: parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
            minor: parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
            patch: parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
        },
        ..Config::default()
    }
}

/// A version component; evaluated at compile time, so a bad one fails the build.
const fn parse_u8(s: &str) -> u8 {
    let bytes = s.as_bytes();
    let mut value: u8 = 0;
    let mut i = 0;
    while i < bytes.len() {
        assert!(
            bytes[i].is_ascii_digit(),
            "version component is not a number"
        );
        value = value * 10 + (bytes[i] - b'0');
        i += 1;
    }
    value
}

/// Carries out what the library asked for once its reply has gone out.
pub fn perform(action: SystemAction) -> ! {
    match action {
        SystemAction::RebootToBootloader => {
            defmt::info!("rebooting into the USB bootloader");
            // No activity LED; both the mass-storage (UF2 drive) and the
            // PICOBOOT interface (picotool) enabled.
            rom_data::reset_to_usb_boot(0, 0);
            // The ROM call does not return; if it ever did, a reset is the safe end.
            cortex_m::peripheral::SCB::sys_reset()
        }
    }
}
