//! The wire contract between `lrmcal` (host) and the arm's firmware (board).
//!
//! Both ends depend on this crate and on `model`; nothing else is shared.
//!
//! # Endpoints
//!
//! Every exchange is one request frame from the host and one response frame
//! from the board with the same sequence number. A new endpoint is one row
//! here, one [`Request`] variant and one handler in the firmware.
//!
//! | path | request | response | what it does |
//! |---|---|---|---|
//! | `link/hello` | [`Request::Hello`] | [`Response::Hello`] | versions at connect |
//! | `status/get` | [`Request::Status`] | [`Response::Status`] | versions, calibration, mode, targets, pulses, faults, uptime |
//! | `motion/move` | [`Request::Move`] | [`Response::Done`] | move to joint targets, one per joint (duration or speed) |
//! | `motion/home` | [`Request::Home`] | [`Response::Done`] | attach all joints and move to the home pose |
//! | `servo/attach` | [`Request::Attach`] | [`Response::Done`] | drive one joint's channel or all of them again |
//! | `servo/detach` | [`Request::Detach`] | [`Response::Done`] | make one or all channels limp |
//! | `servo/raw` | [`Request::RawPulse`] | [`Response::Pulse`] | a raw pulse on one joint's channel (servo tuning) |
//! | `comp/payload` | [`Request::SetPayload`] | [`Response::Done`] | payload mass at the tool |
//! | `comp/mode` | [`Request::SetCompensation`] | [`Response::Done`] | off / elastic only / full |
//! | `calib/begin` | [`Request::CalibrationBegin`] | [`Response::CalibrationAck`] | start a calibration upload |
//! | `calib/chunk` | [`Request::CalibrationChunk`] | [`Response::CalibrationAck`] | one chunk of it |
//! | `calib/commit` | [`Request::CalibrationCommit`] | [`Response::CalibrationStored`] | check, store and apply it |
//! | `calib/read` | [`Request::CalibrationRead`] | [`Response::CalibrationData`] | one chunk of the stored calibration |
//! | `calib/erase` | [`Request::CalibrationErase`] | [`Response::Done`] | forget the calibration (nominal curves) |
//! | `sys/bootloader` | [`Request::RebootToBootloader`] | [`Response::Done`] | reboot into the USB (UF2) bootloader |
//!
//! Any request may instead get [`Response::Error`] with a [`WireError`].
//! The frame format, buffer sizes and versioning rule are in [`frame`].
//!
//! # Joints and channels
//!
//! The board has [`CHANNELS`] servo channels and drives an arm of 1 to that
//! many joints, joint `i` on channel `i`: the calibration's arm, or one of
//! [`CHANNELS`] joints on the data-sheet curves without a calibration. Joint
//! vectors on the wire ([`PerChannel`]: move targets, home pose, status
//! angles) have one value per joint of that arm; a move with any other number
//! is refused ([`WireError::TargetCount`]). The channels past the arm's last
//! joint are always limp: no move, home or attach-all drives them, and
//! attaching one or putting a raw pulse on it is refused
//! ([`WireError::UnusedChannel`]); detaching one is allowed (it is limp
//! already; like any detach, it stops a running motion).
#![cfg_attr(not(feature = "use-std"), no_std)]

pub mod calibration;
pub mod error;
pub mod frame;
pub mod messages;

pub use calibration::{Calibration, CalibrationFault, ModelOption};
pub use error::WireError;
pub use frame::{FrameError, FrameReader, PROTOCOL_VERSION};
pub use messages::{
    CalibrationInfo, CompensationMode, CompensationReport, DeviceInfo, Faults, FirmwareVersion,
    Request, Response, Status, Timing,
};

/// Bytes of calibration data carried by one chunk frame.
pub const CHUNK_LEN: usize = 128;

/// Servo channels of the board: it drives arms of 1 to this many joints,
/// joint `i` on channel `i`; the channels past an arm's last joint stay limp.
pub const CHANNELS: usize = 6;

/// One value per joint of an arm the board drives, on the wire: as many as
/// the arm has joints, at most [`CHANNELS`].
pub type PerChannel<T> = model::ChainVec<T, CHANNELS>;
