//! The dispatch table: request frames in, reply frames out.
//!
//! The table lives here rather than in `app.rs` on purpose. It names every
//! handler, and every handler works on the [`Device`] that `app.rs` defines;
//! with the table in `app.rs` the two modules would import each other.
//! Here the modules form a line, `app` (the context) ← `handlers` (one
//! function per endpoint) ← `dispatch` (the wire side and the table), and a
//! new endpoint is one row of the `protocol` table, one row below and one
//! handler.

use protocol::frame::{self, FrameError, MAX_FRAME};
use protocol::{Faults, Request, Response, WireError};

use crate::{Device, FlashStorage, ServoBus, handlers as h};

/// Routes a decoded request to its handler: one row per endpoint.
fn dispatch<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>, request: Request) -> Response {
    let reply = match request {
        Request::Hello => h::hello(d),
        Request::Status => h::status(d),
        Request::Move {
            targets_rad,
            timing,
        } => h::move_to(d, targets_rad, timing),
        Request::Home { timing } => h::home(d, timing),
        Request::Attach { channel } => h::attach(d, channel),
        Request::Detach { channel } => h::detach(d, channel),
        Request::RawPulse { channel, pulse_us } => h::raw_pulse(d, channel, pulse_us),
        Request::SetPayload { mass_kg } => h::set_payload(d, mass_kg),
        Request::SetCompensation { mode } => h::set_compensation(d, mode),
        Request::CalibrationBegin { len_bytes, crc } => h::calibration_begin(d, len_bytes, crc),
        Request::CalibrationChunk { offset, data } => h::calibration_chunk(d, offset, &data),
        Request::CalibrationCommit => h::calibration_commit(d),
        Request::CalibrationRead { offset } => h::calibration_read(d, offset),
        Request::CalibrationErase => h::calibration_erase(d),
        Request::RebootToBootloader => h::reboot_to_bootloader(d),
    };
    reply.unwrap_or_else(Response::Error)
}

impl<B: ServoBus, F: FlashStorage> Device<B, F> {
    /// Handles one frame from the host (COBS bytes as cut by a
    /// [`protocol::FrameReader`], with or without the 0x00) and writes the
    /// reply frame into `out`; returns the reply's length, 0 for none.
    pub fn handle_frame(&mut self, frame: &[u8], out: &mut [u8; MAX_FRAME]) -> usize {
        let (seq, response) = match frame::decode::<Request>(frame) {
            Ok((seq, request)) => (seq, dispatch(self, request)),
            Err(FrameError::Version { seq, .. }) => {
                (seq, Response::Error(WireError::VersionMismatch))
            }
            Err(FrameError::Body { seq }) => (seq, Response::Error(WireError::UnknownRequest)),
            Err(_) => {
                // Corrupt: its seq is not trustworthy, so no reply; the host retries.
                self.count_dropped_frame();
                return 0;
            }
        };
        frame::encode(seq, &response, out).unwrap_or(0)
    }

    /// Counts a frame the binary's [`protocol::FrameReader`] dropped as over-long.
    pub fn frame_overflowed(&mut self) {
        self.count_dropped_frame();
    }

    /// A frame was lost: `status/get` reports the count and the latched flag.
    fn count_dropped_frame(&mut self) {
        self.frames_dropped = self.frames_dropped.saturating_add(1);
        self.faults.set(Faults::FRAMES_DROPPED, true);
    }
}
