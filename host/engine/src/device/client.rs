//! The typed client: one method per endpoint, each a request frame out and a
//! matching response frame back, with timeouts and retries.
//!
//! Errors split in two: [`CommsError`] when the exchange itself failed (no
//! port, no answer, another protocol version) and [`ClientError::Endpoint`]
//! when the board answered and refused; a calibration the board would refuse
//! is not sent at all ([`ClientError::Invalid`]).

use std::io::ErrorKind;
use std::time::{Duration, Instant};

use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::{self, Feed, FrameError, MAX_FRAME, PROTOCOL_VERSION};
use protocol::{
    CHUNK_LEN, Calibration, CalibrationFault, CalibrationInfo, CompensationMode, DeviceInfo,
    FrameReader, Request, Response, Status, Timing, WireError,
};

use super::Link;

/// The exchange with the board failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CommsError {
    /// The port could not be opened.
    #[error("open `{port}` (is the board plugged in? `lrmcal ports` lists the serial ports)")]
    Open {
        /// The port name.
        port: String,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// Reading or writing the link failed (e.g. the board was unplugged).
    #[error("talk to the board during `{path}` (was it unplugged?)")]
    Io {
        /// The endpoint being called.
        path: &'static str,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// No valid reply within the timeout, after every retry.
    #[error("get an answer to `{path}` after {attempts} attempts of {timeout_ms} ms each")]
    Timeout {
        /// The endpoint being called.
        path: &'static str,
        /// Attempts made.
        attempts: u32,
        /// Timeout of each, ms.
        timeout_ms: u128,
    },
    /// The board speaks another protocol version. Both sides' frames keep
    /// their version in the first byte forever, so whichever side is older,
    /// this is what the newer lrmcal says (and what earlier ones said too).
    #[error(
        "agree on the protocol: the board speaks protocol {board}, this lrmcal speaks {PROTOCOL_VERSION}: {}",
        if *board < PROTOCOL_VERSION {
            "reflash the firmware (hold BOOTSEL while plugging the board in, then `lrmcal flash firmware.uf2`)"
        } else {
            "update lrmcal"
        }
    )]
    Version {
        /// The board's protocol version.
        board: u8,
    },
    /// The board answered with a response that does not fit the request.
    #[error("understand the board's answer to `{path}`: {got}")]
    Unexpected {
        /// The endpoint being called.
        path: &'static str,
        /// What came back.
        got: String,
    },
    /// A calibration read back from the board does not decode or check out.
    #[error("read the calibration back: {0}")]
    BadCalibration(&'static str),
}

/// A device call failed: either the exchange or the board's refusal.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The exchange failed.
    #[error(transparent)]
    Comms(#[from] CommsError),
    /// The board refused the request.
    #[error("`{path}`: the board said: {error}")]
    Endpoint {
        /// The endpoint.
        path: &'static str,
        /// Its reason.
        error: WireError,
    },
    /// A calibration the board would refuse was not sent.
    #[error("send the calibration: {0}; not sent")]
    Invalid(CalibrationFault),
}

/// A connection to one board.
pub struct Client<L> {
    link: L,
    timeout: Duration,
    retries: u32,
    seq: u16,
    reader: FrameReader<MAX_FRAME>,
}

impl<L: Link> Client<L> {
    /// A client over `link`; each request waits `timeout` and is resent up to `retries` times.
    pub fn new(link: L, timeout: Duration, retries: u32) -> Self {
        Self {
            link,
            timeout,
            retries,
            seq: 0,
            reader: FrameReader::new(),
        }
    }

    /// The link (to inspect an in-memory one in tests).
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// Sends `request` and waits for the response with its sequence number.
    pub fn call(&mut self, request: &Request) -> Result<Response, ClientError> {
        let path = request.path();
        let io = |source| CommsError::Io { path, source };
        for _ in 0..=self.retries {
            self.seq = self.seq.wrapping_add(1);
            // A leading 0x00 ends whatever half frame the board may hold (line
            // noise, an interrupted session), so this one is read from its start.
            let mut out = [0u8; MAX_FRAME + 1];
            let n = 1 + frame::encode(self.seq, request, &mut out[1..]).map_err(|e| {
                CommsError::Unexpected {
                    path,
                    got: format!("request does not fit a frame: {e}"),
                }
            })?;
            self.link
                .write_all(&out[..n])
                .and_then(|()| self.link.flush())
                .map_err(io)?;
            if let Some(response) = self.receive(path)? {
                return match response {
                    Response::Error(error) => Err(ClientError::Endpoint { path, error }),
                    other => Ok(other),
                };
            }
        }
        Err(CommsError::Timeout {
            path,
            attempts: self.retries + 1,
            timeout_ms: self.timeout.as_millis(),
        }
        .into())
    }

