//! A board in memory: the firmware library itself ([`firmware::Device`]) on
//! its recording servo bus and simulated flash (`firmware::sim`), behind a
//! [`Link`], so a [`super::Client`] talks to it exactly as to a board on a
//! cable. The demo's positioning drives it frame by frame; the tests also
//! pull its cable, lose its replies and cut its power.
//!
//! Time is the board's own: [`MemoryBoard::frame`] runs one 20 ms servo
//! frame. A board made [`MemoryBoard::running`] also runs one each time the
//! host reads (a board that goes on while the host waits for its answer).

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::time::Duration;

use firmware::sim::{MockBus, SimFlash};
use firmware::{CHANNELS, Config, Device};
use protocol::frame::{Feed, MAX_FRAME};
use protocol::{FrameReader, Request};

use super::Link;

/// The servo frame period of the firmware, µs (50 Hz).
pub const FRAME_US: u64 = 20_000;

/// The firmware on in-memory servo outputs and flash, behind a byte link.
pub struct MemoryBoard {
    device: Option<Device<MockBus, SimFlash>>,
    reader: FrameReader<MAX_FRAME>,
    replies: VecDeque<u8>,
    now_us: u64,
    frame_per_read: bool,
    /// Bytes the host may still send before the cable is pulled.
    cable_bytes: Option<usize>,
    /// Replies to lose on the way back, by the request path that caused them.
    lose_reply_to: Vec<&'static str>,
}

impl Default for MemoryBoard {
    fn default() -> Self {
        Self::new(SimFlash::new())
    }
}

impl MemoryBoard {
    /// A board booted on `flash` (erased: a board that never had a
    /// calibration), its time standing still between [`MemoryBoard::frame`]s.
    pub fn new(flash: SimFlash) -> Self {
        Self {
            device: Some(Device::new(MockBus::default(), flash, Config::default(), 0)),
            reader: FrameReader::new(),
            replies: VecDeque::new(),
            now_us: 0,
            frame_per_read: false,
            cable_bytes: None,
            lose_reply_to: Vec::new(),
        }
    }

    /// The same board running one servo frame at every read of the host.
    pub fn running(self) -> Self {
        Self {
            frame_per_read: true,
            ..self
        }
    }

    /// The firmware.
    ///
    /// # Panics
    /// While the power is off (inside [`MemoryBoard::reboot`] only).
    pub fn device(&mut self) -> &mut Device<MockBus, SimFlash> {
        self.device.as_mut().expect("the board is powered")
    }

    /// Runs one servo frame and returns the pulses on the outputs, µs (`None`: limp).
    pub fn frame(&mut self) -> [Option<u16>; CHANNELS] {
        self.now_us += FRAME_US;
        let now = self.now_us;
        let device = self.device();
        device.servo_frame(now);
        device.bus().now
    }

    /// The board's time, µs since it booted.
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Power off and on again, keeping the flash (its power restored).
    pub fn reboot(&mut self) {
        let (_, mut flash) = self.device.take().expect("the board is powered").release();
        flash.power_on();
        self.now_us = 0;
        self.replies.clear();
        self.device = Some(Device::new(MockBus::default(), flash, Config::default(), 0));
    }

    /// Switches the power off and hands over the flash as it is (the
    /// board is gone: nothing but [`MemoryBoard::new`] on the flash brings it back).
    pub fn power_off(&mut self) -> SimFlash {
        self.replies.clear();
        self.device
            .take()
            .expect("the board is powered")
            .release()
            .1
    }

    /// Pulls the cable after the host has sent `bytes` more bytes.
    pub fn pull_cable_after(&mut self, bytes: usize) {
        self.cable_bytes = Some(bytes);
    }

    /// Plugs the cable in again.
    pub fn reconnect_cable(&mut self) {
        self.cable_bytes = None;
    }

    /// Loses the board's next reply to a request of `path`.
    pub fn lose_reply_to(&mut self, path: &'static str) {
        self.lose_reply_to.push(path);
    }

    /// How many replies are still to be lost.
    pub fn replies_to_lose(&self) -> usize {
        self.lose_reply_to.len()
    }

    /// Puts `bytes` on the line towards the host, as if the board had sent
    /// them (a board of another protocol, a stray reply).
    pub fn answer_with(&mut self, bytes: &[u8]) {
        self.replies.extend(bytes);
    }

    fn unplugged() -> io::Error {
        io::Error::new(io::ErrorKind::BrokenPipe, "device disconnected")
    }
}

impl Write for MemoryBoard {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        for &b in bytes {
            if let Some(left) = &mut self.cable_bytes {
                if *left == 0 {
                    return Err(Self::unplugged());
                }
                *left -= 1;
            }
            if let Feed::Frame(f) = self.reader.feed(b) {
                let f = f.to_vec();
                let path = protocol::frame::decode::<Request>(&f).map(|(_, r)| r.path());
                let mut out = [0u8; MAX_FRAME];
                let n = self.device().handle_frame(&f, &mut out);
                match self.lose_reply_to.iter().position(|p| Ok(*p) == path) {
                    Some(i) => {
                        self.lose_reply_to.remove(i);
                    }
                    None => self.replies.extend(&out[..n]),
                }
            }
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Read for MemoryBoard {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.cable_bytes == Some(0) {
            return Err(Self::unplugged());
        }
        if self.frame_per_read {
            self.frame();
        }
        if self.replies.is_empty() {
            return Err(io::ErrorKind::TimedOut.into());
        }
        let n = buf.len().min(self.replies.len());
        for (slot, b) in buf.iter_mut().zip(self.replies.drain(..n)) {
            *slot = b;
        }
        Ok(n)
    }
}

impl Link for MemoryBoard {
    fn set_timeout(&mut self, _: Duration) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Client;
    use protocol::Timing;

    #[test]
    fn a_client_moves_the_board_in_memory_frame_by_frame() {
        let mut client = Client::new(MemoryBoard::default(), Duration::from_millis(1), 0);
        assert!(client.status().unwrap().calibration.is_none());
        client
            .move_to([0.2, 0.0, 0.0, 0.0, 0.0, 0.0].into(), Timing::DurationMs(0))
            .unwrap();
        let first = client.link_mut().frame();
        assert!(first.iter().all(Option::is_some), "{first:?}");
        for _ in 0..100 {
            client.link_mut().frame();
        }
        let status = client.status().unwrap();
        assert!(!status.moving);
        assert_eq!(status.nominal_rad[0], 0.2);
        assert_eq!(client.link_mut().now_us(), 101 * FRAME_US);
    }
}
