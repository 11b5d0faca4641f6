//! The invariants: a reference reading of frames, and a model of what the
//! board must be doing, learnt from the replies alone.
//!
//! The model does not copy the firmware's logic. It knows the rules a host
//! can see: which channel a reply made limp, held or raw; the bytes of the
//! upload in progress, so which commit may store what; which calibrations
//! the flash may hold after a power cut. Every pulse, reply and boot is
//! checked against it.

use core::fmt;
use core::ops::Range;

use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::{CRC_LEN, HEADER_LEN, MAX_FRAME, MAX_RAW, crc32};
use protocol::{
    CHUNK_LEN, Calibration, CalibrationInfo, CompensationMode, Request, Response, Status, WireError,
};

use crate::{CHANNELS, Config, servo};

/// The invariant a [`Fault`] broke.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Invariant {
    /// A step panicked.
    Panic,
    /// A pulse outside the safe range reached a servo.
    PulseRange,
    /// A driven joint's pulse lies outside its limits (through the servo curve in force).
    JointLimits,
    /// A corrupt frame got a reply.
    ReplyToCorrupt,
    /// An intact frame got no reply, a reply under another sequence number,
    /// or a reply that does not answer its request.
    Reply,
    /// A calibration was applied, stored or reported that is not the whole
    /// of one complete, intact upload, or the one in use is not the one stored.
    Calibration,
    /// After a power cut the board booted with neither the previous nor the
    /// new calibration, a mixture, or none where one existed.
    Boot,
    /// A servo frame did not set every channel as the replies said
    /// (a pulse for a held or raw channel, none for a limp one).
    ServoFrame,
    /// A channel past the arm's last joint got a pulse, or `status` reported
    /// joint vectors or a joint count that are not the arm's.
    Joints,
}

impl fmt::Display for Invariant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Panic => "no panic",
            Self::PulseRange => "pulses inside the safe range",
            Self::JointLimits => "joints inside their limits",
            Self::ReplyToCorrupt => "no reply to a corrupt frame",
            Self::Reply => "one matching reply to every intact frame",
            Self::Calibration => "no calibration ever partially applied",
            Self::Boot => "a power cut boots the previous or the new calibration",
            Self::ServoFrame => "the servo frame keeps running",
            Self::Joints => "one value per joint, and the channels past the last joint limp",
        })
    }
}

/// A broken invariant and what broke it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fault {
    /// Which invariant.
    pub invariant: Invariant,
    /// What was seen.
    pub detail: String,
}

impl Fault {
    pub(crate) fn new(invariant: Invariant, detail: String) -> Self {
        Self { invariant, detail }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.invariant, self.detail)
    }
}

/// The sequence number of `frame` (COBS bytes as a reader cuts them, without
/// the 0x00) if it is intact: valid COBS, neither too short nor too long, CRC right.
///
/// Written from the frame format's rules, deliberately without the
/// decoder under test, so that a decoder accepting a corrupt frame (or
/// refusing an intact one) disagrees with it.
pub(crate) fn intact(frame: &[u8]) -> Option<u16> {
    // MAX_FRAME counts the terminator.
    if frame.len() >= MAX_FRAME {
        return None;
    }
    let raw = unstuff(frame)?;
    // Header and CRC, and a body of at most MAX_BODY bytes.
    if !(HEADER_LEN + CRC_LEN..=MAX_RAW).contains(&raw.len()) {
        return None;
    }
    let (covered, trailer) = raw.split_at(raw.len() - CRC_LEN);
    (crc32(covered).to_le_bytes() == trailer).then(|| u16::from_le_bytes([covered[1], covered[2]]))
}

