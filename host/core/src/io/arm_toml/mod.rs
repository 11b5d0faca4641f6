//! The arm description file (`docs/FORMATS.md`, "Arm description"): TOML <-> [`model::Arm`]
//! and the planner's [`CollisionSpec`].
//!
//! Every key of the model is required; there are no defaults, because a
//! forgotten line in a calibration input should be an error, not a silent
//! zero. Three parts are optional: a joint's `servo` table (an arm our board
//! does not drive has none, its joints have `servo: None`), the collision description
//! (`[collision]`, `[[body]]`) and the candidate grid's levels (`[plan]`),
//! whose defaults are the planner's. Unknown keys
//! are rejected (a misspelt key would otherwise be ignored). Numbers must be
//! finite; masses, compliances and sizes must not be negative; joint limits
//! must satisfy `lo < hi`; servo curves must be strictly monotonic with their
//! pulses in [`PULSE_RANGE_US`]. Errors name the key path (`joint[3].mass`,
//! `body[2].capsule.from`, array positions counted from 1 like the joints
//! `j1..j6`), the line, and what was expected.
//!
//! A servo curve is written as its knots, `{ angles_deg = [...], pulses_us =
//! [...] }`; the three points of earlier files, `{ minus100, zero, plus100 }`,
//! still read as the same curve, bit for bit.

use std::ops::Range;
use std::path::Path;

use model::Arm;

use crate::collision::CollisionSpec;
use crate::error::{Error, Field, InputError, Location, Problem};
use crate::io::{atomic, read_text};

mod check;
mod edit;
mod raw;

pub use edit::{with_servo, write_servo};
use raw::RawArm;

/// An arm description as read from (or written to) a TOML file.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmDescription {
    /// The arm's name (`name` key).
    pub name: String,
    /// The joints' names, base to tip (`joint[i].name`).
    pub joint_names: Vec<String>,
    /// The arm's parameters; a joint without a `servo` table has no curve
    /// (`servo: None`: an arm moved by its own controller).
    pub arm: Arm<f64>,
    /// The bodies, floor and clearance the planner tests (`[collision]`, `[[body]]`).
    pub collision: CollisionSpec,
    /// The levels of the planner's candidate grid, degrees, increasing
    /// (`[plan] levels_deg`); `None`: the planner's default, the paper's
    /// -100, 0, +100.
    pub levels_deg: Option<Vec<f64>>,
}

/// Reads and checks an arm description file.
pub fn read(path: &Path) -> Result<ArmDescription, Error> {
    let text = read_text(path)?;
    parse(&text).map_err(|e| e.in_file(path))
}

/// Writes an arm description file atomically (a temporary file renamed into place).
pub fn write(path: &Path, description: &ArmDescription) -> Result<(), Error> {
    let text = to_toml(description);
    atomic::write(path, |w| w.write_all(text.as_bytes()))
}

/// Serialises an arm description as TOML in the layout `docs/FORMATS.md` describes.
pub fn to_toml(description: &ArmDescription) -> String {
    let raw = RawArm::from_description(description);
    // Serialising plain structs of numbers and strings cannot fail.
    let body = toml::to_string(&raw).expect("an arm description always serialises");
    format!("# Arm description (lrmcal docs/FORMATS.md): metres, radians, kilograms, µs.\n{body}")
}

/// Parses and checks the text of an arm description.
pub fn parse(text: &str) -> Result<ArmDescription, InputError> {
    let lines = LineIndex::new(text);
    let deserializer = toml::Deserializer::parse(text).map_err(|e| toml_error(&lines, e, None))?;
    let raw: RawArm = serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let path = super::key_path(e.path());
        toml_error(&lines, e.into_inner(), Some(path))
    })?;
    raw.check(&lines)
}

/// A `toml` or serde error turned into an [`InputError`] with line and key path.
pub(crate) fn toml_error(
    lines: &LineIndex,
    error: toml::de::Error,
    path: Option<String>,
) -> InputError {
    let line = error.span().map(|s| lines.line_of(s.start));
    let location = Location {
        line,
        field: path.filter(|p| !p.is_empty()).map(Field::Key),
    };
    InputError::new(
        location,
        Problem::Syntax {
            message: error.message().trim().to_owned(),
        },
    )
}

/// Byte offset -> 1-based line number.
pub(crate) struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    pub(crate) fn new(text: &str) -> Self {
        let starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Self { starts }
    }

    fn line_of(&self, offset: usize) -> u64 {
        let line = self.starts.partition_point(|&start| start <= offset);
        line as u64
    }

    fn span_line(&self, span: Range<usize>) -> Option<u64> {
        // Values made in memory (for writing) carry an empty span at 0.
        (!span.is_empty()).then(|| self.line_of(span.start))
    }
}
