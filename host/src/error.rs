//! The one error type of `lrmcal`, and the exit code of each kind of failure.
//!
//! Messages are lowercase and read after "failed to …": `main_impl` prints
//! `error: failed to <error>: <cause>: <cause>`. Errors about the content of an
//! input file carry an [`InputError`] that names the line and the key or
//! column, and says what was expected. The lower floors return their own
//! errors; this one gathers them and gives each its exit code.

use std::path::PathBuf;

pub use lrmcal_core::error::{Field, InputError, Location, Problem, report};
use lrmcal_engine::{calib, device, ik, plan, sim, tracker};

/// Process exit codes, one per kind of failure (documented in `lrmcal --help`).
pub mod exit_codes {
    /// The command did what was asked.
    pub const SUCCESS: u8 = 0;
    /// The command line was wrong (clap's own code).
    pub const USAGE: u8 = 2;
    /// An input file exists but its content is invalid.
    pub const INVALID_INPUT: u8 = 3;
    /// A file could not be read or written.
    pub const FILE_ACCESS: u8 = 4;
    /// The model could not be evaluated (e.g. the elastic deflection did not converge).
    pub const MODEL: u8 = 5;
    /// The board could not be reached, or it refused a request (or the emulated board could
    /// not be started).
    pub const DEVICE: u8 = 6;
}

/// Everything that can make an `lrmcal` command fail.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Options that do not go together, found after clap's own checks.
    #[error("use lrmcal: {0}")]
    Usage(String),
    /// A file could not be read, written or used.
    #[error(transparent)]
    File(#[from] lrmcal_core::Error),
    /// A pose list gives one pose id several loads, but the output has one row per id.
    #[error(
        "predict pose {pose} of `{}`: it is listed with several loads and a prediction file holds one position per pose; pass --load-kg or split the list by load",
        path.display()
    )]
    AmbiguousLoad {
        /// The pose list.
        path: PathBuf,
        /// The pose id.
        pose: u32,
    },
    /// The simulator could not run (`lrmcal simulate`).
    #[error("simulate the arm")]
    Simulate {
        /// What the simulator said.
        #[source]
        source: sim::SimError,
    },
    /// The candidate poses could not be planned (`lrmcal plan`).
    #[error("plan candidate poses")]
    Plan {
        /// What the planner said.
        #[source]
        source: plan::PlanError,
    },
    /// The calibration engine refused its input or could not finish.
    #[error(transparent)]
    Calib(#[from] calib::CalibError),
    /// Talking to the board failed, or the board refused a request.
    #[error("talk to the board")]
    Device {
        /// The link's or the board's reason.
        #[source]
        source: device::ClientError,
    },
    /// A webcam read directly (`measure --webcam`) could not be opened or gave no frame.
    #[error("read the webcam {}: {reason}", device.display())]
    Webcam {
        /// The device file.
        device: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A device command got something it cannot send or use.
    #[error("{what}: {reason}")]
    DeviceInput {
        /// What was being prepared, e.g. "prepare the calibration of `cal.json` for the board".
        what: String,
        /// Why it cannot be used.
        reason: String,
    },
    /// No joint targets put the nominal arm's tool point on a Cartesian target.
    #[error(
        "find joint targets for the tool point ({:.1}, {:.1}, {:.1}) mm",
        target_mm[0],
        target_mm[1],
        target_mm[2]
    )]
    Ik {
        /// The target, world frame, mm.
        target_mm: [f64; 3],
        /// Why not: out of reach, beyond the limits or colliding (boxed:
        /// it carries a pose of up to ten joints).
        #[source]
        source: Box<ik::IkError>,
    },
    /// The positioning error at the tool could not be measured (`lrmcal demo`).
    #[error("measure the positioning error through the board")]
    Positioning(#[from] sim::positioning::PositioningError),
    /// `lrmcal report` was given a folder without a report.
    #[error(
        "build the page: `{}` not found; expected the report.json that `lrmcal identify` (or `lrmcal demo`) writes in its output folder",
        path.display()
    )]
    NoReport {
        /// The report file looked for.
        path: PathBuf,
    },
    /// A plot could not be drawn.
    #[error("draw {}: {message}", path.display())]
    Plot {
        /// The output file.
        path: PathBuf,
        /// What the plotting library said.
        message: String,
    },
    /// The emulated board could not be started, or stopped on its own (`lrmcal emulator`).
    #[error("run the emulated board: {reason}")]
    Emulator {
        /// What is missing or went wrong, and how to mend it.
        reason: String,
    },
    /// A file named as the emulated board's flash is not a flash image.
    #[error(
        "use `{}` as the board's flash: expected a {expected}-byte image of the flash chip, found {found} bytes",
        path.display()
    )]
    FlashImage {
        /// The file.
        path: PathBuf,
        /// The board's flash size, bytes.
        expected: u64,
        /// The file's size, bytes.
        found: u64,
    },
    /// A tracker could not be heard, or a recorded take could not be used.
    #[error(transparent)]
    Tracker(#[from] tracker::TrackerError),
    /// An image file could not be read or searched for tags (`lrmcal detect`).
    #[error("read the image `{}`: {reason}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What the image reader or the detector said.
        reason: String,
    },
    /// An image is not of the size the intrinsics are for (`lrmcal detect`).
    #[error(
        "use the image `{}`: it is {}x{} px, the intrinsics `{}` are for {}x{} px",
        path.display(), size.0, size.1, intrinsics.display(), expected.0, expected.1
    )]
    ImageSize {
        /// The image file.
        path: PathBuf,
        /// Its width and height, px.
        size: (u32, u32),
        /// The intrinsics file.
        intrinsics: PathBuf,
        /// Their width and height, px.
        expected: (u32, u32),
    },
    /// A camera measurement file's views cannot be measurements (`lrmcal identify --camera`).
    #[error("use the camera measurements `{}`: {source}", path.display())]
    Views {
        /// The camera measurement file.
        path: PathBuf,
        /// Which view, and why.
        source: lrmcal_engine::camera::corner_measurements::ViewError,
    },
    /// The AprilTag detector could not be made.
    #[error("start the AprilTag detector: {reason}")]
    Detect {
        /// What the library said.
        reason: String,
    },
    /// The model could not be evaluated for one pose.
    #[error("evaluate the model for pose {pose} with {load_kg} kg: {reason}")]
    Model {
        /// Pose id.
        pose: u32,
        /// Payload, kg.
        load_kg: f64,
        /// The model's own error (it is `no_std`, so not a `std::error::Error`).
        reason: model::DeflectionError,
    },
}

