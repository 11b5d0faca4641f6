//! `lrmcal move`: move the arm to nominal joint angles, or put its tool point
//! on a Cartesian target (`--xyz`) through the nominal arm's inverse
//! kinematics ([`lrmcal_engine::ik`]).

use std::time::Duration;

use model::{Arm, MAX_JOINTS, PerJoint};
use nalgebra::Vector3;
use protocol::CompensationMode;
use protocol::{CHANNELS, PerChannel};

use crate::commands::device_args::{DeviceArgs, timing};
use crate::commands::helpers::{finite_height_mm, non_negative};
use crate::error::Error;
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_engine::device::calibration::NotDriven;
use lrmcal_engine::device::commanded::{Commanded, within_board};
use lrmcal_engine::device::{Client, Link, calibration};
use lrmcal_engine::ik::{self, IkOptions, IkSolution};
use lrmcal_engine::plan::PlanConfig;

/// Move every joint to a nominal angle (degrees), all arriving together, or
/// the tool point to a position (--xyz).
#[derive(Debug, clap::Args)]
#[command(
    // With --dry-run no board is needed.
    mut_arg("port", |a| a.required(false).required_unless_present("dry_run")),
    after_help = "Examples:\n  \
lrmcal move 0 30 -45 0 60 0 --port /dev/ttyACM0\n  \
lrmcal move -- -100 0 100 0 -100 0 --duration-ms 4000\n  \
lrmcal move --xyz 250 -50 120 --port /dev/ttyACM0\n  \
lrmcal move --xyz 250 -50 120 --dry-run --from-deg 0 30 -45 0 60 0\n\n\
The angles are the nominal model's: with compensation on, the board commands the angles that \
put the calibrated, deflected arm's tool where the nominal arm's would be. The board keeps \
its speed and acceleration limits whatever the duration asked for.\n\n\
With --xyz X Y Z (mm, the world frame of the measurements) the host solves the nominal, rigid \
arm's inverse kinematics for the tool point: of all the joint angles that put it there \
(a 6-joint arm has a three-dimensional family of them) it takes the one nearest the board's \
current pose in joint space, within the joint limits the board enforces and clear of the \
ground and of itself (the bodies and clearance of `lrmcal plan`), prints it and sends it as \
an ordinary move; the board compensates it like any other. With a calibration on the board, \
only solutions whose compensated commands the board can send are taken: every joint within \
its range (with half its play either way) and within four fifths of the calibration's largest \
correction for it (worked out on the host with the board's compensation mode and payload). \
The nominal arm is the one of the calibration on the board, or --arm when the board has none. \
A target out of reach, reachable only beyond the joint limits, only by colliding poses or only \
by poses the board's compensation cannot command is refused with the distance, joints or \
bodies at fault (exit code 3), before anything moves.\n\n\
--dry-run solves and prints without a board, from --from-deg (default all 0) on --arm, or on the \
nominal arm of --calibration, whose compensation (full, with --load-kg) it then keeps to."
)]
pub struct Args {
    /// One angle per joint of the board's arm, degrees, base to tip.
    #[arg(
        num_args = 1..=CHANNELS,
        value_name = "DEG",
        allow_negative_numbers = true,
        required_unless_present = "xyz",
        conflicts_with = "xyz"
    )]
    pub angles_deg: Vec<f64>,
    /// Put the tool point at this position instead, mm, world frame (as in
    /// the measurement files): the nearest solution of the inverse kinematics.
    #[arg(
        long,
        num_args = 3,
        value_names = ["X", "Y", "Z"],
        allow_negative_numbers = true,
        value_parser = finite_number
    )]
    pub xyz: Option<Vec<f64>>,
    /// Solve --xyz and print the joint targets, without a board.
    #[arg(long, requires = "xyz", conflicts_with = "angles_deg")]
    pub dry_run: bool,
    /// The pose --dry-run starts from, one angle per joint, degrees [default: all 0].
    #[arg(
        long,
        num_args = 1..=MAX_JOINTS,
        value_name = "DEG",
        allow_negative_numbers = true,
        requires = "dry_run",
        value_parser = finite_number
    )]
    pub from_deg: Option<Vec<f64>>,
    /// The nominal arm --xyz solves: a bundled arm's name or an arm
    /// description `.toml` file [default: the nominal arm of the board's
    /// calibration, else the bundled `lrm`].
    #[arg(
        long,
        value_name = "NAME|FILE",
        requires = "xyz",
        conflicts_with = "calibration"
    )]
    pub arm: Option<ArmSource>,
    /// With --dry-run: solve as a board holding this calibration would be
    /// sent (its nominal arm, its compensation's limits).
    #[arg(long, value_name = "FILE", requires = "dry_run")]
    pub calibration: Option<std::path::PathBuf>,
    /// With --dry-run and --calibration: the payload the board compensates for, kg.
    #[arg(
        long,
        value_name = "KG",
        default_value_t = 0.0,
        requires = "calibration"
    )]
    pub load_kg: f64,
    /// Height of the ground plane for --xyz, mm, world frame.
    #[arg(long, value_name = "MM", default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite_height_mm)]
    pub ground_z_mm: f64,
    /// Let --xyz poses reach below the ground plane (e.g. an arm mounted at a table edge).
    #[arg(long, conflicts_with = "ground_z_mm")]
    pub no_ground: bool,
    /// Smallest gap --xyz allows between two links, or a link and the ground, mm.
    #[arg(long, value_name = "MM", default_value_t = PlanConfig::default().clearance_m * 1e3, value_parser = non_negative)]
    pub clearance_mm: f64,
    /// How long the move takes, ms (stretched if the limits need more).
    #[arg(long, conflicts_with = "speed_deg_s")]
    pub duration_ms: Option<u32>,
    /// Speed of the joint that travels furthest, deg/s [default: the board's top speed].
    #[arg(long)]
    pub speed_deg_s: Option<f64>,
    /// Return at once instead of waiting until the arm stands still.
    #[arg(long)]
    pub no_wait: bool,
    /// The board (not needed with --dry-run).
    #[command(flatten)]
    pub device: Option<DeviceArgs>,
}

