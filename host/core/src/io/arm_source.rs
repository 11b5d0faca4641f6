//! Which arm a command works on, as given by `--arm`: the name of a bundled arm
//! (`lrm`, the default, so a new user needs no files) or a file whose extension
//! says what it holds: `.toml` a nominal arm description, `.urdf` a robot
//! description whose serial chain is the arm (between the links `--base-link`
//! and `--tip-link` name, or its one root and one end), `.json` a calibration
//! file written by `lrmcal identify` or `lrmcal demo` (its corrected arm is used).
//!
//! To accept another kind of file, add a variant to [`ArmSource`], its
//! extension in [`ArmSource::from_str`] and its loader in [`ArmSource::load`].

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use model::Arm;

use crate::collision::CollisionSpec;
use crate::error::Error;
use crate::io::arm_toml::{self, ArmDescription};
use crate::io::arm_urdf;
use crate::io::calibration_file::CalibrationFile;

/// The arms shipped inside the binary: (name, TOML text). `lrm` (the
/// default) is a stand-in for the paper's arm; `so101` is the SO-101
/// desktop arm, its geometry from its URDF (`arms/so101/`).
pub const BUNDLED: &[(&str, &str)] = &[
    ("lrm", include_str!("../../arms/lrm.toml")),
    ("so101", include_str!("../../arms/so101.toml")),
];

/// The arm used when `--arm` is not given.
pub const DEFAULT_ARM: &str = "lrm";

/// Where an arm comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ArmSource {
    /// A bundled arm, by name.
    Bundled(&'static str),
    /// A nominal arm description file (TOML).
    Description(PathBuf),
    /// A URDF's serial chain from a base link to a tip link (its one root
    /// and one end when not named).
    Urdf {
        /// The URDF file.
        path: PathBuf,
        /// The chain's first link, `--base-link`.
        base_link: Option<String>,
        /// The link whose origin is the measured point's frame, `--tip-link`.
        tip_link: Option<String>,
    },
    /// A calibration file (JSON): the calibrated arm it carries.
    Calibration(PathBuf),
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
    /// Its joints' names, base to tip: the arm file's (a calibration
    /// file's recorded ones, `joint_1` … for one that holds none).
    pub joint_names: Vec<String>,
    /// Its bodies, floor and clearance for the planner: the arm file's, or
    /// the defaults (the arm's skeleton) for a calibration file, which holds none.
    pub collision: CollisionSpec,
    /// The levels of the planner's candidate grid, degrees: the arm file's
    /// `[plan] levels_deg`, or `None` (the planner's default) for an arm
    /// file without it, a URDF or a calibration file.
    pub levels_deg: Option<Vec<f64>>,
    /// The calibration file it came from, if it did: what its arm means
    /// (the servo curves its commands go through, its targets) is the
    /// engine's to work out from it.
    pub calibration: Option<CalibrationFile>,
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
            Some("urdf") => Ok(Self::Urdf {
                path: path.to_owned(),
                base_link: None,
                tip_link: None,
            }),
            Some("json") => Ok(Self::Calibration(path.to_owned())),
            _ => Err(format!(
                "expected the name of a bundled arm ({}), an arm description file ending in .toml \
                 or .urdf, or a calibration file ending in .json, found `{spec}`",
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
            Self::Urdf {
                path,
                base_link,
                tip_link,
            } => {
                write!(f, "`{}`", path.display())?;
                match (base_link, tip_link) {
                    (None, None) => Ok(()),
                    _ => write!(
                        f,
                        " from `{}` to `{}`",
                        base_link.as_deref().unwrap_or("its root"),
                        tip_link.as_deref().unwrap_or("its end")
                    ),
                }
            }
            Self::Calibration(path) => write!(f, "calibration `{}`", path.display()),
        }
    }
}

