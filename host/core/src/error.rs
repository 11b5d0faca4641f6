//! The errors of the host's ground floor: a file that could not be read,
//! written or used ([`Error`]), and, for a file whose content is invalid,
//! where in it and what was expected ([`InputError`]).
//!
//! Messages are lowercase and read after "failed to …", as the command line
//! prints them.

use std::fmt;
use std::path::PathBuf;

/// A file that could not be read, written or used.
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
}

impl Error {
    /// Whether the file itself could not be read or written, rather than used.
    pub fn is_access(&self) -> bool {
        matches!(self, Self::Read { .. } | Self::Write { .. })
    }

    /// The full message: `error: failed to <this>: <cause>: …` on one line.
    pub fn report(&self) -> String {
        report(self)
    }
}

/// The full message of any error, as `lrmcal` prints it:
/// `error: failed to <error>: <cause>: …` on one line.
pub fn report(error: &dyn std::error::Error) -> String {
    let mut out = format!("error: failed to {error}");
    let mut cause = error.source();
    while let Some(c) = cause {
        out.push_str(": ");
        out.push_str(&c.to_string());
        cause = c.source();
    }
    out
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

    /// Attaches the file path, making an [`Error::Parse`].
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
        "pose {pose}: {angle_deg}{unit} is outside joint {joint}'s limits [{}{unit}, {}{unit}] \
         (pass --allow-outside-limits to use it anyway)",
        limits_deg[0],
        limits_deg[1],
        unit = match kind {
            model::JointKind::Revolute => "°",
            model::JointKind::Prismatic => " mm",
        }
    )]
    OutsideLimits {
        /// Pose id.
        pose: u32,
        /// The joint, 1-based.
        joint: u32,
        /// The angle, degrees (a prismatic joint's position, mm).
        angle_deg: f64,
        /// The joint's limits, degrees (mm).
        limits_deg: [f64; 2],
        /// The joint's kind, which says the unit: `°`, or ` mm` for a
        /// prismatic joint (a kind, not the unit's text, keeps the error
        /// small enough to return by value).
        kind: model::JointKind,
    },
    /// The arm file has no joints or more than [`model::MAX_JOINTS`].
    #[error("expected 1 to {} [[joint]] tables, found {found}", model::MAX_JOINTS)]
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