/// COBS decoding by the book: a code byte `n` is followed by `n - 1` data
/// bytes and a 0x00, except after code 0xFF and after the last block.
pub(crate) fn unstuff(frame: &[u8]) -> Option<Vec<u8>> {
    let mut raw = Vec::with_capacity(frame.len());
    let mut at = 0;
    while at < frame.len() {
        let code = usize::from(frame[at]);
        let end = at + code;
        if code == 0 || end > frame.len() || frame[at + 1..end].contains(&0) {
            return None;
        }
        raw.extend_from_slice(&frame[at + 1..end]);
        at = end;
        if code < 0xFF && at < frame.len() {
            raw.push(0);
        }
    }
    Some(raw)
}

/// A whole calibration upload the model knows the bytes of.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Known {
    pub bytes: Vec<u8>,
    pub calibration: Calibration,
}

/// What a channel must be doing, as the replies said.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Expect {
    Limp,
    Held,
    Raw(u16),
}

/// The upload in progress, byte for byte.
#[derive(Clone, Debug)]
struct Upload {
    len: usize,
    crc: u32,
    received: usize,
    bytes: Vec<u8>,
}

/// The board as the host must see it.
#[derive(Clone, Debug)]
pub(crate) struct Model {
    pub channels: [Expect; CHANNELS],
    /// The calibration in use and what `status/get` says of it.
    active: Option<(Known, CalibrationInfo)>,
    /// When a failed erase left the board on whichever calibration survived,
    /// the ones it may be on; the next `status/get` settles it.
    unsure: Option<Vec<Option<Known>>>,
    /// The calibrations the flash may hold: the board must boot with one of them.
    on_boot: Vec<Option<Known>>,
    upload: Option<Upload>,
    /// Whether the board has just booted: the status that settles the
    /// calibration also settles what the flash holds.
    booting: bool,
    /// Whether the flash may have lost power since the last boot.
    pub cut_armed: bool,
    mode: CompensationMode,
    config: Config,
}

impl Model {
    /// A board just booted from a flash known to hold one of `on_boot`.
    pub fn new(on_boot: Vec<Option<Known>>) -> Self {
        Self {
            channels: [Expect::Limp; CHANNELS],
            active: None,
            unsure: Some(on_boot.clone()),
            on_boot,
            upload: None,
            booting: true,
            cut_armed: false,
            mode: CompensationMode::Off,
            config: Config::default(),
        }
    }

    /// The calibrations the flash may hold.
    pub fn on_boot(&self) -> &[Option<Known>] {
        &self.on_boot
    }

    /// Adds a calibration the flash may hold after a failed write.
    fn may_boot(&mut self, k: Option<Known>) {
        if !self.on_boot.contains(&k) {
            self.on_boot.push(k);
        }
    }

    /// Whether the next reply must be a status that settles the calibration in use.
    pub fn unsure(&self) -> bool {
        self.unsure.is_some()
    }

    /// The length of the calibration in use, to read it back; `None` without one.
    pub fn active_len(&self) -> Option<usize> {
        self.active.as_ref().map(|(k, _)| k.bytes.len())
    }

    /// The arm's joints, on channels `0..joints`: the calibration's, or one
    /// per channel without a calibration.
    pub fn joints(&self) -> usize {
        self.active
            .as_ref()
            .map_or(CHANNELS, |(k, _)| k.calibration.calibrated.joint_count())
    }

    /// After the calibration in use changed: the channels past the new arm's
    /// last joint are limp (the board makes them so as it applies one).
    fn fit_joints(&mut self) {
        let joints = self.joints();
        self.channels[joints.min(CHANNELS)..].fill(Expect::Limp);
    }

    /// A pulse on a channel past the arm's last joint is a fault, whatever the model expects.
    fn check_used(&self, channel: usize, pulse: Option<u16>) -> Result<(), Fault> {
        match pulse {
            Some(us) if channel >= self.joints() => Err(Fault::new(
                Invariant::Joints,
                format!(
                    "channel {channel}, past the last of the arm's {} joints, got {us} µs",
                    self.joints()
                ),
            )),
            _ => Ok(()),
        }
    }

