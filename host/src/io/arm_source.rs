//! Which arm a command works on, as given by `--arm`: the name of a bundled arm
//! (`lrm`, the default, so a new user needs no files) or a file whose extension
//! says what it holds (`.toml`: a nominal arm description).
//!
//! To accept another kind of file (a calibration result), add a variant to
//! [`ArmSource`], its extension in [`ArmSource::from_str`] and its loader in
//! [`ArmSource::load`].

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use model::Arm;

use crate::error::Error;
use crate::io::arm_toml::{self, ArmDescription};

/// The arms shipped inside the binary: (name, TOML text).
pub const BUNDLED: &[(&str, &str)] = &[("lrm", include_str!("../../arms/lrm.toml"))];

/// The arm used when `--arm` is not given.
pub const DEFAULT_ARM: &str = "lrm";

/// Where an arm comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ArmSource {
    /// A bundled arm, by name.
    Bundled(&'static str),
    /// A nominal arm description file (TOML).
    Description(PathBuf),
}

/// An arm ready for use, with a human-readable origin for reports.
#[derive(Clone, Debug)]
pub struct LoadedArm {
    /// Where it came from (`bundled arm lrm`, a path).
    pub origin: String,
    /// The arm's name.
    pub name: String,
    /// The arm.
    pub arm: Arm<f64>,
}

impl FromStr for ArmSource {
    type Err = String;

    /// A bundled name (unless a file of that name exists) or a path with a known extension.
    fn from_str(spec: &str) -> Result<Self, String> {
        let path = Path::new(spec);
        if let Some(&(name, _)) = BUNDLED.iter().find(|(name, _)| *name == spec)
            && !path.exists()
        {
            return Ok(Self::Bundled(name));
        }
        match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => Ok(Self::Description(path.to_owned())),
            _ => Err(format!(
                "expected the name of a bundled arm ({}) or an arm description file ending in .toml, found `{spec}`",
                BUNDLED
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }
}

impl fmt::Display for ArmSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bundled(name) => write!(f, "bundled arm `{name}`"),
            Self::Description(path) => write!(f, "`{}`", path.display()),
        }
    }
}

impl ArmSource {
    /// Reads and checks the arm.
    pub fn load(&self) -> Result<LoadedArm, Error> {
        let description = match self {
            Self::Bundled(name) => bundled(name)?,
            Self::Description(path) => arm_toml::read(path)?,
        };
        Ok(LoadedArm {
            origin: self.to_string(),
            name: description.name,
            arm: description.arm,
        })
    }
}

/// Parses a bundled arm by name.
pub fn bundled(name: &str) -> Result<ArmDescription, Error> {
    let Some((name, text)) = BUNDLED.iter().find(|(n, _)| *n == name) else {
        return Err(Error::ArmSource {
            arm: name.to_owned(),
            reason: format!(
                "no bundled arm of that name (bundled: {})",
                BUNDLED
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    };
    arm_toml::parse(text).map_err(|e| e.in_file(format!("bundled:{name}")))
}
