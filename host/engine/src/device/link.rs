//! The byte link to the board: a USB serial port, or a TCP socket for the
//! emulator (`socket://HOST:PORT`). Both are a [`Link`]; the client does not
//! know which one it has.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use super::CommsError;

/// A byte stream with a read timeout.
pub trait Link: Read + Write {
    /// Sets how long a `read` waits before returning `TimedOut` or `WouldBlock`.
    fn set_timeout(&mut self, timeout: Duration) -> std::io::Result<()>;
}

impl Link for TcpStream {
    fn set_timeout(&mut self, timeout: Duration) -> std::io::Result<()> {
        self.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))
    }
}

impl Link for Box<dyn serialport::SerialPort> {
    fn set_timeout(&mut self, timeout: Duration) -> std::io::Result<()> {
        serialport::SerialPort::set_timeout(self.as_mut(), timeout).map_err(std::io::Error::from)
    }
}

impl<L: Link + ?Sized> Link for Box<L> {
    fn set_timeout(&mut self, timeout: Duration) -> std::io::Result<()> {
        (**self).set_timeout(timeout)
    }
}

/// The USB CDC-ACM line rate; the board ignores it, but the OS wants one.
const BAUD: u32 = 115_200;

/// Opens `port`: `socket://HOST:PORT` is a TCP connection, anything else a serial port.
pub fn open(port: &str) -> Result<Box<dyn Link>, CommsError> {
    let failed = |source: std::io::Error| CommsError::Open {
        port: port.to_owned(),
        source,
    };
    if let Some(address) = port.strip_prefix("socket://") {
        let stream = TcpStream::connect(address).map_err(failed)?;
        stream.set_nodelay(true).map_err(failed)?;
        return Ok(Box::new(stream));
    }
    let serial = serialport::new(port, BAUD)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|e| failed(e.into()))?;
    Ok(Box::new(serial))
}