impl ArmSource {
    /// Reads and checks the arm.
    ///
    /// A calibration file is read by its own module (schema and version
    /// checked there); it names no arm, so the name says which model option
    /// calibrated it.
    pub fn load(&self) -> Result<LoadedArm, Error> {
        let (d, calibration) = match self {
            Self::Bundled(name) => (bundled(name)?, None),
            Self::Description(path) => (arm_toml::read(path)?, None),
            Self::Urdf {
                path,
                base_link,
                tip_link,
            } => (
                arm_urdf::read(path, base_link.as_deref(), tip_link.as_deref())?,
                None,
            ),
            Self::Calibration(path) => {
                let file = CalibrationFile::read(path)?;
                let d = ArmDescription {
                    name: file
                        .arm_name
                        .clone()
                        .unwrap_or_else(|| format!("calibrated, {} model", file.option.name())),
                    joint_names: file.joint_names_or_numbered(),
                    arm: file.arm,
                    collision: CollisionSpec::default(),
                    levels_deg: None,
                };
                (d, Some(file))
            }
        };
        Ok(LoadedArm {
            origin: self.to_string(),
            name: d.name,
            arm: d.arm,
            joint_names: d.joint_names,
            collision: d.collision,
            levels_deg: d.levels_deg,
            calibration,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calibration_file::test_support::sample_file as calibration;
    use crate::io::calibration_file::{SCHEMA, SCHEMA_VERSION};

    fn load_text(text: &str) -> Result<LoadedArm, Error> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cal.json");
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().parse::<ArmSource>().unwrap().load()
    }

    #[test]
    fn the_extension_says_what_a_file_holds() {
        assert_eq!(
            "a/cal.json".parse::<ArmSource>(),
            Ok(ArmSource::Calibration("a/cal.json".into()))
        );
        assert_eq!(
            "a/arm.toml".parse::<ArmSource>(),
            Ok(ArmSource::Description("a/arm.toml".into()))
        );
        assert_eq!("lrm".parse::<ArmSource>(), Ok(ArmSource::Bundled("lrm")));
        let e = "arm.yaml".parse::<ArmSource>().unwrap_err();
        assert!(
            e.contains(".toml") && e.contains(".json") && e.contains("arm.yaml"),
            "{e}"
        );
    }

    #[test]
    fn a_calibration_file_gives_its_calibrated_arm() {
        let file = calibration();
        let loaded = load_text(&file.to_json()).unwrap();
        assert_eq!(loaded.arm, file.arm);
        assert_ne!(loaded.arm, file.nominal);
        assert!(loaded.origin.contains("cal.json"), "{}", loaded.origin);
        assert!(loaded.name.contains("elastic"), "{}", loaded.name);
    }

    #[test]
    fn other_json_and_other_versions_are_refused_as_invalid_input() {
        let e = load_text("{\"schema\": \"lrmcal-sim-truth/1\", \"seed\": 1}").unwrap_err();
        let msg = e.report();
        assert!(!e.is_access(), "{msg}");
        assert!(
            msg.contains("cal.json") && msg.contains("calibration") && msg.contains(SCHEMA),
            "{msg}"
        );

        let json = calibration().to_json().replace(
            &format!("\"schema_version\": {SCHEMA_VERSION}"),
            "\"schema_version\": 99",
        );
        let e = load_text(&json).unwrap_err();
        let msg = e.report();
        assert!(!e.is_access(), "{msg}");
        assert!(
            msg.contains("schema_version") && msg.contains("99"),
            "{msg}"
        );

        let e = load_text("pose,x_mm\n1,2\n").unwrap_err();
        assert!(!e.is_access());
        assert!(e.report().contains("not JSON"), "{}", e.report());
    }

    #[test]
    fn a_missing_calibration_file_is_a_file_access_error() {
        let e = ArmSource::Calibration("/nonexistent/cal.json".into())
            .load()
            .unwrap_err();
        assert!(e.is_access());
        assert!(
            e.report().contains("/nonexistent/cal.json"),
            "{}",
            e.report()
        );
    }
}