    /// Reads until the response to the current seq arrives (`Some`) or the timeout passes (`None`).
    fn receive(&mut self, path: &'static str) -> Result<Option<Response>, CommsError> {
        let deadline = Instant::now() + self.timeout;
        let mut buf = [0u8; 256];
        // The link is read at least once, however late this thread runs: a
        // reply already waiting is never taken for a timeout.
        let mut read_once = false;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() && read_once {
                return Ok(None);
            }
            read_once = true;
            self.link
                .set_timeout(left.max(Duration::from_millis(1)))
                .map_err(|source| CommsError::Io { path, source })?;
            let n = match self.link.read(&mut buf) {
                Ok(0) => {
                    let source = std::io::Error::new(ErrorKind::UnexpectedEof, "the link closed");
                    return Err(CommsError::Io { path, source });
                }
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) =>
                {
                    continue;
                }
                Err(source) => return Err(CommsError::Io { path, source }),
            };
            for &byte in &buf[..n] {
                let Feed::Frame(f) = self.reader.feed(byte) else {
                    continue;
                };
                match frame::decode::<Response>(f) {
                    Ok((seq, response)) if seq == self.seq => return Ok(Some(response)),
                    Err(FrameError::Version { theirs, .. }) => {
                        return Err(CommsError::Version { board: theirs });
                    }
                    // A late answer to an earlier attempt, or a damaged frame: keep listening.
                    _ => {}
                }
            }
        }
    }

    fn unexpected<T>(path: &'static str, got: Response) -> Result<T, ClientError> {
        Err(CommsError::Unexpected {
            path,
            got: format!("{got:?}"),
        }
        .into())
    }

    /// Calls an endpoint whose answer is [`Response::Done`].
    fn done(&mut self, request: Request) -> Result<(), ClientError> {
        match self.call(&request)? {
            Response::Done => Ok(()),
            other => Self::unexpected(request.path(), other),
        }
    }

    /// `link/hello`: the board's versions; fails with [`CommsError::Version`] on a mismatch.
    pub fn hello(&mut self) -> Result<DeviceInfo, ClientError> {
        match self.call(&Request::Hello)? {
            Response::Hello(info) if info.protocol == PROTOCOL_VERSION => Ok(info),
            Response::Hello(info) => Err(CommsError::Version {
                board: info.protocol,
            }
            .into()),
            other => Self::unexpected("link/hello", other),
        }
    }

    /// `status/get`.
    pub fn status(&mut self) -> Result<Status, ClientError> {
        match self.call(&Request::Status)? {
            Response::Status(s) => Ok(s),
            other => Self::unexpected("status/get", other),
        }
    }

    /// `motion/move`.
    pub fn move_to(
        &mut self,
        targets_rad: protocol::PerChannel<f32>,
        timing: Timing,
    ) -> Result<(), ClientError> {
        self.done(Request::Move {
            targets_rad,
            timing,
        })
    }

    /// `motion/home`.
    pub fn home(&mut self, timing: Timing) -> Result<(), ClientError> {
        self.done(Request::Home { timing })
    }

    /// Polls `status/get` until no motion runs; `poll` is the pause between polls.
    pub fn wait_until_still(
        &mut self,
        poll: Duration,
        limit: Duration,
    ) -> Result<Status, ClientError> {
        let start = Instant::now();
        loop {
            let s = self.status()?;
            if !s.moving {
                return Ok(s);
            }
            if start.elapsed() > limit {
                return Err(CommsError::Timeout {
                    path: "status/get",
                    attempts: 1,
                    timeout_ms: limit.as_millis(),
                }
                .into());
            }
            std::thread::sleep(poll);
        }
    }

    /// `servo/attach` (`None`: all channels).
    pub fn attach(&mut self, channel: Option<u8>) -> Result<(), ClientError> {
        self.done(Request::Attach { channel })
    }

    /// `servo/detach` (`None`: all channels).
    pub fn detach(&mut self, channel: Option<u8>) -> Result<(), ClientError> {
        self.done(Request::Detach { channel })
    }

    /// `servo/raw`: returns the pulse the board applied after clamping, µs.
    pub fn raw_pulse(&mut self, channel: u8, pulse_us: u16) -> Result<u16, ClientError> {
        match self.call(&Request::RawPulse { channel, pulse_us })? {
            Response::Pulse { applied_us } => Ok(applied_us),
            other => Self::unexpected("servo/raw", other),
        }
    }

    /// `comp/payload`.
    pub fn set_payload(&mut self, mass_kg: f32) -> Result<(), ClientError> {
        self.done(Request::SetPayload { mass_kg })
    }

    /// `comp/mode`.
    pub fn set_compensation(&mut self, mode: CompensationMode) -> Result<(), ClientError> {
        self.done(Request::SetCompensation { mode })
    }

    /// `calib/erase`.
    pub fn erase_calibration(&mut self) -> Result<(), ClientError> {
        self.done(Request::CalibrationErase)
    }

    /// `sys/bootloader`.
    pub fn reboot_to_bootloader(&mut self) -> Result<(), ClientError> {
        self.done(Request::RebootToBootloader)
    }

    /// Uploads, stores and applies `calibration` (`calib/begin`, `calib/chunk`…, `calib/commit`);
    /// `progress` hears the bytes sent so far. The board keeps its previous
    /// calibration unless the commit succeeds.
    pub fn push_calibration(
        &mut self,
        calibration: &Calibration,
        mut progress: impl FnMut(usize, usize),
    ) -> Result<CalibrationInfo, ClientError> {
        // The board checks too, but nothing it would refuse (a non-monotonic
        // servo curve above all) ever leaves the host.
        calibration.check().map_err(ClientError::Invalid)?;
        let mut buf = [0u8; MAX_CALIBRATION_LEN];
        let bytes = calibration
            .encode(&mut buf)
            .map_err(|e| CommsError::Unexpected {
                path: "calib/begin",
                got: format!("calibration does not encode: {e}"),
            })?;
        let begin = Request::CalibrationBegin {
            len_bytes: bytes.len() as u32,
            crc: frame::crc32(bytes),
        };
        self.call(&begin)?;
        for (k, chunk) in bytes.chunks(CHUNK_LEN).enumerate() {
            let offset = k * CHUNK_LEN;
            let data = heapless::Vec::from_slice(chunk).unwrap_or_default();
            match self.call(&Request::CalibrationChunk {
                offset: offset as u32,
                data,
            })? {
                Response::CalibrationAck { received }
                    if received as usize >= offset + chunk.len() => {}
                other => return Self::unexpected("calib/chunk", other),
            }
            progress(offset + chunk.len(), bytes.len());
        }
        match self.call(&Request::CalibrationCommit) {
            Ok(Response::CalibrationStored(info)) => Ok(info),
            Ok(other) => Self::unexpected("calib/commit", other),
            // The commit went through but its answer was lost and the retry found no upload:
            // the status tells whether ours is the one in use.
            Err(ClientError::Endpoint {
                error: WireError::NoTransfer,
                ..
            }) => match self.status()?.calibration {
                Some(info) if info.id == calibration.id => Ok(info),
                _ => Err(ClientError::Endpoint {
                    path: "calib/commit",
                    error: WireError::NoTransfer,
                }),
            },
            Err(e) => Err(e),
        }
    }

    /// Reads the stored calibration back (`calib/read` until complete) and checks its CRC.
    pub fn pull_calibration(&mut self) -> Result<Calibration, ClientError> {
        let mut bytes = Vec::new();
        loop {
            let request = Request::CalibrationRead {
                offset: bytes.len() as u32,
            };
            let Response::CalibrationData {
                len_bytes,
                crc,
                offset,
                data,
            } = self.call(&request)?
            else {
                return Err(CommsError::Unexpected {
                    path: "calib/read",
                    got: "not calibration data".into(),
                }
                .into());
            };
            if offset as usize != bytes.len()
                || (data.is_empty() && bytes.len() < len_bytes as usize)
            {
                return Err(
                    CommsError::BadCalibration("the board sent a chunk out of order").into(),
                );
            }
            bytes.extend_from_slice(&data);
            if bytes.len() >= len_bytes as usize {
                if frame::crc32(&bytes) != crc {
                    return Err(CommsError::BadCalibration("CRC mismatch").into());
                }
                return Calibration::decode(&bytes).ok_or(
                    CommsError::BadCalibration("the bytes are not a usable calibration").into(),
                );
            }
        }
    }
}
