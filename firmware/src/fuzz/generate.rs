//! The generators: requests with the values that matter (limits, NaN,
//! huge, the calibration uploads), random and mutated frames, and request
//! sequences with servo frames, power cuts and reboots between them.

use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::{self, CRC_LEN, HEADER_LEN, MAX_BODY, MAX_FRAME, crc32};
use protocol::{CHUNK_LEN, CompensationMode, PerChannel, Request, Timing};

use super::check::unstuff;
use super::{Case, Fixtures, Source, Step};
use crate::CHANNELS;

/// Frames per case of [`frames_case`]: the board lives through a few dozen
/// before the case ends with its status and reboot checks.
pub const FRAMES_PER_CASE: usize = 64;

/// Which upload a sequence is sending and how far it got, so that chunks
/// usually continue it.
#[derive(Default)]
struct Progress {
    upload: Option<usize>,
    next: usize,
}

/// A case of `frames` random and mutated frames (at most [`FRAMES_PER_CASE`]),
/// with servo frames and a few well-formed requests between them.
pub fn frames_case(src: &mut impl Source, fixtures: &Fixtures, frames: usize) -> Case {
    let mut progress = Progress::default();
    let mut steps = Vec::new();
    if src.one_in(2) {
        // Driven, compensating joints make the mutated requests matter.
        steps.push(Step::Request(Request::SetCompensation {
            mode: CompensationMode::Full,
        }));
        steps.push(Step::Request(Request::Home {
            timing: Timing::DurationMs(0),
        }));
    }
    for _ in 0..frames.min(FRAMES_PER_CASE) {
        steps.push(Step::Bytes(mutated_frame(src, fixtures, &mut progress)));
        if src.one_in(4) {
            steps.push(Step::Frames(1 + src.below(3) as u32));
        }
    }
    Case {
        preload: preload(src, fixtures),
        steps,
    }
}

/// A case of up to 24 actions: requests, whole uploads (some cut short,
/// damaged or interrupted by a power cut), power cuts and reboots, each
/// followed by a few servo frames or many.
pub fn sequence_case(src: &mut impl Source, fixtures: &Fixtures) -> Case {
    let mut progress = Progress::default();
    let mut steps = Vec::new();
    for _ in 0..1 + src.below(24) {
        match src.below(16) {
            0 | 1 => upload(src, fixtures, &mut steps),
            2 => steps.push(Step::CutPower(cut_point(src, fixtures))),
            3 if src.one_in(2) => steps.push(Step::Reboot),
            _ => steps.push(Step::Request(request(src, fixtures, &mut progress))),
        }
        let frames = match src.below(20) {
            0..=7 => 0,
            8..=15 => 1 + src.below(3),
            16..=18 => 4 + src.below(60),
            _ => 60 + src.below(140),
        };
        if frames > 0 {
            steps.push(Step::Frames(frames as u32));
        }
    }
    Case {
        preload: preload(src, fixtures),
        steps,
    }
}

/// The calibration in flash at power-on: none, or one of the valid uploads.
fn preload(src: &mut impl Source, fixtures: &Fixtures) -> Option<usize> {
    let valid = fixtures.valid();
    let pick = src.below(valid.len() as u64 + 1) as usize;
    valid.get(pick).copied()
}

/// Byte operations into a calibration commit where the power goes: any
/// point of the erase, the payload or the header.
fn cut_point(src: &mut impl Source, fixtures: &Fixtures) -> u32 {
    let longest = fixtures.uploads.iter().map(|u| u.bytes.len()).max();
    let commit = crate::sim::SLOT_SIZE + longest.unwrap_or(0) + 24;
    src.below(commit as u64 + 64) as u32
}

/// A whole upload, `calib/begin` to `calib/commit`, now and then with a
/// chunk left out, sent twice, damaged or out of place, or a power cut
/// before the commit.
fn upload(src: &mut impl Source, fixtures: &Fixtures, steps: &mut Vec<Step>) {
    let index = src.below(fixtures.uploads.len() as u64) as usize;
    let bytes = &fixtures.uploads[index].bytes;
    steps.push(Step::Request(Request::CalibrationBegin {
        len_bytes: bytes.len() as u32,
        crc: crc32(bytes),
    }));
    for (k, chunk) in bytes.chunks(CHUNK_LEN).enumerate() {
        let offset = (k * CHUNK_LEN) as u32;
        let mut data = heapless::Vec::from_slice(chunk).unwrap_or_default();
        match src.below(48) {
            0 => continue,
            1 => steps.push(Step::Request(Request::CalibrationChunk {
                offset,
                data: data.clone(),
            })),
            2 => {
                if let Some(byte) = data.get_mut(src.below(chunk.len() as u64) as usize) {
                    *byte ^= 1 << src.below(8);
                }
            }
            3 => steps.push(Step::Frames(1 + src.below(5) as u32)),
            _ => {}
        }
        steps.push(Step::Request(Request::CalibrationChunk { offset, data }));
    }
    if src.one_in(4) {
        steps.push(Step::CutPower(cut_point(src, fixtures)));
    }
    steps.push(Step::Request(Request::CalibrationCommit));
}

