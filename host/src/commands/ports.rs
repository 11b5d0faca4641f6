//! `lrmcal ports`: the serial ports a board could be on.

use crate::error::Error;

/// List serial ports.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "The board shows up as a USB serial port (CDC-ACM), e.g. /dev/ttyACM0 on \
Linux or COM5 on Windows. Pass it to the device commands with --port or LRMCAL_PORT. The \
emulator is reached with --port socket://127.0.0.1:PORT."
)]
pub struct Args {}

/// Runs `lrmcal ports`.
pub fn run(_: &Args) -> Result<(), Error> {
    let ports = serialport::available_ports().map_err(|e| Error::DeviceInput {
        what: "list the serial ports".into(),
        reason: e.to_string(),
    })?;
    if ports.is_empty() {
        println!("no serial ports found (is the board plugged in?)");
    }
    for p in ports {
        let kind = match p.port_type {
            serialport::SerialPortType::UsbPort(usb) => format!(
                "USB {:04x}:{:04x} {}",
                usb.vid,
                usb.pid,
                usb.product.unwrap_or_default()
            ),
            serialport::SerialPortType::PciPort => "PCI".into(),
            serialport::SerialPortType::BluetoothPort => "Bluetooth".into(),
            serialport::SerialPortType::Unknown => "unknown".into(),
        };
        println!("{}\t{kind}", p.port_name);
    }
    Ok(())
}
