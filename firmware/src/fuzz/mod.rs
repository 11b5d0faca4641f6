//! Fuzzing the whole [`Device`] on the host (feature `fuzz`): generated
//! cases, a runner that checks the invariants after every step, and a
//! shrinker for the case that broke one.
//!
//! A [`Case`] is a list of [`Step`]s: request frames, raw bytes on the serial
//! line (random or mutated frames), servo frames, power cuts and reboots.
//! [`run`] plays it against a [`Device`] over the recording servo bus and
//! the simulated flash of [`crate::sim`], feeding every byte through a
//! [`FrameReader`] as the binary does, and checks each
//! [`check::Invariant`]: no panic (the caller catches it), pulses inside the
//! safe range and driven joints inside their limits, no reply to a corrupt
//! frame and one matching reply to an intact one, no calibration ever
//! partially applied, the board booting with the previous or the new
//! calibration after a power cut, the servo frame setting every channel
//! every frame, and no pulse on a channel past the arm's last joint (the
//! uploads include arms of five joints and of one). Each case ends with a status and a reboot, so every case
//! checks the boot too.
//!
//! The generators draw from a [`Source`] of random words: a seeded RNG in
//! the campaign (`examples/fuzz_campaign.rs`), libFuzzer's input in
//! `fuzz/`; the same source gives the same case.

pub mod check;
mod generate;

use core::fmt;

use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::{self, Feed, FrameError, FrameReader, MAX_FRAME, PROTOCOL_VERSION};
use protocol::{CHUNK_LEN, Calibration, ModelOption, Request, Response, WireError};

pub use check::{Fault, Invariant};
use check::{Known, Model};
pub use generate::{FRAMES_PER_CASE, frames_case, sequence_case};

use crate::sim::{MockBus, SimFlash, test_calibration, test_calibration_of};
use crate::storage::Storage;
use crate::{CHANNELS, Config, Device, SystemAction};

/// Time between servo frames, µs.
const FRAME_US: u64 = 20_000;

/// Random words for the generators.
pub trait Source {
    /// The next word.
    fn word(&mut self) -> u64;

    /// A number in `0..n` (0 for `n == 0`).
    fn below(&mut self, n: u64) -> u64 {
        self.word().checked_rem(n).unwrap_or(0)
    }

    /// True once in `n` draws on average.
    fn one_in(&mut self, n: u64) -> bool {
        self.below(n) == 0
    }
}

/// Any closure that gives words is a source, e.g. `|| rng.next_u64()`.
impl<F: FnMut() -> u64> Source for F {
    fn word(&mut self) -> u64 {
        self()
    }
}

/// One thing that happens to the board.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// A well-formed request frame, after a 0x00 that ends any partial frame
    /// (as a host resynchronising would send).
    Request(Request),
    /// Bytes on the serial line: a random or mutated frame, with or without its 0x00.
    Bytes(Vec<u8>),
    /// This many servo frames, 20 ms apart.
    Frames(u32),
    /// The flash loses power after this many more byte operations, and
    /// stays without until the next reboot.
    CutPower(u32),
    /// Power off and on: a new device over the same flash.
    Reboot,
}

/// A case: the calibration in flash at power-on (an index into
/// [`Fixtures::uploads`]) and the steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// The upload stored in flash before the first boot, if any.
    pub preload: Option<usize>,
    /// What happens, in order.
    pub steps: Vec<Step>,
}

/// A calibration the generators upload.
#[derive(Clone, Debug)]
pub struct Upload {
    /// Its encoded bytes.
    pub bytes: Vec<u8>,
    /// Whether the board must accept it.
    pub valid: bool,
}

/// What every case shares: the calibrations to upload, and flashes holding them.
#[derive(Clone, Debug)]
pub struct Fixtures {
    /// Five valid calibrations (plain, with tight limits and our model
    /// option, with curves that ask for pulses outside the safe range and the
    /// kinematic option, an arm of five joints, an arm of one) and three the
    /// board must refuse (a curve with a NaN, an arm of seven joints, arms of
    /// five and six joints in one calibration).
    pub uploads: Vec<Upload>,
    /// A flash holding each valid upload (by index), written by the storage itself.
    flashes: Vec<Option<SimFlash>>,
}

impl Default for Fixtures {
    fn default() -> Self {
        Self::new()
    }
}

