//! Listening to a live DTrack stream on a UDP port (`dtrack://[ADDR:]PORT`).
//!
//! DTrack sends a datagram per frame whether or not anyone listens, so while
//! the arm moves the socket fills with frames of the move. Each reading first
//! drops what is queued, then feeds fresh frames to a [`Settler`] until it has
//! a reading, the target is lost for too long, or the time is up.

use std::io::ErrorKind;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::{Duration, Instant};

use super::TrackerError;
use super::dtrack::{self, Target};
use super::settle::{LastFrame, Reading, SettleOptions, Settler};

/// The scheme of a DTrack address on the command line.
pub const SCHEME: &str = "dtrack://";

/// Parses `dtrack://PORT` (all interfaces) or `dtrack://ADDR:PORT`.
pub fn parse_address(spec: &str) -> Result<SocketAddr, String> {
    let rest = spec
        .strip_prefix(SCHEME)
        .ok_or_else(|| format!("expected `{SCHEME}[ADDR:]PORT`, found `{spec}`"))?;
    let bad = || {
        format!(
            "expected `{SCHEME}PORT` or `{SCHEME}ADDR:PORT` (e.g. {SCHEME}5000, {SCHEME}192.168.1.20:5000), found `{spec}`"
        )
    };
    if let Ok(port) = rest.parse::<u16>() {
        return Ok(SocketAddr::from(([0, 0, 0, 0], port)));
    }
    rest.to_socket_addrs()
        .map_err(|_| bad())?
        .next()
        .ok_or_else(bad)
}

/// A bound UDP socket receiving DTrack output.
pub struct Listener {
    socket: UdpSocket,
    addr: SocketAddr,
    last: Option<(u64, Option<f64>, Instant)>,
    foreign: Option<(usize, String)>,
    buf: Vec<u8>,
}

impl Listener {
    /// Binds the socket DTrack sends to.
    pub fn bind(addr: SocketAddr) -> Result<Self, TrackerError> {
        let socket =
            UdpSocket::bind(addr).map_err(|source| TrackerError::Listen { addr, source })?;
        let addr = socket.local_addr().unwrap_or(addr);
        Ok(Self {
            socket,
            addr,
            last: None,
            foreign: None,
            // DTrack datagrams are a few hundred bytes per body; the largest UDP payload fits.
            buf: vec![0; 65_536],
        })
    }

    /// The address actually bound (the port is chosen by the OS for port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// One reading of `target`: waits at most `timeout` for a still window.
    pub fn read(
        &mut self,
        target: Target,
        options: SettleOptions,
        timeout: Duration,
    ) -> Result<Reading, TrackerError> {
        let addr = self.addr;
        let fail = |problem| TrackerError::Stream {
            addr,
            target,
            problem,
        };
        self.drain()?;
        let mut settler = Settler::new(target, options);
        let start = Instant::now();
        loop {
            let left = timeout.saturating_sub(start.elapsed());
            if left.is_zero() {
                let last = self.last.map(|(counter, timestamp_s, at)| LastFrame {
                    counter,
                    timestamp_s,
                    ago_s: at.elapsed().as_secs_f64(),
                });
                let problem = settler.give_up(timeout.as_secs_f64(), last, self.foreign.clone());
                return Err(fail(problem));
            }
            self.socket
                .set_read_timeout(Some(left))
                .map_err(|source| self.receive_error(source))?;
            let Some(frame) = self.receive()? else {
                continue;
            };
            if let Some(reading) = settler.push(&frame).map_err(fail)? {
                return Ok(reading);
            }
        }
    }

    /// Drops the datagrams queued while nobody was reading.
    fn drain(&mut self) -> Result<(), TrackerError> {
        self.socket
            .set_nonblocking(true)
            .map_err(|source| self.receive_error(source))?;
        while self.receive()?.is_some() {}
        self.socket
            .set_nonblocking(false)
            .map_err(|source| self.receive_error(source))
    }

    /// The next DTrack frame, `None` when the wait ended or the datagram was not DTrack output.
    fn receive(&mut self) -> Result<Option<dtrack::Frame>, TrackerError> {
        let n = match self.socket.recv(&mut self.buf) {
            Ok(n) => n,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return Ok(None);
            }
            // An ICMP "port unreachable" from an earlier send; nothing to do with us.
            Err(e) if e.kind() == ErrorKind::ConnectionReset => return Ok(None),
            Err(source) => return Err(self.receive_error(source)),
        };
        match dtrack::parse(&String::from_utf8_lossy(&self.buf[..n])) {
            Ok(frame) => {
                self.last = Some((frame.counter, frame.timestamp_s, Instant::now()));
                Ok(Some(frame))
            }
            Err(e) => {
                let count = self.foreign.as_ref().map_or(0, |(n, _)| *n);
                self.foreign = Some((count + 1, e.to_string()));
                Ok(None)
            }
        }
    }

    fn receive_error(&self, source: std::io::Error) -> TrackerError {
        TrackerError::Receive {
            addr: self.addr,
            source,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_with_and_without_a_host() {
        assert_eq!(
            parse_address("dtrack://5000").unwrap(),
            "0.0.0.0:5000".parse().unwrap()
        );
        assert_eq!(
            parse_address("dtrack://127.0.0.1:5001").unwrap(),
            "127.0.0.1:5001".parse().unwrap()
        );
        assert_eq!(
            parse_address("dtrack://[::1]:5002").unwrap(),
            "[::1]:5002".parse().unwrap()
        );
        let err = parse_address("dtrack://tracker").unwrap_err();
        assert!(err.contains("expected `dtrack://PORT`"), "{err}");
        assert!(parse_address("dtrack://70000").is_err());
        assert!(parse_address("udp://5000").is_err());
    }
}