fn finite_number(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("expected a finite number, found `{text}`")),
    }
}

/// Runs `lrmcal move`.
pub fn run(args: &Args) -> Result<(), Error> {
    if let Some(xyz) = &args.xyz {
        let target_mm = numbers::<3>(xyz, "--xyz")?;
        return if args.dry_run {
            dry_run(args, target_mm)
        } else {
            move_to_point(args, target_mm)
        };
    }
    let targets = PerChannel::from_fn(args.angles_deg.len().min(CHANNELS), |j| {
        args.angles_deg[j].to_radians() as f32
    });
    let mut client = board(args)?.connect()?;
    send(&mut client, targets, args)
}

/// `lrmcal move --xyz … --dry-run`: solve from --from-deg on --arm and print.
fn dry_run(args: &Args, target_mm: [f64; 3]) -> Result<(), Error> {
    let start_for = |joints: usize| match &args.from_deg {
        Some(deg) => PerJoint::from_fn(deg.len(), |j| deg[j].to_radians()),
        None => PerJoint::splat(joints, 0.0),
    };
    let (solution, origin, start) = match &args.calibration {
        Some(path) => {
            let file = CalibrationFile::read(path)?;
            let joints = file.arm.joints.len();
            let home = PerChannel::splat(joints.min(CHANNELS), 0.0);
            let payload =
                calibration::payload(&file, home).map_err(|fault| Error::DeviceInput {
                    what: format!("use `{}` for --xyz", path.display()),
                    reason: calibration::explain(fault, &file.arm),
                })?;
            let board = Commanded::new(&payload, CompensationMode::Full, args.load_kg);
            let arm = within_board(&payload.nominal.map(f64::from), Some(&payload));
            let origin = format!("nominal arm of `{}`", path.display());
            let start = start_for(joints);
            (
                solve(args, &arm, target_mm, &start, Some(&board))?,
                origin,
                start,
            )
        }
        None => {
            let (arm, origin) = nominal_arm(args.arm.as_ref())?;
            let start = start_for(arm.joints.len());
            (solve(args, &arm, target_mm, &start, None)?, origin, start)
        }
    };
    print!(
        "{}",
        report(&origin, "--from-deg", &start, target_mm, &solution)
    );
    Ok(())
}

/// `lrmcal move --xyz …`: solve from the board's pose on the board's nominal
/// arm and limits, print, move.
fn move_to_point(args: &Args, target_mm: [f64; 3]) -> Result<(), Error> {
    let mut client = board(args)?.connect()?;
    let status = client.status()?;
    let calibration = match status.calibration {
        Some(_) => Some(client.pull_calibration()?),
        None => None,
    };
    let board_model = calibration
        .as_ref()
        .map(|c| Commanded::new(c, status.mode, f64::from(status.payload_kg)));
    let (arm, origin) = match &calibration {
        Some(c) => {
            if let Some(source) = &args.arm {
                eprintln!(
                    "warning: --arm {source} not used: the board's calibration {:08x} says \
                     which nominal arm its joint targets are for",
                    c.id
                );
            }
            (
                c.nominal.map(f64::from),
                format!("nominal arm of the board's calibration {:08x}", c.id),
            )
        }
        None => nominal_arm(args.arm.as_ref())?,
    };
    // The arm's servo curves are the board's business here: only its length counts.
    if let Err(refused @ NotDriven::Joints { .. }) = calibration::drivable(&arm) {
        return Err(Error::DeviceInput {
            what: "move the arm".into(),
            reason: refused.to_string(),
        });
    }
    // The board refuses targets outside its ranges: keep the solution inside.
    let arm = within_board(&arm, calibration.as_ref());
    let start = PerJoint::from_fn(status.nominal_rad.len(), |j| {
        f64::from(status.nominal_rad[j])
    });
    let solution = solve(args, &arm, target_mm, &start, board_model.as_ref())?;
    print!(
        "{}",
        report(&origin, "the board's pose", &start, target_mm, &solution)
    );
    // Rounding to f32 keeps the order, so an in-limit angle stays in the board's f32 limits.
    let targets = PerChannel::from_fn(solution.q.len().min(CHANNELS), |j| solution.q[j] as f32);
    send(&mut client, targets, args)
}

