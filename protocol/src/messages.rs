//! The messages: one [`Request`] variant per endpoint, the [`Response`]s, and
//! the plain structs they carry. Units are in the field names.

use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::calibration::ModelOption;
use crate::{CHANNELS, CHUNK_LEN, PerChannel, WireError};

/// How long a move takes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Timing {
    /// Take this long (the board stretches it if its speed or acceleration limits need more).
    DurationMs(u32),
    /// Move the joint that travels furthest at most this fast; the others slower, arriving together.
    SpeedRadPerS(f32),
}

/// What the board does to nominal joint targets before they reach the servos.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CompensationMode {
    /// Servo curves (and the play's offset, see `Joint::backlash`) only: the
    /// targets go to the servos as they are.
    Off,
    /// Cancel the elastic sag only: the calibrated deflected arm reaches the
    /// calibrated rigid arm's tool point.
    ElasticOnly,
    /// Cancel sag and geometric errors: the calibrated deflected arm reaches
    /// the nominal arm's tool point.
    Full,
}

/// Requests, host → board. The table in the crate docs gives each one's path.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// `link/hello`: first request after connecting; the answer has the board's versions.
    Hello,
    /// `status/get`.
    Status,
    /// `motion/move`: move every joint to a nominal target angle, rad.
    Move {
        /// Nominal joint targets, rad (within the joint limits), one per
        /// joint of the board's arm (the calibration's; six without one).
        targets_rad: PerChannel<f32>,
        /// Duration or speed.
        timing: Timing,
    },
    /// `motion/home`: attach every joint and move to the calibration's home pose (zeros without one).
    /// The channels past the arm's last joint stay limp.
    Home {
        /// Duration or speed.
        timing: Timing,
    },
    /// `servo/attach`: drive a channel again, holding its last position
    /// (`None`: every joint's channel). A channel past the arm's last joint
    /// stays limp: attaching it is refused with [`WireError::UnusedChannel`].
    Attach {
        /// A joint's channel, `0..joints`, or all.
        channel: Option<u8>,
    },
    /// `servo/detach`: stop the pulses of a channel so the servo goes limp (`None`: all).
    Detach {
        /// Channel `0..CHANNELS` (one past the arm's last joint is limp already), or all.
        channel: Option<u8>,
    },
    /// `servo/raw`: put a raw pulse on one channel, for level-1 servo tuning.
    /// The board clamps it to its safe range and says what it applied. A
    /// channel past the arm's last joint stays limp: refused with
    /// [`WireError::UnusedChannel`].
    RawPulse {
        /// A joint's channel, `0..joints`.
        channel: u8,
        /// Pulse width, µs.
        pulse_us: u16,
    },
    /// `comp/payload`: mass carried at the tool.
    SetPayload {
        /// Payload mass, kg.
        mass_kg: f32,
    },
    /// `comp/mode`.
    SetCompensation {
        /// The new mode.
        mode: CompensationMode,
    },
    /// `calib/begin`: announce an upload of `len_bytes` with CRC-32 `crc`.
    CalibrationBegin {
        /// Length of the postcard-encoded [`crate::Calibration`], bytes.
        len_bytes: u32,
        /// Its CRC-32 ([`crate::frame::crc32`]).
        crc: u32,
    },
    /// `calib/chunk`: bytes at `offset` of the announced upload. Re-sending a
    /// chunk (a retry) is harmless.
    CalibrationChunk {
        /// Offset in the upload, bytes; at most the number received so far.
        offset: u32,
        /// Up to [`CHUNK_LEN`] bytes.
        data: Vec<u8, CHUNK_LEN>,
    },
    /// `calib/commit`: check the whole upload, store it in flash and apply it.
    CalibrationCommit,
    /// `calib/read`: the stored calibration's bytes from `offset`.
    CalibrationRead {
        /// Offset, bytes.
        offset: u32,
    },
    /// `calib/erase`: forget the calibration; the board runs on nominal curves.
    CalibrationErase,
    /// `sys/bootloader`: reboot into the RP2040's USB mass-storage bootloader.
    RebootToBootloader,
}

impl Request {
    /// The endpoint's path, as in the table of the crate docs.
    pub fn path(&self) -> &'static str {
        match self {
            Self::Hello => "link/hello",
            Self::Status => "status/get",
            Self::Move { .. } => "motion/move",
            Self::Home { .. } => "motion/home",
            Self::Attach { .. } => "servo/attach",
            Self::Detach { .. } => "servo/detach",
            Self::RawPulse { .. } => "servo/raw",
            Self::SetPayload { .. } => "comp/payload",
            Self::SetCompensation { .. } => "comp/mode",
            Self::CalibrationBegin { .. } => "calib/begin",
            Self::CalibrationChunk { .. } => "calib/chunk",
            Self::CalibrationCommit => "calib/commit",
            Self::CalibrationRead { .. } => "calib/read",
            Self::CalibrationErase => "calib/erase",
            Self::RebootToBootloader => "sys/bootloader",
        }
    }
}