/// A request of any kind, with values at and beyond the edges.
fn request(src: &mut impl Source, fixtures: &Fixtures, progress: &mut Progress) -> Request {
    match src.below(17) {
        0 => Request::Hello,
        1 | 2 => Request::Status,
        3 | 4 => Request::Move {
            targets_rad: PerChannel::from_fn(joints(src), |_| angle(src)),
            timing: timing(src),
        },
        5 => Request::Home {
            timing: timing(src),
        },
        6 => Request::Attach {
            channel: channel(src),
        },
        7 => Request::Detach {
            channel: channel(src),
        },
        8 => Request::RawPulse {
            channel: src.below(CHANNELS as u64 + 2) as u8,
            pulse_us: pick(src, &[0, 499, 500, 1500, 2500, 2501, u16::MAX])
                .unwrap_or(src.below(3000) as u16),
        },
        9 => Request::SetPayload {
            mass_kg: pick(src, &[0.0, 0.0663, 0.5, 0.5001, -0.1]).unwrap_or_else(|| number(src)),
        },
        10 => Request::SetCompensation {
            mode: [
                CompensationMode::Off,
                CompensationMode::ElasticOnly,
                CompensationMode::Full,
            ][src.below(3) as usize],
        },
        11 => begin(src, fixtures, progress),
        12 | 13 => chunk(src, fixtures, progress),
        14 => Request::CalibrationCommit,
        15 => Request::CalibrationRead {
            offset: src.below(MAX_CALIBRATION_LEN as u64 + 2) as u32,
        },
        _ if src.one_in(4) => Request::RebootToBootloader,
        _ => Request::CalibrationErase,
    }
}

/// `calib/begin` of a known upload (which the next chunks continue), or of a
/// length and CRC out of nowhere.
fn begin(src: &mut impl Source, fixtures: &Fixtures, progress: &mut Progress) -> Request {
    if src.one_in(4) {
        progress.upload = None;
        let len = pick(src, &[0, MAX_CALIBRATION_LEN as u32 + 1, u32::MAX])
            .unwrap_or(src.below(MAX_CALIBRATION_LEN as u64 + 1) as u32);
        return Request::CalibrationBegin {
            len_bytes: len,
            crc: src.word() as u32,
        };
    }
    let index = src.below(fixtures.uploads.len() as u64) as usize;
    let bytes = &fixtures.uploads[index].bytes;
    *progress = Progress {
        upload: Some(index),
        next: 0,
    };
    Request::CalibrationBegin {
        len_bytes: bytes.len() as u32,
        crc: crc32(bytes),
    }
}

/// `calib/chunk`: mostly the next chunk of the upload in progress, else a
/// chunk at a random place with random bytes.
fn chunk(src: &mut impl Source, fixtures: &Fixtures, progress: &mut Progress) -> Request {
    let upload = progress.upload.and_then(|i| fixtures.uploads.get(i));
    match upload {
        Some(u) if !src.one_in(6) => {
            let offset = progress.next.min(u.bytes.len());
            let end = (offset + CHUNK_LEN).min(u.bytes.len());
            progress.next = end;
            Request::CalibrationChunk {
                offset: offset as u32,
                data: heapless::Vec::from_slice(&u.bytes[offset..end]).unwrap_or_default(),
            }
        }
        _ => {
            let len = src.below(CHUNK_LEN as u64 + 1) as usize;
            let data = (0..len).map(|_| src.word() as u8).collect();
            Request::CalibrationChunk {
                offset: pick(src, &[u32::MAX - 3, MAX_CALIBRATION_LEN as u32])
                    .unwrap_or(src.below(MAX_CALIBRATION_LEN as u64) as u32),
                data,
            }
        }
    }
}

/// How many targets a move gives: mostly one per joint of an arm the
/// uploads have (six, five or one), now and then any number the wire allows.
fn joints(src: &mut impl Source) -> usize {
    match src.below(8) {
        0 | 1 => 5,
        2 => 1,
        3 => src.below(CHANNELS as u64 + 1) as usize,
        _ => CHANNELS,
    }
}

/// A joint angle: mostly inside every limit in use, sometimes at or beyond one.
fn angle(src: &mut impl Source) -> f32 {
    if src.one_in(8) {
        number(src)
    } else {
        uniform(src, -1.5, 1.5)
    }
}

/// A number from everywhere: the edges, the specials, any bit pattern, plain values.
fn number(src: &mut impl Source) -> f32 {
    const EDGES: [f32; 10] = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        f32::MIN_POSITIVE,
        -0.0,
        1.7,
        -1.7453293,
        2.618,
        1e9,
    ];
    match src.below(4) {
        0 => EDGES[src.below(EDGES.len() as u64) as usize],
        1 => f32::from_bits(src.word() as u32),
        _ => uniform(src, -2.0, 2.0),
    }
}

/// A duration or a speed, both with their edges.
fn timing(src: &mut impl Source) -> Timing {
    if src.one_in(3) {
        Timing::SpeedRadPerS(if src.one_in(3) {
            number(src)
        } else {
            uniform(src, 0.05, 3.0)
        })
    } else {
        Timing::DurationMs(
            pick(src, &[0, 1, 20, 600_000, 600_001, u32::MAX]).unwrap_or(src.below(2500) as u32),
        )
    }
}