impl Fixtures {
    /// The standard set.
    pub fn new() -> Self {
        let plain = test_calibration(21);
        let mut tight = test_calibration(22);
        tight.option = ModelOption::ElastoKinematicServo;
        tight.calibrated.joints[0].limits = [-0.6, 0.5];
        tight.calibrated.joints[2].limits = [-1.2, 0.9];
        for j in &mut tight.calibrated.joints {
            for p in j.servo.iter_mut().flat_map(|c| c.pulses_us_mut()) {
                *p += 25.0;
            }
        }
        let mut wild = test_calibration(23);
        wild.option = ModelOption::Kinematic;
        for j in &mut wild.calibrated.joints {
            if let Some(curve) = &mut j.servo {
                let pulses = curve.pulses_us_mut();
                pulses[0] = 150.0;
                if let Some(last) = pulses.last_mut() {
                    *last = 3300.0;
                }
            }
        }
        let mut invalid = test_calibration(24);
        if let Some(last) = invalid.calibrated.joints[4]
            .servo
            .as_mut()
            .and_then(|c| c.pulses_us_mut().last_mut())
        {
            *last = f32::NAN;
        }
        let mut five = test_calibration_of(25, 5);
        five.calibrated.joints[1].limits = [-0.4, 1.2];
        let mut one = test_calibration_of(26, 1);
        one.option = ModelOption::ElastoKinematicServo;
        // Seven joints (the home pose and corrections cannot say seven values).
        let mut seven = test_calibration(27);
        for arm in [&mut seven.nominal, &mut seven.calibrated] {
            let last = arm.joints.last_value();
            arm.joints =
                model::PerJoint::from_fn(7, |i| arm.joints.get(i).copied().unwrap_or(last));
        }
        let mut mixed = test_calibration_of(28, 5);
        mixed.nominal = test_calibration(28).nominal;
        let uploads: Vec<Upload> = [plain, tight, wild, invalid, five, one, seven, mixed]
            .iter()
            .map(|c| {
                let mut buf = [0u8; MAX_CALIBRATION_LEN];
                let bytes = c.encode(&mut buf).map(<[u8]>::to_vec).unwrap_or_default();
                let valid = Calibration::decode(&bytes).is_some();
                Upload { bytes, valid }
            })
            .collect();
        let flashes = uploads
            .iter()
            .map(|u| {
                let mut flash = SimFlash::new();
                let mut storage = Storage::new(&mut flash);
                storage.load();
                let stored = u.valid && storage.store(&u.bytes).is_ok();
                stored.then_some(flash)
            })
            .collect();
        Self { uploads, flashes }
    }

    /// The indices of the uploads the board must accept.
    pub fn valid(&self) -> Vec<usize> {
        (0..self.uploads.len())
            .filter(|&i| self.uploads[i].valid)
            .collect()
    }

    /// Upload `index` as the model knows it, if the board must accept it.
    fn known(&self, index: usize) -> Option<Known> {
        let bytes = self.uploads.get(index)?.bytes.clone();
        let calibration = Calibration::decode(&bytes)?;
        Some(Known { bytes, calibration })
    }

    /// The flash a case starts from.
    fn flash(&self, preload: Option<usize>) -> SimFlash {
        preload
            .and_then(|i| self.flashes.get(i).cloned().flatten())
            .unwrap_or_default()
    }
}

/// What the runs did, summed over cases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// [`Step::Bytes`] steps: random or mutated frames put on the line.
    pub frames_sent: u64,
    /// Frames the reader cut from the line, requests included.
    pub frames_read: u64,
    /// Of them, intact by the reference reading.
    pub intact: u64,
    /// Frames the reader dropped as over-long.
    pub overflows: u64,
    /// [`Step::Request`] steps and the runner's own status and read-back requests.
    pub requests: u64,
    /// Servo frames run.
    pub servo_frames: u64,
    /// Calibrations the board stored and applied.
    pub stored: u64,
    /// Power cuts armed.
    pub power_cuts: u64,
    /// Boots, the first of each case included.
    pub boots: u64,
}

impl core::ops::AddAssign for Counts {
    fn add_assign(&mut self, o: Self) {
        self.frames_sent += o.frames_sent;
        self.frames_read += o.frames_read;
        self.intact += o.intact;
        self.overflows += o.overflows;
        self.requests += o.requests;
        self.servo_frames += o.servo_frames;
        self.stored += o.stored;
        self.power_cuts += o.power_cuts;
        self.boots += o.boots;
    }
}

/// A broken invariant: at which step and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Violation {
    /// Index of the step that broke it: `steps.len()` for the checks that
    /// close every case, `None` where unknown (a panic caught outside [`run`]).
    pub step: Option<usize>,
    /// What broke.
    pub fault: Fault,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.step {
            Some(step) => write!(f, "step {step}: {}", self.fault),
            None => write!(f, "{}", self.fault),
        }
    }
}

