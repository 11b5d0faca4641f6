//! The board's long-lived jobs, one task each.
//!
//! | task | job |
//! |---|---|
//! | [`servo::servo_frames`] | every 20 ms: motion, compensation, six pulses; feeds the watchdog |
//! | [`serial::serial`] | request frames from USB into the device, replies back out |
//! | [`usb::usb_device`] | runs the USB stack (enumeration, control requests) |

pub mod serial;
pub mod servo;
pub mod usb;