// The conversions from the modules' own errors live here, with the one error
// type: a module returns its own error and knows nothing of the CLI's.

impl From<device::ClientError> for Error {
    fn from(source: device::ClientError) -> Self {
        Self::Device { source }
    }
}

impl From<plan::PlanError> for Error {
    fn from(source: plan::PlanError) -> Self {
        Self::Plan { source }
    }
}

impl From<sim::SimError> for Error {
    /// The model's own failure keeps its exit code ([`Error::Model`]); the
    /// rest are simulator errors.
    fn from(error: sim::SimError) -> Self {
        match error {
            sim::SimError::Model {
                pose,
                load_kg,
                reason,
            } => Self::Model {
                pose,
                load_kg,
                reason,
            },
            source => Self::Simulate { source },
        }
    }
}

impl Error {
    /// The process exit code for this error (see [`exit_codes`]).
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Usage(_) => exit_codes::USAGE,
            Self::File(e) if e.is_access() => exit_codes::FILE_ACCESS,
            Self::File(_)
            | Self::AmbiguousLoad { .. }
            | Self::Simulate { .. }
            | Self::Plan { .. }
            | Self::Ik { .. }
            | Self::Positioning(_) => exit_codes::INVALID_INPUT,
            Self::Model { .. } => exit_codes::MODEL,
            Self::Device { .. } | Self::Emulator { .. } | Self::Webcam { .. } => exit_codes::DEVICE,
            Self::FlashImage { .. } | Self::NoReport { .. } => exit_codes::INVALID_INPUT,
            Self::DeviceInput { .. } => exit_codes::INVALID_INPUT,
            Self::Image { .. }
            | Self::ImageSize { .. }
            | Self::Detect { .. }
            | Self::Views { .. } => exit_codes::INVALID_INPUT,
            Self::Tracker(e) => match e {
                tracker::TrackerError::Take { .. } | tracker::TrackerError::Periods { .. } => {
                    exit_codes::INVALID_INPUT
                }
                _ => exit_codes::DEVICE,
            },
            Self::Plot { .. } => exit_codes::FILE_ACCESS,
            Self::Calib(e) => match e {
                calib::CalibError::Deflection { .. } | calib::CalibError::Refused { .. } => {
                    exit_codes::MODEL
                }
                _ => exit_codes::INVALID_INPUT,
            },
        }
    }

    /// The full message: `error: failed to <this>: <cause>: …` on one line.
    pub fn report(&self) -> String {
        report(self)
    }
}