/// Plays `case` and checks every invariant after every step; adds what it
/// did to `counts`. Panics of the firmware reach the caller.
pub fn run(fixtures: &Fixtures, case: &Case, counts: &mut Counts) -> Result<(), Violation> {
    let on_boot = vec![case.preload.and_then(|i| fixtures.known(i))];
    let mut rig = Rig::boot(fixtures.flash(case.preload), on_boot, counts);
    let violation = |step| {
        move |fault| Violation {
            step: Some(step),
            fault,
        }
    };
    rig.settle().map_err(violation(0))?;
    for (i, step) in case.steps.iter().enumerate() {
        rig.step(step).map_err(violation(i))?;
    }
    let end = case.steps.len();
    rig.request(&Request::Status).map_err(violation(end))?;
    rig.reboot().map_err(violation(end))
}

/// The device under test and everything the checks need.
struct Rig<'c> {
    device: Device<MockBus, SimFlash>,
    reader: FrameReader<MAX_FRAME>,
    model: Model,
    now_us: u64,
    seq: u16,
    /// Bus log entries already checked.
    checked: usize,
    counts: &'c mut Counts,
}

impl<'c> Rig<'c> {
    fn boot(flash: SimFlash, on_boot: Vec<Option<Known>>, counts: &'c mut Counts) -> Self {
        counts.boots += 1;
        let now_us = 1_000;
        Self {
            device: Device::new(MockBus::default(), flash, Config::default(), now_us),
            reader: FrameReader::new(),
            model: Model::new(on_boot),
            now_us,
            seq: 0,
            checked: 0,
            counts,
        }
    }

    /// The bus calls since the last look.
    fn new_pulses(&mut self) -> Vec<(usize, Option<u16>)> {
        let log = &self.device.bus().log;
        let fresh = log[self.checked..].to_vec();
        self.checked = log.len();
        fresh
    }

    /// Right after a boot: every channel limp, then the calibration settled
    /// by a status and read back whole.
    fn settle(&mut self) -> Result<(), Fault> {
        let boot = self.new_pulses();
        if boot != (0..CHANNELS).map(|c| (c, None)).collect::<Vec<_>>() {
            return Err(Fault::new(
                Invariant::ServoFrame,
                format!("the board started with {boot:?}, not every channel limp"),
            ));
        }
        self.request(&Request::Status)?;
        self.read_back()
    }

    /// Reads the calibration in use back to the last byte (the model checks each chunk).
    fn read_back(&mut self) -> Result<(), Fault> {
        let len = self.model.active_len().unwrap_or(0);
        for offset in (0..len.max(1)).step_by(CHUNK_LEN) {
            self.request(&Request::CalibrationRead {
                offset: offset as u32,
            })?;
        }
        Ok(())
    }

    fn reboot(&mut self) -> Result<(), Fault> {
        let on_boot = self.model.on_boot().to_vec();
        // A blank board stands in for the moment the flash is out of the old one.
        let device = core::mem::replace(
            &mut self.device,
            Device::new(MockBus::default(), SimFlash::new(), Config::default(), 0),
        );
        let (_, mut flash) = device.release();
        flash.power_on();
        self.now_us += 1_000_000;
        self.counts.boots += 1;
        self.device = Device::new(MockBus::default(), flash, Config::default(), self.now_us);
        self.reader = FrameReader::new();
        self.model = Model::new(on_boot);
        self.checked = 0;
        self.settle()
    }

    fn step(&mut self, step: &Step) -> Result<(), Fault> {
        match step {
            Step::Request(request) => self.request(request),
            Step::Bytes(bytes) => {
                self.counts.frames_sent += 1;
                self.feed(bytes)
            }
            Step::Frames(n) => {
                for _ in 0..*n {
                    self.now_us += FRAME_US;
                    self.device.servo_frame(self.now_us);
                    self.counts.servo_frames += 1;
                    let pulses = self.new_pulses();
                    self.model.check_servo_frame(&pulses)?;
                }
                Ok(())
            }
            Step::CutPower(n) => {
                self.counts.power_cuts += 1;
                self.device.flash_mut().cut_after(*n as usize);
                self.model.cut_armed = true;
                Ok(())
            }
            Step::Reboot => self.reboot(),
        }
    }