/// Solves the target with the collision settings of the command line, among
/// the poses `board` (the board's calibration, if it has one) can command.
fn solve(
    args: &Args,
    arm: &Arm<f64>,
    target_mm: [f64; 3],
    start: &[f64],
    board: Option<&Commanded>,
) -> Result<IkSolution, Error> {
    let options = IkOptions {
        collisions: Some(PlanConfig {
            ground_z_m: (!args.no_ground).then_some(args.ground_z_mm * 1e-3),
            clearance_m: args.clearance_mm * 1e-3,
            ..PlanConfig::default()
        }),
        ..IkOptions::default()
    };
    let admit = |q: &[f64]| match board {
        Some(board) => board.command(q).map(drop).map_err(|r| r.to_string()),
        None => Ok(()),
    };
    ik::solve_position_admitted(
        arm,
        &(Vector3::from(target_mm) * 1e-3),
        start,
        &options,
        &admit,
    )
    .map_err(|source| Error::Ik {
        target_mm,
        source: Box::new(source),
    })
}

/// Sends the targets and, unless --no-wait, waits until the arm stands still.
fn send<L: Link>(
    client: &mut Client<L>,
    targets_rad: PerChannel<f32>,
    args: &Args,
) -> Result<(), Error> {
    client.move_to(targets_rad, timing(args.duration_ms, args.speed_deg_s))?;
    if !args.no_wait {
        client.wait_until_still(Duration::from_millis(100), Duration::from_secs(700))?;
        println!("arrived");
    }
    Ok(())
}

/// The board to talk to.
fn board(args: &Args) -> Result<&DeviceArgs, Error> {
    args.device.as_ref().ok_or_else(|| Error::DeviceInput {
        what: "move the arm".into(),
        reason: "no board given: pass --port or set LRMCAL_PORT (or --dry-run with --xyz)".into(),
    })
}

/// The nominal arm `--arm` names (bundled `lrm` without it), and where it came from.
/// A calibration file is refused: its calibrated arm is not what joint targets mean.
fn nominal_arm(source: Option<&ArmSource>) -> Result<(Arm<f64>, String), Error> {
    let source = source.cloned().unwrap_or(ArmSource::Bundled(DEFAULT_ARM));
    if let ArmSource::Calibration(path) = &source {
        return Err(lrmcal_core::Error::ArmSource {
            arm: path.display().to_string(),
            reason: "joint targets are for a nominal arm: give the bundled arm's name or the \
                     arm description (.toml) the calibration was identified against"
                .into(),
        }
        .into());
    }
    let loaded = source.load()?;
    Ok((loaded.arm, format!("{} ({})", loaded.origin, loaded.name)))
}

/// Exactly `N` numbers, or an error naming `what`.
fn numbers<const N: usize>(values: &[f64], what: &str) -> Result<[f64; N], Error> {
    <[f64; N]>::try_from(values).map_err(|_| Error::DeviceInput {
        what: "move the arm".into(),
        reason: format!("{what}: expected {N} numbers, found {}", values.len()),
    })
}

/// What `--xyz` found, for people: the arm, the start, the target, the joint
/// targets (in degrees, ready for `lrmcal move`) and how well they do.
fn report(
    origin: &str,
    start_from: &str,
    start: &[f64],
    target_mm: [f64; 3],
    s: &IkSolution,
) -> String {
    let deg = |q: &[f64]| {
        let list: Vec<String> = q
            .iter()
            .map(|a| format!("{:.4}", (a.to_degrees() * 1e4).round() / 1e4 + 0.0))
            .collect();
        list.join(" ")
    };
    format!(
        "nominal arm: {origin}\n\
         start ({start_from}), deg: {}\n\
         target, mm: {:.3} {:.3} {:.3}\n\
         joint targets, deg: {}\n\
         tool point {:.1e} mm from the target, {:.2}° from the start in joint space\n",
        deg(start),
        target_mm[0],
        target_mm[1],
        target_mm[2],
        deg(&s.q),
        s.error_m * 1e3,
        s.distance_rad.to_degrees()
    )
}
