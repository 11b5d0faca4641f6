//! `lrmcal export`: an arm's rigid geometry (calibrated or nominal) as a
//! URDF for ROS tools, with what URDF cannot hold said in the file (`--urdf`);
//! or a nominal arm, a URDF's chain above all, as lrmcal's own arm file to
//! complete by hand (`--toml`).

use protocol::{CHANNELS, PerChannel};
use std::path::{Path, PathBuf};

use model::Arm;

use crate::commands::helpers::{non_negative, positive};
use crate::error::Error;
use lrmcal_core::collision::{BodySet, CollisionSpec};
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM, LoadedArm};
use lrmcal_core::io::arm_toml::{self, ArmDescription};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::urdf::{self, UrdfOptions};
use lrmcal_engine::device::calibration;

/// Gravity further than this from the URDF root's -z is warned about, rad (1°).
const MAX_TILT_RAD: f64 = 0.017_453_292_519_943_295;

/// Export an arm for other tools.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal export --urdf --calibration cal/calibration-elasto-kinematic-servo.json --out arm.urdf\n  \
lrmcal export --urdf --arm my_arm.toml > nominal.urdf\n\n\
lrmcal export --urdf --calibration cal/calibration-elasto-kinematic-servo.json --arm my_arm.toml --name my_arm --out arm.urdf\n  \
lrmcal export --toml --arm robot.urdf --base-link base --tip-link gripper --out my_arm.toml\n\n\
The URDF chain is base_link (with base beside it) -> link_1..link_6 (revolute joints named \
as in the arm file) -> flange -> tool0 -> tool_point, the robot standing in its own base \
frame; --world roots it at world, the frame lrmcal measured in. Links carry the arm file's \
masses and centres of mass, and its collision bodies as visual and collision geometry. \
Joint positions are lrmcal's commanded angles in radians, 0 where the pose files say 0 \
degrees, so the same angles put tool_point where `lrmcal predict` puts the tool point of a \
rigid arm. Compliances (the sag under gravity and load), servo curves and play have no \
place in a URDF; the file's header says so.\n\n\
--toml writes a nominal arm (--arm) as lrmcal's arm file: a URDF's chain with the DH \
geometry, limits and masses lrmcal reads from it, and what a URDF cannot say as lrmcal takes \
it (gravity along -z, rigid springs, no servo tables, the skeleton as bodies), said in the \
file's header. Add servo tables, payload or bodies to it and use it as --arm.",
    group(clap::ArgGroup::new("format").args(["urdf", "toml"]).required(true))
)]
pub struct Args {
    /// Write a URDF (ROS robot description) of the arm's rigid geometry.
    #[arg(long)]
    pub urdf: bool,
    /// Write the nominal arm (--arm) as an arm description TOML, to edit and
    /// use as --arm.
    #[arg(long, conflicts_with_all = ["calibration", "world", "payload_kg", "effort_nm", "velocity_rad_s"])]
    pub toml: bool,
    /// Calibration file from `lrmcal identify` or `lrmcal demo`: its calibrated arm.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// The arm: a bundled arm's name, an arm description `.toml` file, a URDF
    /// `.urdf` file (its chain from --base-link to --tip-link), or a
    /// calibration `.json` file (as --calibration). With --calibration, the
    /// arm description whose joint names, bodies and name the URDF takes, the
    /// geometry staying the calibration's; it must describe the
    /// calibration's nominal arm (its joints' DH geometry, limits and
    /// masses) [default: the bundled arm; with --calibration, joints
    /// joint_1.. and the arm's skeleton].
    #[arg(long, value_name = "NAME|FILE")]
    pub arm: Option<ArmSource>,
    /// The robot's name in the URDF [default: the arm's name; `arm` for a
    /// calibration without --arm].
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
    /// Root the URDF at `world`, the frame lrmcal measured in (the
    /// tracker's), with the arm's base placed in it [default: the robot in
    /// its own base frame, `base_link` the root].
    #[arg(long)]
    pub world: bool,
    /// A payload at the tool, kg: a `payload` link at the arm's payload
    /// centre of mass.
    #[arg(long, value_name = "KG", value_parser = non_negative)]
    pub payload_kg: Option<f64>,
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
    /// Where to write the URDF or TOML [default: standard output].
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// The arm to export, with what the file's header says about it.
struct Exported {
    arm: Arm<f64>,
    joint_names: Vec<String>,
    collision: CollisionSpec,
    /// What the arm is called in messages.
    label: String,
    /// The robot's name when --name is not given.
    default_name: String,
    provenance: Vec<String>,
}

/// Runs `lrmcal export`.
pub fn run(args: &Args) -> Result<(), Error> {
    if args.toml {
        return export_toml(args);
    }
    let bundled = ArmSource::Bundled(DEFAULT_ARM);
    let exported = match (&args.calibration, &args.arm) {
        (Some(path), names) => from_calibration(path, names.as_ref())?,
        (None, Some(ArmSource::Calibration(path))) => from_calibration(path, None)?,
        (None, source) => from_arm(source.as_ref().unwrap_or(&bundled))?,
    };
    let bodies = BodySet::for_arm(&exported.arm, &exported.collision).map_err(|e| {
        lrmcal_core::Error::ArmSource {
            arm: exported.label.clone(),
            reason: format!("its collision bodies do not fit the arm exported: {e}"),
        }
    })?;
    let off_down = urdf::gravity_off_down_rad(&exported.arm, args.world);
    if off_down > MAX_TILT_RAD {
        let root = if args.world { "world" } else { "base_link" };
        eprintln!(
            "warning: gravity in {} is {:.1}° off the -z axis of {root}: ROS takes gravity along -z, \
             so the arm stands tilted by that much in it ({})",
            exported.label,
            off_down.to_degrees(),
            if args.world {
                "register with `identify --up AXIS` so that the measurement frame is Z-up, or export without --world"
            } else {
                "the arm's base frame is not level; the calibration's gravity says how it is mounted"
            }
        );
    }
    let options = UrdfOptions {
        robot_name: args.name.clone().unwrap_or(exported.default_name),
        provenance: exported.provenance,
        effort_nm: args.effort_nm,
        velocity_rad_s: args.velocity_rad_s,
        joint_names: exported.joint_names,
        bodies: Some(bodies),
        world: args.world,
        payload_kg: args.payload_kg,
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
        None => to_stdout(&urdf::render(&exported.arm, &options)),
    }
}

/// `--toml`: the nominal arm of `--arm` as an arm description, with a header
/// saying where it came from and, for a URDF's chain, what was taken as what.
fn export_toml(args: &Args) -> Result<(), Error> {
    let source = args.arm.clone().unwrap_or(ArmSource::Bundled(DEFAULT_ARM));
    if let ArmSource::Calibration(path) = &source {
        return Err(lrmcal_core::Error::ArmSource {
            arm: path.display().to_string(),
            reason: "--toml writes a nominal arm (an arm file, a bundled arm or a URDF's chain); \
                     a calibration's arm is used as it is (`--arm FILE.json`) or exported with --urdf"
                .to_owned(),
        }
        .into());
    }
    let loaded = source.load()?;
    let text = format!(
        "{}{}",
        toml_header(&source, &loaded),
        arm_toml::to_toml(&ArmDescription {
            name: args.name.clone().unwrap_or_else(|| loaded.name.clone()),
            joint_names: loaded.joint_names,
            arm: loaded.arm,
            collision: loaded.collision,
            levels_deg: loaded.levels_deg,
        })
    );
    match &args.out {
        Some(path) => {
            lrmcal_core::io::atomic::write(path, |w| w.write_all(text.as_bytes()))?;
            eprintln!(
                "wrote the arm file of {} to `{}`",
                loaded.origin,
                path.display()
            );
            Ok(())
        }
        None => to_stdout(&text),
    }
}

/// The comment lines that open an exported arm file.
fn toml_header(source: &ArmSource, loaded: &LoadedArm) -> String {
    let mut lines = vec![format!(
        "Written by `lrmcal export --toml` from {}: edit it and use it as --arm.",
        loaded.origin
    )];
    if let ArmSource::Urdf { .. } = source {
        lines.extend(
            [
                "From the URDF: the joints' axes and origins as standard DH, their",
                "limits, each link's mass and centre of mass. Not in a URDF, so taken as:",
                "gravity along -z of the base link, compliances 0 (calibration finds",
                "them), no payload, the skeleton as collision bodies, and no servo",
                "tables: the board drives a joint only once it has one. Add",
                "`servo = { minus100 = ..., zero = ..., plus100 = ... }` (pulses in µs)",
                "to a joint, then `lrmcal servo-tune` refines it.",
            ]
            .map(str::to_owned),
        );
    }
    lines.iter().map(|l| format!("# {l}\n")).collect()
}

/// Writes `text` on standard output.
fn to_stdout(text: &str) -> Result<(), Error> {
    std::io::Write::write_all(&mut std::io::stdout().lock(), text.as_bytes()).map_err(|source| {
        Error::from(lrmcal_core::Error::Write {
            path: "<stdout>".into(),
            source,
        })
    })
}

/// The calibrated arm of a calibration file (the one place `export` reads one),
/// and the id the board will show for it; joint names, bodies and name from
/// the arm description `names`, if given.
fn from_calibration(path: &Path, names: Option<&ArmSource>) -> Result<Exported, Error> {
    let file = CalibrationFile::read(path)?;
    check_limits(&file.arm, path)?;
    // `lrmcal push` without --home-deg sends the all-zero home pose, and the
    // home pose is part of what the id covers.
    let home = PerChannel::splat(file.arm.joints.len().min(CHANNELS), 0.0);
    let id = match calibration::payload(&file, home) {
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
    let described = names.map(ArmSource::load).transpose()?;
    if let Some(d) = &described {
        // Its names and bodies fit only the arm the calibration is of: a
        // calibration file given as --arm stands for its own nominal arm.
        let nominal = d.calibration.as_ref().map_or(&d.arm, |c| &c.nominal);
        file.check_describes_nominal(nominal, &d.origin, path)?;
    }
    // Without --arm, the names the calibration recorded of its arm.
    let (default_name, joint_names, collision) = match described {
        Some(d) => (d.name, d.joint_names, d.collision),
        None => (
            file.arm_name.clone().unwrap_or_else(|| "arm".to_owned()),
            file.joint_names_or_numbered(),
            CollisionSpec::default(),
        ),
    };
    Ok(Exported {
        arm: file.arm,
        joint_names,
        collision,
        label: format!("calibration `{}`", path.display()),
        default_name,
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
        joint_names: loaded.joint_names,
        collision: loaded.collision,
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