    /// Sends `request` in a frame of its own.
    fn request(&mut self, request: &Request) -> Result<(), Fault> {
        self.counts.requests += 1;
        self.seq = self.seq.wrapping_add(1);
        let mut buf = [0u8; MAX_FRAME + 1];
        let n = frame::encode(self.seq, request, &mut buf[1..]).map_err(|e| {
            Fault::new(
                Invariant::Reply,
                format!("{request:?} does not fit a frame: {e}"),
            )
        })?;
        self.feed(&buf[..=n])
    }

    /// Puts bytes on the line; checks every frame the reader cuts from them.
    fn feed(&mut self, bytes: &[u8]) -> Result<(), Fault> {
        for &byte in bytes {
            let frame = match self.reader.feed(byte) {
                Feed::Pending => continue,
                Feed::Overflow => {
                    self.counts.overflows += 1;
                    self.device.frame_overflowed();
                    continue;
                }
                Feed::Frame(frame) => frame.to_vec(),
            };
            self.frame(&frame)?;
        }
        Ok(())
    }

    /// One frame: the reply it must (or must not) get, the pulses it may set.
    fn frame(&mut self, frame: &[u8]) -> Result<(), Fault> {
        self.counts.frames_read += 1;
        let mut out = [0u8; MAX_FRAME];
        let len = self.device.handle_frame(frame, &mut out);
        let pulses = self.new_pulses();
        let Some(seq) = check::intact(frame) else {
            if len > 0 || !pulses.is_empty() {
                return Err(Fault::new(
                    Invariant::ReplyToCorrupt,
                    format!(
                        "corrupt frame {frame:02x?} got {len} reply bytes and pulses {pulses:?}"
                    ),
                ));
            }
            return Ok(());
        };
        self.counts.intact += 1;
        let reply = match frame::decode::<Response>(&out[..len]) {
            Ok((s, reply)) if s == seq && len > 0 => reply,
            other => {
                return Err(Fault::new(
                    Invariant::Reply,
                    format!("intact frame {frame:02x?} (seq {seq}) got {other:?}"),
                ));
            }
        };
        let request = match frame::decode::<Request>(frame) {
            Ok((_, request)) => request,
            Err(e) => {
                let expected = match e {
                    FrameError::Version { theirs, .. } if theirs != PROTOCOL_VERSION => {
                        WireError::VersionMismatch
                    }
                    _ => WireError::UnknownRequest,
                };
                return if reply == Response::Error(expected) && pulses.is_empty() {
                    Ok(())
                } else {
                    Err(Fault::new(
                        Invariant::Reply,
                        format!("undecodable frame ({e}) answered {reply:?}"),
                    ))
                };
            }
        };
        self.model.on_reply(&request, &reply)?;
        if matches!(reply, Response::CalibrationStored(_)) {
            self.counts.stored += 1;
        }
        self.model.check_request_pulses(&pulses)?;
        let action = self.device.take_action();
        let asked = request == Request::RebootToBootloader && reply == Response::Done;
        if action != asked.then_some(SystemAction::RebootToBootloader) {
            return Err(Fault::new(
                Invariant::Reply,
                format!("{request:?} answered {reply:?} left the action {action:?}"),
            ));
        }
        if action.is_some() {
            return self.reboot();
        }
        if self.model.unsure() {
            return self.request(&Request::Status);
        }
        Ok(())
    }
}

/// Shrinks a failing case: drops runs of steps, then single steps, and
/// halves servo-frame counts, for as long as `fails` still says it fails.
pub fn shrink(case: &Case, mut fails: impl FnMut(&Case) -> bool) -> Case {
    let mut best = case.clone();
    loop {
        let before = best.steps.len();
        let mut chunk = best.steps.len().div_ceil(2).max(1);
        while chunk >= 1 {
            let mut at = 0;
            while at < best.steps.len() {
                let mut trial = best.clone();
                trial.steps.drain(at..(at + chunk).min(trial.steps.len()));
                if fails(&trial) {
                    best = trial;
                } else {
                    at += chunk;
                }
            }
            chunk /= 2;
        }
        for i in 0..best.steps.len() {
            while let Step::Frames(n) = best.steps[i]
                && n > 1
            {
                let mut trial = best.clone();
                trial.steps[i] = Step::Frames(n / 2);
                if !fails(&trial) {
                    break;
                }
                best = trial;
            }
        }
        if best.preload.is_some() {
            let trial = Case {
                preload: None,
                ..best.clone()
            };
            if fails(&trial) {
                best = trial;
            }
        }
        if best.steps.len() == before {
            return best;
        }
    }
}

#[cfg(test)]
mod tests;