/// A channel: one that exists, all (`None`), or one that does not.
fn channel(src: &mut impl Source) -> Option<u8> {
    match src.below(8) {
        0 => None,
        1 => Some(pick(src, &[CHANNELS as u8, 7, u8::MAX]).unwrap_or(CHANNELS as u8)),
        _ => Some(src.below(CHANNELS as u64) as u8),
    }
}

/// One of `edges` a third of the time, else `None` (the caller draws a plain value).
fn pick<T: Copy>(src: &mut impl Source, edges: &[T]) -> Option<T> {
    if src.one_in(3) {
        edges.get(src.below(edges.len() as u64) as usize).copied()
    } else {
        None
    }
}

/// A number in `lo..hi`.
fn uniform(src: &mut impl Source, lo: f32, hi: f32) -> f32 {
    let unit = (src.word() >> 40) as f32 / (1u64 << 24) as f32;
    lo + (hi - lo) * unit
}

/// Bytes for the line: a random frame, or a well-formed request frame
/// mutated on the line (bit flips, truncation, a splice with another) or
/// inside (bytes edited, inserted or dropped, the CRC broken or made to fit
/// the edit, another version).
fn mutated_frame(src: &mut impl Source, fixtures: &Fixtures, progress: &mut Progress) -> Vec<u8> {
    let base = request(src, fixtures, progress);
    let mut encoded = encode(src, &base);
    let len = encoded.len() as u64;
    match src.below(10) {
        0 => {
            // Random bytes; now and then a run without 0x00 longer than any frame.
            let long = src.one_in(8);
            let n = if long {
                MAX_FRAME as u64 + src.below(2 * MAX_FRAME as u64)
            } else {
                src.below(80)
            };
            let mut bytes: Vec<u8> = (0..n)
                .map(|_| {
                    let byte = src.word() as u8;
                    if long { byte.max(1) } else { byte }
                })
                .collect();
            bytes.push(0);
            bytes
        }
        1 => encoded,
        2 => {
            for _ in 0..1 + src.below(3) {
                let at = src.below(len) as usize;
                encoded[at] ^= 1 << src.below(8);
            }
            encoded
        }
        3 => {
            // Cut short; without its 0x00 half of the time, so it runs into the next frame.
            encoded.truncate(src.below(len) as usize);
            if src.one_in(2) {
                encoded.push(0);
            }
            encoded
        }
        4 => {
            let other = request(src, fixtures, progress);
            let other = encode(src, &other);
            let head = src.below(len) as usize;
            let tail = src.below(other.len() as u64) as usize;
            encoded.truncate(head);
            encoded.extend_from_slice(&other[tail..]);
            encoded
        }
        _ => match unstuff(&encoded[..encoded.len() - 1]) {
            Some(mut raw) if raw.len() >= HEADER_LEN + CRC_LEN => {
                edit_raw(src, &mut raw);
                stuff(&raw)
            }
            // Not reached: `encode` gives a well-formed frame.
            _ => encoded,
        },
    }
}

/// Edits a raw frame (version, seq, body, CRC) inside: a body byte changed,
/// inserted or dropped (which shifts the postcard lengths and tags), the
/// version changed, the CRC broken; the CRC is then made to fit the edit
/// three times in four, so the edit reaches the body decoder.
fn edit_raw(src: &mut impl Source, raw: &mut Vec<u8>) {
    let body = HEADER_LEN..raw.len() - CRC_LEN;
    let at = (body.start + src.below(body.len() as u64 + 1) as usize).min(body.end);
    match src.below(6) {
        0 => raw.insert(at, src.word() as u8),
        1 if at < body.end => {
            raw.remove(at);
        }
        2 => raw[0] = raw[0].wrapping_add(1 + src.below(255) as u8),
        3 => {
            // A body of random bytes up to past the longest.
            let n = src.below(MAX_BODY as u64 + 8) as usize;
            raw.splice(body, (0..n).map(|_| src.word() as u8));
        }
        _ => {
            if let Some(byte) = raw.get_mut(at) {
                *byte ^= 1 << src.below(8);
            }
        }
    }
    let end = raw.len() - CRC_LEN;
    if src.one_in(4) {
        raw[end + src.below(CRC_LEN as u64) as usize] ^= 1 << src.below(8);
    } else {
        let crc = crc32(&raw[..end]);
        raw[end..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// A request's frame under a random sequence number, with its 0x00 (only
/// the 0x00 if it did not fit, which no request does).
fn encode(src: &mut impl Source, request: &Request) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    match frame::encode(src.word() as u16, request, &mut out) {
        Ok(n) => out[..n].to_vec(),
        Err(_) => vec![0],
    }
}

/// COBS-encodes a raw frame and ends it with 0x00.
fn stuff(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; cobs::max_encoding_length(raw.len()) + 1];
    let n = cobs::encode(raw, &mut out);
    out.truncate(n);
    out.push(0);
    out
}
