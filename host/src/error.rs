//! The one error type of `lrmcal`, and the exit code of each kind of failure.
//!
//! Messages are lowercase and read after "failed to …": `main_impl` prints
//! `error: failed to <error>: <cause>: <cause>`. Errors about the content of an
//! input file carry an [`InputError`] that names the line and the key or
//! column, and says what was expected.

use std::fmt;
use std::path::PathBuf;

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
    /// A file could not be read.
    #[error("read `{}`", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A file could not be written (nothing is left half-written).
    #[error("write `{}`", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// An input file was read but its content is invalid.
    #[error("parse `{}`", path.display())]
    Parse {
        /// The file (or `bundled:<name>` for a bundled one).
        path: PathBuf,
        /// Where in the file and what was expected.
        #[source]
        source: InputError,
    },
    /// `--arm` named neither a bundled arm nor a file of a known kind.
    #[error("load arm `{arm}`: {reason}")]
    ArmSource {
        /// What the user passed.
        arm: String,
        /// Why it could not be used.
        reason: String,
    },
    /// A calibration file was identified from another nominal arm than the one given.
    #[error("use calibration `{}`: {problem}", path.display())]
    ArmMismatch {
        /// The calibration file.
        path: PathBuf,
        /// The difference found, and what to do about it.
        problem: String,
    },
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
        source: crate::sim::SimError,
    },
    /// The candidate poses could not be planned (`lrmcal plan`).
    #[error("plan candidate poses")]
    Plan {
        /// What the planner said.
        #[source]
        source: crate::plan::PlanError,
    },
    /// The calibration engine refused its input or could not finish.
    #[error(transparent)]
    Calib(#[from] crate::calib::CalibError),
    /// Talking to the board failed, or the board refused a request.
    #[error("talk to the board")]
    Device {
        /// The link's or the board's reason.
        #[source]
        source: crate::device::ClientError,
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
        /// Why not: out of reach, beyond the limits or colliding.
        #[source]
        source: crate::ik::IkError,
    },
    /// The positioning error at the tool could not be measured (`lrmcal demo`).
    #[error("measure the positioning error through the board")]
    Positioning(#[from] crate::sim::positioning::PositioningError),
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
    Tracker(#[from] crate::tracker::TrackerError),
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

impl From<crate::device::ClientError> for Error {
    fn from(source: crate::device::ClientError) -> Self {
        Self::Device { source }
    }
}

impl From<crate::plan::PlanError> for Error {
    fn from(source: crate::plan::PlanError) -> Self {
        Self::Plan { source }
    }
}

impl From<crate::sim::SimError> for Error {
    /// The model's own failure keeps its exit code ([`Error::Model`]); the
    /// rest are simulator errors.
    fn from(error: crate::sim::SimError) -> Self {
        match error {
            crate::sim::SimError::Model {
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
            Self::Read { .. } | Self::Write { .. } => exit_codes::FILE_ACCESS,
            Self::Parse { .. }
            | Self::ArmSource { .. }
            | Self::ArmMismatch { .. }
            | Self::AmbiguousLoad { .. }
            | Self::Simulate { .. }
            | Self::Plan { .. }
            | Self::Ik { .. }
            | Self::Positioning(_) => exit_codes::INVALID_INPUT,
            Self::Model { .. } => exit_codes::MODEL,
            Self::Device { .. } | Self::Emulator { .. } => exit_codes::DEVICE,
            Self::FlashImage { .. } => exit_codes::INVALID_INPUT,
            Self::DeviceInput { .. } => exit_codes::INVALID_INPUT,
            Self::Tracker(e) => e.exit_code(),
            Self::Calib(e) => match e {
                crate::calib::CalibError::Plot { .. } => exit_codes::FILE_ACCESS,
                crate::calib::CalibError::Deflection { .. } => exit_codes::MODEL,
                _ => exit_codes::INVALID_INPUT,
            },
        }
    }

    /// The full message: `error: failed to <this>: <cause>: …` on one line.
    pub fn report(&self) -> String {
        let mut out = format!("error: failed to {self}");
        let mut cause = std::error::Error::source(self);
        while let Some(c) = cause {
            out.push_str(": ");
            out.push_str(&c.to_string());
            cause = c.source();
        }
        out
    }
}

/// Where in an input file a problem is, and what the problem is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{location}{problem}")]
pub struct InputError {
    /// Line and key/column, as far as known.
    pub location: Location,
    /// What is wrong and what was expected.
    pub problem: Problem,
}

impl InputError {
    /// A problem at a location.
    pub fn new(location: Location, problem: Problem) -> Self {
        Self { location, problem }
    }

    /// Attaches the file path, making a top-level [`Error`].
    pub fn in_file(self, path: impl Into<PathBuf>) -> Error {
        Error::Parse {
            path: path.into(),
            source: self,
        }
    }
}

/// A place in an input file: 1-based line and the field there, as far as known.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Location {
    /// 1-based line number, when known.
    pub line: Option<u64>,
    /// The key or column, when known.
    pub field: Option<Field>,
}

/// A named place within a line.
#[derive(Debug, Clone, PartialEq)]
pub enum Field {
    /// A TOML key path, e.g. `joint[3].mass` (array positions counted from 1).
    Key(String),
    /// A CSV column, by its header name.
    Column(String),
}

impl Location {
    /// A TOML key path, at a line if known.
    pub fn key(line: Option<u64>, key: impl Into<String>) -> Self {
        Self {
            line,
            field: Some(Field::Key(key.into())),
        }
    }

    /// A CSV column on a line.
    pub fn column(line: u64, column: impl Into<String>) -> Self {
        Self {
            line: Some(line),
            field: Some(Field::Column(column.into())),
        }
    }

    /// A whole line.
    pub fn line(line: u64) -> Self {
        Self {
            line: Some(line),
            field: None,
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Key(key) => write!(f, "key `{key}`"),
            Self::Column(column) => write!(f, "column `{column}`"),
        }
    }
}

impl fmt::Display for Location {
    /// `line 4, column `q3_deg`: ` (with the trailing separator), or as much as is known.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, &self.field) {
            (Some(line), Some(field)) => write!(f, "line {line}, {field}: "),
            (Some(line), None) => write!(f, "line {line}: "),
            (None, Some(field)) => write!(f, "{field}: "),
            (None, None) => Ok(()),
        }
    }
}

/// What is wrong with a value, a line or a file, and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Problem {
    /// The file is not valid TOML / CSV, or a value has the wrong type.
    #[error("{message}")]
    Syntax {
        /// The parser's description.
        message: String,
    },
    /// A number is NaN or infinite.
    #[error("expected a finite number, found {found}")]
    NotFinite {
        /// The value as written.
        found: String,
    },
    /// A number is outside its allowed range.
    #[error("expected {expected}, found {found}")]
    OutOfRange {
        /// The allowed range in words, with units.
        expected: &'static str,
        /// The value found.
        found: String,
    },
    /// A value that is well-formed but does not fit the rest of the file
    /// (a body name that names no body, a body that spans a joint).
    #[error("{message}")]
    Invalid {
        /// What is wrong and what was expected.
        message: String,
    },
    /// A pose's joint angle lies outside the arm's limits for that joint.
    #[error(
        "pose {pose}: {angle_deg}° is outside joint {joint}'s limits [{}°, {}°] \
         (pass --allow-outside-limits to use it anyway)",
        limits_deg[0],
        limits_deg[1]
    )]
    OutsideLimits {
        /// Pose id.
        pose: u32,
        /// The joint, 1-based.
        joint: u32,
        /// The angle, degrees.
        angle_deg: f64,
        /// The joint's limits, degrees.
        limits_deg: [f64; 2],
    },
    /// The arm file does not have exactly six joints.
    #[error("expected exactly 6 [[joint]] tables, found {found}")]
    JointCount {
        /// How many there are.
        found: usize,
    },
    /// A required CSV column is absent from the header.
    #[error("missing from the header (expected columns: {expected})")]
    MissingColumn {
        /// The missing column.
        column: &'static str,
        /// All columns of this kind of file.
        expected: String,
    },
    /// The header has a column this kind of file does not have.
    #[error(
        "unknown column (expected columns: {expected}; name other columns note_* to carry them along)"
    )]
    UnknownColumn {
        /// The unknown column.
        column: String,
        /// All columns of this kind of file.
        expected: String,
    },
    /// The header names a column twice.
    #[error("appears twice in the header")]
    DuplicateColumn {
        /// The repeated column.
        column: String,
    },
    /// A cell is not a number.
    #[error("expected {expected}, found `{found}`")]
    NotANumber {
        /// What kind of number, with units.
        expected: &'static str,
        /// The cell as written.
        found: String,
    },
    /// A row has more or fewer cells than the header.
    #[error("expected {expected} fields as in the header, found {found}")]
    FieldCount {
        /// Header width.
        expected: usize,
        /// This row's width.
        found: usize,
    },
    /// The same (pose, load) pair appears twice.
    #[error(
        "pose {pose} with load {load_kg} kg already appears on line {first_line}; expected each (pose, load_kg) once"
    )]
    DuplicatePose {
        /// Pose id.
        pose: u32,
        /// Load, kg.
        load_kg: f64,
        /// Line of the first occurrence.
        first_line: u64,
    },
    /// A pose id appears twice in a file where ids are unique.
    #[error("pose {pose} already appears on line {first_line}; expected each pose id once")]
    DuplicatePoseId {
        /// Pose id.
        pose: u32,
        /// Line of the first occurrence.
        first_line: u64,
    },
    /// The same pose id appears with other joint angles.
    #[error(
        "pose {pose} has other joint angles on line {first_line}; expected one configuration per pose id"
    )]
    InconsistentPose {
        /// Pose id.
        pose: u32,
        /// Line where the id first appeared.
        first_line: u64,
    },
    /// A JSON file is of another kind than the command reads (its `schema`).
    #[error("expected \"{expected}\", found {found}")]
    WrongSchema {
        /// The schema the command reads.
        expected: &'static str,
        /// What the file says it is, as written.
        found: String,
    },
    /// A JSON file is of another version of its schema than this build reads.
    #[error("expected {}, the versions this lrmcal reads, found {found}", version_range(*oldest, *newest))]
    WrongVersion {
        /// The oldest version this build reads.
        oldest: u32,
        /// The version this build writes.
        newest: u32,
        /// What the file says, as written.
        found: String,
    },
    /// A file that is not UTF-8 text.
    #[error(
        "expected UTF-8 text, found the byte 0x{byte:02x} at column {column} (save the file as UTF-8)"
    )]
    NotUtf8 {
        /// The first byte that is not UTF-8.
        byte: u8,
        /// Its 1-based byte position in its line.
        column: usize,
    },
    /// A file with a header but no data.
    #[error("expected at least one data row, found none")]
    NoRows,
}

/// `2`, or `1 to 2`, for [`Problem::WrongVersion`].
fn version_range(oldest: u32, newest: u32) -> String {
    if oldest == newest {
        newest.to_string()
    } else {
        format!("{oldest} to {newest}")
    }
}