/// Responses, board → host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Response {
    /// The request was carried out.
    Done,
    /// Answer to `link/hello`.
    Hello(DeviceInfo),
    /// Answer to `status/get`.
    Status(Status),
    /// Answer to `servo/raw`: the pulse actually applied after clamping, µs.
    Pulse {
        /// Applied pulse, µs.
        applied_us: u16,
    },
    /// Answer to `calib/begin` and `calib/chunk`: bytes received so far.
    CalibrationAck {
        /// Contiguous bytes received from offset 0.
        received: u32,
    },
    /// Answer to `calib/commit`: stored and in use.
    CalibrationStored(CalibrationInfo),
    /// Answer to `calib/read`.
    CalibrationData {
        /// Length of the whole stored payload, bytes.
        len_bytes: u32,
        /// Its CRC-32.
        crc: u32,
        /// Offset of `data`, bytes.
        offset: u32,
        /// Up to [`CHUNK_LEN`] bytes (empty past the end).
        data: Vec<u8, CHUNK_LEN>,
    },
    /// The request was refused.
    Error(WireError),
}

/// Firmware version, semantic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FirmwareVersion {
    /// Major.
    pub major: u8,
    /// Minor.
    pub minor: u8,
    /// Patch.
    pub patch: u8,
}

impl core::fmt::Display for FirmwareVersion {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

/// Who the board is: the answer to `link/hello`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DeviceInfo {
    /// Protocol version the board speaks.
    pub protocol: u8,
    /// Firmware version.
    pub firmware: FirmwareVersion,
    /// Servo channels: the most joints an arm it drives may have.
    pub channels: u8,
}

/// The calibration in use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CalibrationInfo {
    /// The calibration's id (chosen by the host).
    pub id: u32,
    /// Which model option it was identified with.
    pub option: ModelOption,
    /// The arm's joints, on channels `0..joints`.
    pub joints: u8,
    /// Flash sequence number of the stored copy (grows with each write).
    pub sequence: u32,
}

/// How the last compensation solve went.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompensationReport {
    /// Whether the last servo frame's command reached the tolerance.
    pub converged: bool,
    /// Solver steps (one per servo frame) since the current move started (or
    /// since the solve last started afresh from the nominal targets, if later),
    /// at most 255.
    pub iterations: u8,
    /// The last command's remaining tool-point error, µm (evaluated, not predicted).
    pub error_um: f32,
    /// Servo frames since boot whose solve failed and fell back to the last good correction.
    pub fallbacks: u32,
}

/// Conditions the board wants the user to know about (a bit set).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Faults(pub u16);

impl Faults {
    /// No valid calibration: nominal servo curves and default limits in use.
    pub const NO_CALIBRATION: Faults = Faults(1 << 0);
    /// A flash slot held a damaged calibration at boot (the other one, if valid, is in use).
    pub const STORAGE_DAMAGED: Faults = Faults(1 << 1);
    /// The last servo frame's compensation step failed; a fallback was commanded.
    pub const COMPENSATION_FALLBACK: Faults = Faults(1 << 2);
    /// A joint command was clamped to a joint or pulse limit since the last status read.
    pub const LIMIT_CLAMPED: Faults = Faults(1 << 3);
    /// The last flash write or erase failed.
    pub const FLASH_FAILED: Faults = Faults(1 << 4);
    /// Frames were dropped (bad COBS, CRC or length) since the last status read.
    pub const FRAMES_DROPPED: Faults = Faults(1 << 5);

    /// Whether every bit of `other` is set.
    pub fn contains(self, other: Faults) -> bool {
        self.0 & other.0 == other.0
    }

    /// Sets or clears the bits of `other`.
    pub fn set(&mut self, other: Faults, on: bool) {
        if on {
            self.0 |= other.0;
        } else {
            self.0 &= !other.0;
        }
    }

    /// Every flag with its name, for printing.
    pub const NAMED: [(Faults, &'static str); 6] = [
        (Self::NO_CALIBRATION, "no calibration (nominal curves)"),
        (Self::STORAGE_DAMAGED, "a damaged flash slot was found"),
        (Self::COMPENSATION_FALLBACK, "compensation fell back"),
        (Self::LIMIT_CLAMPED, "a command was clamped to a limit"),
        (Self::FLASH_FAILED, "flash write failed"),
        (Self::FRAMES_DROPPED, "corrupt frames were dropped"),
    ];
}

/// Everything `lrmcal status` prints.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// Protocol and firmware versions.
    pub device: DeviceInfo,
    /// The calibration in use, or `None` (nominal curves on all [`CHANNELS`] channels).
    pub calibration: Option<CalibrationInfo>,
    /// Compensation mode.
    pub mode: CompensationMode,
    /// The last compensation solve.
    pub compensation: CompensationReport,
    /// Payload mass, kg.
    pub payload_kg: f32,
    /// Whether the servos are still moving: a motion runs, or a change of
    /// compensation (mode, payload, calibration) is still fading in.
    pub moving: bool,
    /// Nominal targets of the current (or last) move, rad, one per joint of the arm.
    pub targets_rad: PerChannel<f32>,
    /// Nominal joint angles of this servo frame, rad, one per joint of the arm.
    pub nominal_rad: PerChannel<f32>,
    /// Pulses on every channel now, µs; 0 for a limp channel (always, past the arm's last joint).
    pub pulses_us: [u16; CHANNELS],
    /// Fault flags.
    pub faults: Faults,
    /// Frames dropped since boot.
    pub frames_dropped: u32,
    /// Time since boot, ms.
    pub uptime_ms: u64,
}
