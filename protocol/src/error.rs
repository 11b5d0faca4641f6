//! Errors the board reports on the wire: small, flat and open for additions.

use serde::{Deserialize, Serialize};

/// Why the board refused a request.
///
/// Appending a variant is a wire change like any other (see
/// [`crate::frame`] for the versioning rule); the enum is
/// `#[non_exhaustive]` so the host's `match` survives it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum WireError {
    /// The frame's protocol version is not the board's.
    VersionMismatch,
    /// The frame checked out but its body is not a request this board knows.
    UnknownRequest,
    /// A number in the request is NaN or infinite.
    NotFinite,
    /// A value in the request is outside its allowed range (channel, angle, mass, duration).
    OutOfRange,
    /// A motion is still running; wait for it to finish or detach.
    Busy,
    /// The request needs a valid calibration and the board has none.
    NoCalibration,
    /// A calibration chunk or commit arrived without a `calib/begin`.
    NoTransfer,
    /// A chunk does not continue the upload (gap, overflow or past the announced length).
    BadChunk,
    /// The commit came before all announced bytes arrived.
    TransferIncomplete,
    /// The uploaded bytes do not match the announced CRC.
    CalibrationCrc,
    /// The calibration decoded but is not usable (NaN, inverted limits, non-monotonic curve…).
    CalibrationInvalid,
    /// Writing or erasing the flash failed; the previous calibration is still in use.
    Flash,
    /// `motion/move` carried a number of targets other than the arm's joints
    /// (the calibration's arm; six, one per channel, without a calibration).
    TargetCount,
    /// `servo/attach` or `servo/raw` named a channel past the arm's last
    /// joint: it has no joint to drive and stays limp.
    UnusedChannel,
}

impl WireError {
    /// A short sentence for people, lowercase so it reads after "the board said: ".
    pub fn message(self) -> &'static str {
        match self {
            Self::VersionMismatch => "protocol version mismatch",
            Self::UnknownRequest => "unknown request",
            Self::NotFinite => "a value is NaN or infinite",
            Self::OutOfRange => "a value is out of its allowed range",
            Self::Busy => "a motion is still running",
            Self::NoCalibration => "no valid calibration on the board",
            Self::NoTransfer => "no calibration upload in progress",
            Self::BadChunk => "calibration chunk out of order or too long",
            Self::TransferIncomplete => "calibration upload incomplete",
            Self::CalibrationCrc => "calibration CRC mismatch",
            Self::CalibrationInvalid => "calibration rejected by the board's checks",
            Self::Flash => "flash write failed, previous calibration kept",
            Self::TargetCount => "the move does not give one target per joint of the arm",
            Self::UnusedChannel => {
                "the channel is past the arm's last joint: it has no joint and stays limp"
            }
        }
    }
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

impl core::error::Error for WireError {}
