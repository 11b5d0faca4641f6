//! Framing: how a message becomes bytes on the serial line, and back.
//!
//! ```text
//!  raw frame (before COBS)                                     on the wire
//! +---------+-----------+-------------------------+----------+
//! | version | seq       | body: postcard message  | CRC-32   |  COBS(raw) 0x00
//! | u8      | u16 LE    | Request or Response     | u32 LE   |
//! +---------+-----------+-------------------------+----------+
//!   1 byte    2 bytes     0..=MAX_BODY bytes        4 bytes
//! ```
//!
//! - The host numbers its requests; the board's response carries the same
//!   `seq`, so a late reply to a retried request is recognised and dropped.
//! - The CRC (CRC-32/ISO-HDLC) covers version, seq and body. A frame that
//!   fails COBS or the CRC is dropped without reply (its seq cannot be
//!   trusted); the host times out and retries.
//! - The requests travel host → board and the responses board → host, so the
//!   body's type follows from the direction.
//! - Buffers: a body is at most [`MAX_BODY`] bytes, an encoded frame with
//!   its terminator at most [`MAX_FRAME`] bytes.
//!
//! # Versioning
//!
//! The first three bytes (version, seq) and the CRC trailer are frozen for
//! every version to come. Everything else (any message's layout, the order or
//! set of variants, [`crate::CHUNK_LEN`], the calibration payload) may only
//! change together with [`PROTOCOL_VERSION`]. A board that gets a frame of
//! another version answers [`crate::WireError::VersionMismatch`] under its
//! own version number; a host that sees a version not its own reads nothing
//! past the header and tells the user which side to update. So the two never
//! misread each other. The golden-byte tests in `tests/golden.rs` fail on any
//! drift of the encoding, which is the reminder to bump the version.
//!
//! | version | change |
//! |---|---|
//! | 1 | first release: servo curves of three points (-100°, 0°, +100°) |
//! | 2 | servo curves of 2 to 9 knots (angles and pulses) in the calibration payload, which may now take up to [`crate::calibration::MAX_CALIBRATION_LEN`] = 2048 bytes |
//! | 3 | each joint's backlash (full width of its play, rad) in both arms of the calibration payload |
//! | 4 | the model option `elasto-kinematic-servo` ([`crate::ModelOption::ElastoKinematicServo`], index 3, after the other three, whose indices stay) in the calibration payload and in `status`: the board stores the option a calibration was identified with, where lrmcal of protocol 3 sent ours as elasto-kinematic |
//! | 5 | each arm of the calibration payload carries its rated payload (the springs' bounds, `model::bounds`, are worked out from the nominal arm on both ends), the payload carries each joint's largest correction (from the calibration, no longer the board's fixed 20°), and `status`'s compensation iterations count from the start of the current move |
//! | 6 | arms of 1 to 6 joints: each arm of the calibration payload, its home pose and corrections, `motion/move`'s targets and `status`'s targets and nominal angles carry one value per joint of the arm, behind their count; `link/hello` says how many servo channels the board has, `status`'s calibration how many joints its arm has; two errors appended, [`crate::WireError::TargetCount`] (a move without one target per joint) and [`crate::WireError::UnusedChannel`] (attaching, or a raw pulse on, a channel past the arm's last joint) |
//! | 7 | each joint of the calibration payload's arms carries its servo curve as an option (`None`: a joint no servo of ours drives, which the board refuses with [`crate::calibration::CalibrationFault::NoServo`]) |

use serde::{Serialize, de::DeserializeOwned};

/// The protocol version this crate speaks.
pub const PROTOCOL_VERSION: u8 = 7;
/// Bytes before the body: version and sequence number.
pub const HEADER_LEN: usize = 3;
/// Bytes of the CRC trailer.
pub const CRC_LEN: usize = 4;
/// Largest message body, bytes.
pub const MAX_BODY: usize = 256;
/// Largest raw frame (header, body, CRC), bytes.
pub const MAX_RAW: usize = HEADER_LEN + MAX_BODY + CRC_LEN;
/// Largest encoded frame including its 0x00 terminator, bytes.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_RAW) + 1;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`: the checksum of frames and of calibration payloads.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC.checksum(bytes)
}

/// Why a frame could not be made or read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Not valid COBS.
    Cobs,
    /// Shorter than header plus CRC.
    TooShort,
    /// Longer than [`MAX_FRAME`], or the output buffer is too small.
    TooLong,
    /// The CRC does not match: corrupted on the way.
    Crc,
    /// The frame is intact but speaks another protocol version.
    Version {
        /// The version in the frame.
        theirs: u8,
        /// The frame's sequence number (trusted: the CRC passed).
        seq: u16,
    },
    /// The frame is intact but its body is not a message of the expected type.
    Body {
        /// The frame's sequence number.
        seq: u16,
    },
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Cobs => f.write_str("frame is not valid COBS"),
            Self::TooShort => f.write_str("frame shorter than its header and CRC"),
            Self::TooLong => f.write_str("frame longer than the protocol allows"),
            Self::Crc => f.write_str("frame CRC mismatch"),
            Self::Version { theirs, .. } => write!(
                f,
                "the other side speaks protocol version {theirs}, this one speaks {PROTOCOL_VERSION}"
            ),
            Self::Body { .. } => f.write_str("frame body is not a known message"),
        }
    }
}