    /// The pulses a driven channel may get, µs: the joint's limits through
    /// the curve in force, cut to the safe range, ±1 µs of rounding.
    fn held_range(&self, channel: usize) -> [f32; 2] {
        let arm = self.active.as_ref().map(|(k, _)| &k.calibration.calibrated);
        let c = &self.config;
        let [lo, hi] = servo::joint_limits(arm, c.hard_limits_rad, c.default_limits_rad)[channel];
        let curve = arm
            .and_then(|a| a.joints.get(channel))
            .and_then(|j| j.servo)
            .unwrap_or(c.uncalibrated_curve);
        let [a, b] = [curve.pulse_us(lo), curve.pulse_us(hi)];
        let [safe_lo, safe_hi] = c.pulse_range_us.map(f32::from);
        [
            a.min(b).clamp(safe_lo, safe_hi) - 1.0,
            a.max(b).clamp(safe_lo, safe_hi) + 1.0,
        ]
    }

    /// Checks one pulse a servo got, against the safe range and, on a driven channel, the joint's limits.
    fn check_pulse(&self, channel: usize, pulse_us: u16) -> Result<(), Fault> {
        self.check_safe(channel, pulse_us)?;
        if self.channels[channel] == Expect::Held {
            let [lo, hi] = self.held_range(channel);
            if !(lo..=hi).contains(&f32::from(pulse_us)) {
                return Err(Fault::new(
                    Invariant::JointLimits,
                    format!(
                        "driven channel {channel} got {pulse_us} µs, its limits give {lo:.1}..={hi:.1} µs"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Checks a pulse against the safe range alone.
    fn check_safe(&self, channel: usize, pulse_us: u16) -> Result<(), Fault> {
        let [lo, hi] = self.config.pulse_range_us;
        if (lo..=hi).contains(&pulse_us) {
            Ok(())
        } else {
            Err(Fault::new(
                Invariant::PulseRange,
                format!("channel {channel} got {pulse_us} µs, outside {lo}..={hi}"),
            ))
        }
    }

    /// Checks the six pulses of one servo frame: `log` holds what the bus got during it.
    pub fn check_servo_frame(&self, log: &[(usize, Option<u16>)]) -> Result<(), Fault> {
        let channels: Vec<usize> = log.iter().map(|&(c, _)| c).collect();
        if channels != (0..CHANNELS).collect::<Vec<_>>() {
            return Err(Fault::new(
                Invariant::ServoFrame,
                format!("a servo frame set channels {channels:?}, not each of the six once"),
            ));
        }
        for &(channel, pulse) in log {
            self.check_used(channel, pulse)?;
            match (self.channels[channel], pulse) {
                (Expect::Limp, None) => {}
                (Expect::Raw(raw), Some(us)) if raw == us => self.check_pulse(channel, us)?,
                (Expect::Held, Some(us)) => self.check_pulse(channel, us)?,
                (expect, got) => {
                    return Err(Fault::new(
                        Invariant::ServoFrame,
                        format!("channel {channel} should be {expect:?} but got {got:?}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Checks what the bus got while a request was handled: only the
    /// channels it made limp or raw, with exactly that.
    pub fn check_request_pulses(&self, log: &[(usize, Option<u16>)]) -> Result<(), Fault> {
        for &(channel, pulse) in log {
            self.check_used(channel, pulse)?;
            let expect = self.channels.get(channel).copied();
            match (expect, pulse) {
                (Some(Expect::Limp), None) => {}
                (Some(Expect::Raw(raw)), Some(us)) if raw == us => self.check_safe(channel, us)?,
                (_, got) => {
                    if let Some(us) = got {
                        self.check_safe(channel, us)?;
                    }
                    return Err(Fault::new(
                        Invariant::ServoFrame,
                        format!(
                            "a request put {got:?} on channel {channel}, which should be {expect:?}"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Checks `response` against `request` and learns from it.
    pub fn on_reply(&mut self, request: &Request, response: &Response) -> Result<(), Fault> {
        use Response as R;
        use WireError as E;
        if let (Request::Status, R::Status(status)) = (request, response) {
            return self.on_status(status);
        }
        if self.unsure.is_some() {
            return Err(Fault::new(
                Invariant::Reply,
                "the model lost track: a status must come first".into(),
            ));
        }
        let joints = self.joints();
        // One target per joint, or the move is refused (if the board is not busy first).
        let targets_fit = match request {
            Request::Move { targets_rad, .. } => targets_rad.len() == joints,
            _ => true,
        };
        let fits = match (request, response) {
            (Request::Hello, R::Hello(info)) => usize::from(info.channels) == CHANNELS,
            (Request::Move { .. } | Request::Home { .. }, R::Done) => {
                self.channels[..joints].fill(Expect::Held);
                targets_fit
            }
            (Request::Move { .. } | Request::Home { .. }, R::Error(E::Busy)) => true,
            (Request::Move { .. }, R::Error(E::TargetCount)) => !targets_fit,
            (
                Request::Move { .. } | Request::Home { .. },
                R::Error(E::NotFinite | E::OutOfRange),
            ) => targets_fit,
            (Request::Attach { channel }, _) => match (channels(*channel, joints), response) {
                (Ok(range), R::Done) => {
                    self.channels[range].fill(Expect::Held);
                    true
                }
                (Ok(_), R::Error(E::Busy)) => true,
                (Err(expected), R::Error(e)) => expected == *e,
                _ => false,
            },
            (Request::Detach { channel }, _) => match (channels(*channel, CHANNELS), response) {
                (Ok(range), R::Done) => {
                    self.channels[range].fill(Expect::Limp);
                    true
                }
                (Err(expected), R::Error(e)) => expected == *e,
                _ => false,
            },
            (Request::RawPulse { channel, pulse_us }, _) => {
                let named = channels(Some(*channel), joints);
                let [lo, hi] = self.config.pulse_range_us;
                match (named, response) {
                    (Ok(range), R::Pulse { applied_us })
                        if *applied_us == (*pulse_us).clamp(lo, hi) =>
                    {
                        self.channels[range].fill(Expect::Raw(*applied_us));
                        true
                    }
                    (Ok(_), R::Error(E::Busy)) => true,
                    (Err(expected), R::Error(e)) => expected == *e,
                    _ => false,
                }
            }
            (Request::SetPayload { .. }, R::Done | R::Error(E::NotFinite | E::OutOfRange)) => true,
            (Request::SetCompensation { mode }, _) => match response {
                R::Done if *mode == CompensationMode::Off || self.active.is_some() => {
                    self.mode = *mode;
                    true
                }
                R::Error(E::NoCalibration) => {
                    *mode != CompensationMode::Off && self.active.is_none()
                }
                R::Error(E::Busy) => true,
                _ => false,
            },
            (Request::CalibrationBegin { len_bytes, crc }, _) => {
                let len = *len_bytes as usize;
                let valid = len > 0 && len <= MAX_CALIBRATION_LEN;
                match response {
                    R::CalibrationAck { received: 0 } if valid => {
                        self.upload = Some(Upload {
                            len,
                            crc: *crc,
                            received: 0,
                            bytes: vec![0; len],
                        });
                        true
                    }
                    R::Error(E::OutOfRange) => !valid,
                    _ => false,
                }
            }
            (Request::CalibrationChunk { offset, data }, _) => {
                self.on_chunk(*offset, data, response)
            }
            (Request::CalibrationCommit, _) => return self.on_commit(response),
            (Request::CalibrationRead { offset }, _) => return self.on_read(*offset, response),
            (Request::CalibrationErase, R::Done) => {
                self.active = None;
                self.on_boot = vec![None];
                self.mode = CompensationMode::Off;
                self.fit_joints();
                true
            }
            (Request::CalibrationErase, R::Error(E::Busy)) => true,
            (Request::CalibrationErase, R::Error(E::Flash)) if self.cut_armed => {
                // The board runs on whatever survived; the flash may hold that or nothing.
                let mut may = self.on_boot.clone();
                may.push(self.active.as_ref().map(|(k, _)| k.clone()));
                may.push(None);
                self.unsure = Some(may);
                self.may_boot(None);
                true
            }
            (Request::RebootToBootloader, R::Done) => true,
            _ => false,
        };
        if fits {
            Ok(())
        } else {
            Err(Fault::new(
                Invariant::Reply,
                format!("{request:?} answered {response:?}"),
            ))
        }
    }

    /// `status/get`: the calibration in use is the model's, the pulses are the channels'.
    fn on_status(&mut self, status: &Status) -> Result<(), Fault> {
        let info = status.calibration;
        if let Some(may) = self.unsure.take() {
            let Some(found) = may.into_iter().find(|k| matches_info(k.as_ref(), info)) else {
                return Err(Fault::new(
                    Invariant::Boot,
                    format!(
                        "the board is on {info:?}, none of the calibrations the flash may hold"
                    ),
                ));
            };
            if found.is_none() {
                // A board without a calibration runs without compensation.
                self.mode = CompensationMode::Off;
            }
            if core::mem::take(&mut self.booting) {
                self.on_boot = vec![found.clone()];
            }
            self.active = found.zip(info);
            self.fit_joints();
        } else if self.active.as_ref().map(|(_, i)| *i) != info {
            return Err(Fault::new(
                Invariant::Calibration,
                format!(
                    "status says {info:?} is in use, the replies said {:?}",
                    self.active.as_ref().map(|(_, i)| i)
                ),
            ));
        }
        if status.mode != self.mode {
            return Err(Fault::new(
                Invariant::Reply,
                format!(
                    "status says compensation {:?}, the replies said {:?}",
                    status.mode, self.mode
                ),
            ));
        }
        let joints = self.joints();
        let counted = info.map_or(CHANNELS, |i| usize::from(i.joints));
        if status.targets_rad.len() != joints
            || status.nominal_rad.len() != joints
            || counted != joints
            || usize::from(status.device.channels) != CHANNELS
        {
            return Err(Fault::new(
                Invariant::Joints,
                format!(
                    "status of an arm of {joints} joints says {counted} joints, {} channels, \
                     {} targets and {} angles",
                    status.device.channels,
                    status.targets_rad.len(),
                    status.nominal_rad.len()
                ),
            ));
        }
        for (channel, (&expect, &us)) in self.channels.iter().zip(&status.pulses_us).enumerate() {
            let fits = match expect {
                Expect::Limp => us == 0,
                Expect::Raw(raw) => us == raw,
                // The last frame's pulse, maybe under the calibration just replaced:
                // the frames themselves are checked against the limits.
                Expect::Held => us == 0 || self.check_safe(channel, us).is_ok(),
            };
            if !fits {
                return Err(Fault::new(
                    Invariant::ServoFrame,
                    format!(
                        "status reports {us} µs on channel {channel}, which should be {expect:?}"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// `calib/chunk`: the model keeps the bytes, as the board must.
    fn on_chunk(&mut self, offset: u32, data: &[u8], response: &Response) -> bool {
        let Some(u) = &mut self.upload else {
            return *response == Response::Error(WireError::NoTransfer);
        };
        let offset = offset as usize;
        let end = offset + data.len();
        if offset > u.received || end > u.len {
            return *response == Response::Error(WireError::BadChunk);
        }
        u.bytes[offset..end].copy_from_slice(data);
        u.received = u.received.max(end);
        *response
            == Response::CalibrationAck {
                received: u.received as u32,
            }
    }

    /// `calib/commit`: only a whole, intact, valid upload may be stored and applied.
    fn on_commit(&mut self, response: &Response) -> Result<(), Fault> {
        use Response as R;
        use WireError as E;
        let wrong = |why: &str| {
            Err(Fault::new(
                Invariant::Calibration,
                format!("commit answered {response:?}, {why}"),
            ))
        };
        let Some(u) = &self.upload else {
            return match response {
                R::Error(E::NoTransfer) => Ok(()),
                _ => wrong("with no upload begun"),
            };
        };
        if u.received < u.len {
            return match response {
                R::Error(E::TransferIncomplete) => Ok(()),
                _ => wrong(&format!("with {} of {} bytes received", u.received, u.len)),
            };
        }
        if *response == R::Error(E::Busy) {
            // Refused mid-motion: the upload stays for a later commit.
            return Ok(());
        }
        let Some(u) = self.upload.take() else {
            return Ok(());
        };
        if crc32(&u.bytes) != u.crc {
            return match response {
                R::Error(E::CalibrationCrc) => Ok(()),
                _ => wrong("for bytes that fail the announced CRC"),
            };
        }
        let Some(calibration) = Calibration::decode(&u.bytes) else {
            return match response {
                R::Error(E::CalibrationInvalid) => Ok(()),
                _ => wrong("for bytes that are not a valid calibration"),
            };
        };
        let known = Known {
            bytes: u.bytes,
            calibration,
        };
        match response {
            R::CalibrationStored(info) if matches_info(Some(&known), Some(*info)) => {
                self.active = Some((known.clone(), *info));
                self.on_boot = vec![Some(known)];
                self.fit_joints();
                Ok(())
            }
            R::Error(E::Flash) if self.cut_armed => {
                // The calibration in use stays; the flash may hold the new one too.
                self.may_boot(Some(known));
                Ok(())
            }
            _ => wrong(&format!(
                "for a whole valid upload of id {}",
                calibration.id
            )),
        }
    }

    /// `calib/read`: the bytes in flash are those of the calibration in use.
    fn on_read(&self, offset: u32, response: &Response) -> Result<(), Fault> {
        let o = offset as usize;
        let fits = match (&self.active, response) {
            (
                Some((k, _)),
                Response::CalibrationData {
                    len_bytes,
                    crc,
                    offset: echoed,
                    data,
                },
            ) => {
                let end = (o + CHUNK_LEN).min(k.bytes.len());
                *len_bytes as usize == k.bytes.len()
                    && *crc == crc32(&k.bytes)
                    && *echoed == offset
                    && k.bytes.get(o..end) == Some(&data[..])
            }
            (Some((k, _)), Response::Error(WireError::OutOfRange)) => {
                o > k.bytes.len() || self.cut_armed
            }
            (None, Response::Error(WireError::NoCalibration)) => true,
            _ => false,
        };
        if fits {
            Ok(())
        } else {
            Err(Fault::new(
                Invariant::Calibration,
                format!(
                    "read at {offset} answered {response:?}; in use: {:?}",
                    self.active.as_ref().map(|(_, i)| i)
                ),
            ))
        }
    }
}

/// Whether calibration `k` (or none) is what `info` reports.
fn matches_info(k: Option<&Known>, info: Option<CalibrationInfo>) -> bool {
    match (k, info) {
        (None, None) => true,
        (Some(k), Some(i)) => {
            let c = &k.calibration;
            c.id == i.id
                && c.option == i.option
                && c.calibrated.joint_count() == usize::from(i.joints)
        }
        _ => false,
    }
}

/// The channels a request names among the first `count` (all of them for
/// `None`), or the error the board must give: a channel of the board past
/// `count` (the arm's last joint) is unused, one past the board's is out of range.
fn channels(channel: Option<u8>, count: usize) -> Result<Range<usize>, WireError> {
    match channel.map(usize::from) {
        None => Ok(0..count),
        Some(c) if c < count => Ok(c..c + 1),
        Some(c) if c < CHANNELS => Err(WireError::UnusedChannel),
        Some(_) => Err(WireError::OutOfRange),
    }
}
