//! `lrmcal export --urdf`: an arm's rigid geometry (calibrated or nominal) as a
//! URDF for ROS tools, with what URDF cannot hold said in the file.

use model::JOINTS;
use std::path::{Path, PathBuf};

use model::Arm;

use crate::commands::helpers::positive;
use crate::error::Error;
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::urdf::{self, UrdfOptions};
use lrmcal_engine::device::calibration;

/// Export an arm for other tools.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal export --urdf --calibration cal/calibration-elasto-kinematic-servo.json --out arm.urdf\n  \
lrmcal export --urdf --arm my_arm.toml > nominal.urdf\n\n\
The URDF chain is world -> base_link -> link_1..link_6 (revolute joint_1..joint_6) -> \
flange -> tool0 -> tool_point. Joint positions are lrmcal's commanded angles in radians, \
0 where the pose files say 0 degrees, so the same angles put tool_point where `lrmcal \
predict` puts the tool point of a rigid arm. Compliances (the sag under gravity and load) \
and servo curves have no place in a URDF; the file's header says so.")]
pub struct Args {
    /// Write a URDF (ROS robot description) of the arm's rigid geometry.
    #[arg(long, required = true)]
    pub urdf: bool,
    /// Calibration file from `lrmcal identify` or `lrmcal demo`: its calibrated arm.
    #[arg(long, value_name = "FILE", conflicts_with = "arm")]
    pub calibration: Option<PathBuf>,
    /// The arm otherwise: a bundled arm's name, an arm description `.toml` file,
    /// or a calibration `.json` file (as --calibration).
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// The robot's name in the URDF [default: the arm's name, or the calibration file's name].
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
    /// Effort limit written for every joint, N·m: lrmcal does not know it, URDF
    /// requires one (the default is about a standard hobby servo's stall torque).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "NM",
        default_value_t = 1.0,
        value_parser = positive
    )]
    pub effort_nm: f64,
    /// Velocity limit written for every joint, rad/s (the default is the board's top joint speed).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "RAD_S",
        default_value_t = 1.5,
        value_parser = positive
    )]
    pub velocity_rad_s: f64,
    /// Where to write the URDF [default: standard output].
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// The arm to export, with what the file's header says about it.
struct Exported {
    arm: Arm<f64>,
    /// What the arm is called in messages.
    label: String,
    /// The robot's name when --name is not given.
    default_name: String,
    provenance: Vec<String>,
}

/// Runs `lrmcal export`.
pub fn run(args: &Args) -> Result<(), Error> {
    let exported = match (&args.calibration, &args.arm) {
        (Some(path), _) | (None, ArmSource::Calibration(path)) => from_calibration(path)?,
        (None, source) => from_arm(source)?,
    };
    let options = UrdfOptions {
        robot_name: args.name.clone().unwrap_or(exported.default_name),
        provenance: exported.provenance,
        effort_nm: args.effort_nm,
        velocity_rad_s: args.velocity_rad_s,
    };
    match &args.out {
        Some(path) => {
            urdf::write(path, &exported.arm, &options)?;
            eprintln!(
                "wrote the URDF of {} to `{}`",
                exported.label,
                path.display()
            );
            Ok(())
        }
        None => {
            let text = urdf::render(&exported.arm, &options);
            std::io::Write::write_all(&mut std::io::stdout().lock(), text.as_bytes()).map_err(
                |source| {
                    Error::from(lrmcal_core::Error::Write {
                        path: "<stdout>".into(),
                        source,
                    })
                },
            )
        }
    }
}

/// The calibrated arm of a calibration file (the one place `export` reads one),
/// and the id the board will show for it.
fn from_calibration(path: &Path) -> Result<Exported, Error> {
    let file = CalibrationFile::read(path)?;
    check_limits(&file.arm, path)?;
    // `lrmcal push` without --home-deg sends the all-zero home pose, and the
    // home pose is part of what the id covers.
    let id = match calibration::payload(&file, [0.0; JOINTS]) {
        Ok(payload) => format!(
            "Calibration id {:08x}: what `lrmcal status` shows once `lrmcal push` has stored it \
             (default home pose).",
            payload.id
        ),
        Err(fault) => format!(
            "No calibration id: `lrmcal push` refuses this calibration with the default home \
             pose ({fault})."
        ),
    };
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "arm".into());
    Ok(Exported {
        arm: file.arm,
        label: format!("calibration `{}`", path.display()),
        default_name: name,
        provenance: vec![
            format!(
                "Arm: the calibrated arm of `{}` ({} model).",
                path.display(),
                file.option.name()
            ),
            id,
        ],
    })
}

/// A bundled arm or an arm description, as it is (nominal).
fn from_arm(source: &ArmSource) -> Result<Exported, Error> {
    let loaded = source.load()?;
    Ok(Exported {
        arm: loaded.arm,
        provenance: vec![format!(
            "Arm: {} ({}), nominal: not a calibration.",
            loaded.origin, loaded.name
        )],
        label: loaded.origin,
        default_name: loaded.name,
    })
}

/// A URDF revolute joint needs `lower < upper`: arm descriptions are checked
/// when read, the arm of a calibration file is not.
fn check_limits(arm: &Arm<f64>, path: &Path) -> Result<(), Error> {
    for (i, joint) in arm.joints.iter().enumerate() {
        let [lower, upper] = joint.limits;
        if lower >= upper {
            return Err(lrmcal_core::Error::ArmSource {
                arm: path.display().to_string(),
                reason: format!(
                    "joint {}'s limits are [{lower}, {upper}] rad; expected the lower limit below the upper",
                    i + 1
                ),
            }
        .into());
        }
    }
    Ok(())
}
