//! The USB device task: enumeration and control requests, forever.

use embassy_usb::UsbDevice;

use crate::board::usb::UsbDriver;

/// Runs the USB stack; the serial task talks through the class it built.
#[embassy_executor::task]
pub async fn usb_device(mut usb: UsbDevice<'static, UsbDriver>) -> ! {
    usb.run().await
}
