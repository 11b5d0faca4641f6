//! USB CDC-ACM serial: the board's link to `lrmcal`.
//!
//! The board enumerates as one CDC-ACM serial port (a `/dev/ttyACM*` on
//! Linux, a COM port on Windows; no driver needed). USB ids: the pid.codes
//! test pair 1209:0001, product string "lrmcal arm". Full speed, 64-byte
//! packets. The line settings (baud rate etc.) are ignored: it is USB.

use defmt::panic;
use embassy_rp::peripherals::USB;
use embassy_rp::usb::{Driver, InterruptHandler};
use embassy_rp::{Peri, bind_interrupts};
use embassy_usb::class::cdc_acm::{CdcAcmClass, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::{Builder, UsbDevice};
use static_cell::StaticCell;

/// USB vendor id: pid.codes, the open-source vendor id.
pub const VID: u16 = 0x1209;
/// USB product id: pid.codes' test id for hobby and development devices.
pub const PID: u16 = 0x0001;
/// Bytes per USB full-speed bulk packet.
pub const PACKET: usize = 64;

bind_interrupts!(struct Irqs {
    USBCTRL_IRQ => InterruptHandler<USB>;
});

/// The USB driver of the RP2040.
pub type UsbDriver = Driver<'static, USB>;
/// The CDC-ACM serial port.
pub type Serial = CdcAcmClass<'static, UsbDriver>;

/// The host closed the port or the cable was pulled: an expected event.
pub struct Disconnected;

impl From<EndpointError> for Disconnected {
    fn from(e: EndpointError) -> Self {
        match e {
            // Our buffers are one packet long: an overflow is a bug here.
            EndpointError::BufferOverflow => panic!("USB buffer overflow"),
            EndpointError::Disabled => Disconnected,
        }
    }
}

/// Builds the USB device (to be run by its own task) and its serial port.
///
/// Call once: the descriptors live in statics.
pub fn init(usb: Peri<'static, USB>) -> (UsbDevice<'static, UsbDriver>, Serial) {
    let driver = Driver::new(usb, Irqs);

    let mut config = embassy_usb::Config::new(VID, PID);
    config.manufacturer = Some("lrmcal");
    config.product = Some("lrmcal arm");
    config.max_power = 100;
    config.max_packet_size_0 = PACKET as u8;

    static CONFIG_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static STATE: StaticCell<State> = StaticCell::new();

    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESC.init([0; 256]),
        BOS_DESC.init([0; 256]),
        &mut [], // no Microsoft OS descriptors
        CONTROL_BUF.init([0; 64]),
    );
    let serial = CdcAcmClass::new(&mut builder, STATE.init(State::new()), PACKET as u16);
    (builder.build(), serial)
}

/// Writes `bytes` as one USB transfer: full packets, then a short (possibly
/// empty) one, so the host sees where the transfer ends.
pub async fn write_all(serial: &mut Serial, bytes: &[u8]) -> Result<(), Disconnected> {
    let mut last_len = 0;
    for chunk in bytes.chunks(PACKET) {
        serial.write_packet(chunk).await?;
        last_len = chunk.len();
    }
    if last_len == PACKET {
        serial.write_packet(&[]).await?;
    }
    Ok(())
}
