//! The RP2040 board: chip-specific drivers behind the firmware library's traits.
//!
//! Everything here touches embassy-rp and exists only on the MCU
//! (`target_os = "none"`). The peripherals are handed out once, in named groups
//! (one group per long-lived job), by [`Resources::take`].
//!
//! | module | what it drives |
//! |---|---|
//! | [`servo_pwm`] | six 50 Hz servo outputs on three PWM slices (pin map there) |
//! | [`flash`] | the two calibration slots at the end of flash |
//! | [`usb`] | the USB CDC-ACM serial port |

pub mod flash;
pub mod servo_pwm;
pub mod usb;

use embassy_rp::Peri;
use embassy_rp::peripherals::{
    FLASH, PIN_2, PIN_3, PIN_4, PIN_5, PIN_6, PIN_7, PWM_SLICE1, PWM_SLICE2, PWM_SLICE3, USB,
    WATCHDOG,
};

/// The peripherals of the six servo outputs (see the pin map in [`servo_pwm`]).
pub struct ServoResources {
    /// Slice 1 drives servos 1 and 2.
    pub slice1: Peri<'static, PWM_SLICE1>,
    /// Slice 2 drives servos 3 and 4.
    pub slice2: Peri<'static, PWM_SLICE2>,
    /// Slice 3 drives servos 5 and 6.
    pub slice3: Peri<'static, PWM_SLICE3>,
    /// Servo 1, slice 1 channel A.
    pub s1: Peri<'static, PIN_2>,
    /// Servo 2, slice 1 channel B.
    pub s2: Peri<'static, PIN_3>,
    /// Servo 3, slice 2 channel A.
    pub s3: Peri<'static, PIN_4>,
    /// Servo 4, slice 2 channel B.
    pub s4: Peri<'static, PIN_5>,
    /// Servo 5, slice 3 channel A.
    pub s5: Peri<'static, PIN_6>,
    /// Servo 6, slice 3 channel B.
    pub s6: Peri<'static, PIN_7>,
}

/// All peripherals the firmware uses, grouped by the job that owns them.
pub struct Resources {
    /// The servo outputs (servo frame task).
    pub servo: ServoResources,
    /// The flash holding the calibration slots (the device, via the library).
    pub flash: Peri<'static, FLASH>,
    /// The USB controller (USB device and serial tasks).
    pub usb: Peri<'static, USB>,
    /// The watchdog, fed by the servo frame task.
    pub watchdog: Peri<'static, WATCHDOG>,
}

impl Resources {
    /// Splits the chip's peripherals into the firmware's groups.
    pub fn take(p: embassy_rp::Peripherals) -> Self {
        Self {
            servo: ServoResources {
                slice1: p.PWM_SLICE1,
                slice2: p.PWM_SLICE2,
                slice3: p.PWM_SLICE3,
                s1: p.PIN_2,
                s2: p.PIN_3,
                s3: p.PIN_4,
                s4: p.PIN_5,
                s5: p.PIN_6,
                s6: p.PIN_7,
            },
            flash: p.FLASH,
            usb: p.USB,
            watchdog: p.WATCHDOG,
        }
    }
}