impl core::error::Error for FrameError {}

/// Encodes `msg` as a complete frame (COBS, 0x00 terminator) into `out`; returns its length.
pub fn encode<M: Serialize>(seq: u16, msg: &M, out: &mut [u8]) -> Result<usize, FrameError> {
    encode_with_version(PROTOCOL_VERSION, seq, msg, out)
}

/// [`encode`] with an explicit version number: for replies that must say the
/// board's version, and for tests that play an older or newer peer.
pub fn encode_with_version<M: Serialize>(
    version: u8,
    seq: u16,
    msg: &M,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_RAW];
    raw[0] = version;
    raw[1..HEADER_LEN].copy_from_slice(&seq.to_le_bytes());
    let body_len = postcard::to_slice(msg, &mut raw[HEADER_LEN..HEADER_LEN + MAX_BODY])
        .map_err(|_| FrameError::TooLong)?
        .len();
    let crc_at = HEADER_LEN + body_len;
    let crc = crc32(&raw[..crc_at]);
    raw[crc_at..crc_at + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    let raw = &raw[..crc_at + CRC_LEN];
    let n = cobs::try_encode(raw, out).map_err(|_| FrameError::TooLong)?;
    let terminator = out.get_mut(n).ok_or(FrameError::TooLong)?;
    *terminator = 0;
    Ok(n + 1)
}

/// Decodes one frame (COBS bytes, with or without the 0x00 terminator) into
/// its sequence number and message, checking CRC and version.
pub fn decode<M: DeserializeOwned>(frame: &[u8]) -> Result<(u16, M), FrameError> {
    let mut raw = [0u8; MAX_RAW];
    let (version, seq, body) = decode_raw(frame, &mut raw)?;
    if version != PROTOCOL_VERSION {
        return Err(FrameError::Version {
            theirs: version,
            seq,
        });
    }
    // Trailing bytes after a complete message mean the sender meant something else.
    match postcard::take_from_bytes::<M>(body) {
        Ok((msg, [])) => Ok((seq, msg)),
        _ => Err(FrameError::Body { seq }),
    }
}

/// Undoes COBS and checks the CRC; returns version, seq and the body inside `raw`.
pub fn decode_raw<'a>(
    frame: &[u8],
    raw: &'a mut [u8; MAX_RAW],
) -> Result<(u8, u16, &'a [u8]), FrameError> {
    let frame = match frame.split_last() {
        Some((0, rest)) => rest,
        _ => frame,
    };
    if frame.len() >= MAX_FRAME {
        return Err(FrameError::TooLong);
    }
    if frame.is_empty() {
        return Err(FrameError::TooShort);
    }
    let report = cobs::decode(frame, raw).map_err(|_| FrameError::Cobs)?;
    // A 0x00 inside the frame would have ended it earlier: not one frame.
    if report.parsed_size() < frame.len() {
        return Err(FrameError::Cobs);
    }
    let raw = &raw[..report.frame_size()];
    if raw.len() < HEADER_LEN + CRC_LEN {
        return Err(FrameError::TooShort);
    }
    let (covered, trailer) = raw.split_at(raw.len() - CRC_LEN);
    let mut crc = [0u8; CRC_LEN];
    crc.copy_from_slice(trailer);
    if crc32(covered) != u32::from_le_bytes(crc) {
        return Err(FrameError::Crc);
    }
    let seq = u16::from_le_bytes([covered[1], covered[2]]);
    Ok((covered[0], seq, &covered[HEADER_LEN..]))
}

/// What one byte did to a [`FrameReader`].
#[derive(Debug, PartialEq, Eq)]
pub enum Feed<'a> {
    /// No complete frame yet.
    Pending,
    /// A complete frame (COBS bytes, without the terminator).
    Frame(&'a [u8]),
    /// A frame longer than the buffer ended here and was dropped.
    Overflow,
}

/// Gathers bytes from a stream until a 0x00 ends a frame.
///
/// Over-long frames are dropped whole (not cut), so a burst of garbage
/// costs one [`Feed::Overflow`] and the next frame reads normally.
#[derive(Debug)]
pub struct FrameReader<const N: usize = MAX_FRAME> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflowed: false,
        }
    }
}

impl<const N: usize> FrameReader<N> {
    /// An empty reader.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes one byte from the stream.
    pub fn feed(&mut self, byte: u8) -> Feed<'_> {
        if byte != 0 {
            if self.len < N {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return Feed::Pending;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflowed) {
            Feed::Overflow
        } else if len == 0 {
            // Back-to-back terminators: an empty frame, used to resynchronise.
            Feed::Pending
        } else {
            Feed::Frame(&self.buf[..len])
        }
    }
}
