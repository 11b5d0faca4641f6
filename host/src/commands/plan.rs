//! `lrmcal plan`: the candidate poses a calibration may choose from, the grid
//! of joint levels less the poses that leave the joint limits or collide, and,
//! with `--camera`, those whose board the camera does not see.

use std::path::PathBuf;

use crate::commands::helpers::{finite_height_mm, non_negative};
use crate::error::Error;
use lrmcal_core::camera::setup;
use lrmcal_core::dataset::PoseRow;
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::pose_list;
use lrmcal_engine::plan::{
    DEFAULT_RANDOM_POSES, DEFAULT_RANDOM_SEED, Levels, PlanConfig, candidates,
};

/// Generate the candidate poses: a grid of joint levels, filtered for safety.
#[derive(Debug, clap::Args)]
#[command(after_help = "The grid puts every joint at every level \
(the paper's grid: -100, 0, +100 degrees, 3^6 = 729 poses for six joints; an arm file's \
[plan] levels_deg gives its own), less the poses that would leave \
a joint's limits, bring a body too close to the ground, or bring two bodies too close to each \
other.\n\n\
The bodies are those of the arm file's [[body]] tables (capsules and boxes fixed to its \
frames), or else its skeleton: a capsule along each link's DH offsets and one to the tool \
point, a twentieth of the arm's length thick. Bodies on neighbouring links, or joined by less \
arm than their radii (an elbow, a spherical wrist), are not tested against each other. The \
ground is the plane z = --ground-z-mm of the world frame. A pose is dropped for the first test \
it fails (limits, ground, self-collision), so the counts on stderr add up to the grid. With --camera, a pose is also dropped when the camera of the setup file \
does not see the board the arm carries: every tag corner must project inside the image, 10 px \
from its edges, and the board must face the camera within 60 degrees (the setup file, the \
intrinsics and the board files are described in docs/FORMATS.md; the poses there need only be \
told roughly). Random poses are drawn until as many are seen. Pose \
ids are grid indices (joint 1 the slowest digit, the last joint the fastest) and stay the same \
whatever is dropped.\n\n\
Examples:\n  \
lrmcal plan --out candidates.csv\n  \
lrmcal plan --levels 5 --out fine.csv              # -100,-50,0,50,100 on every joint\n  \
lrmcal plan --levels -90,-30,30,90 --clearance-mm 20 --out c.csv\n  \
lrmcal plan --arm my_arm.toml --ground-z-mm -120 --out c.csv   # base 12 cm above the floor\n  \
lrmcal plan --camera webcam.toml --out seen.csv    # only poses the webcam sees the board in\n\n\
The output is a pose list (pose,q1_deg..q6_deg) for `lrmcal simulate --poses`, `lrmcal select` \
or a measurement session.")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, an arm description `.toml` file, or a
    /// URDF `.urdf` file (its chain from --base-link to --tip-link).
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Joint levels: a count N (N levels evenly from -100 to +100 degrees) or
    /// comma-separated angles in degrees; the same for every joint [default:
    /// the arm file's `[plan] levels_deg`, else -100,0,100].
    #[arg(long, value_name = "N|DEG,...", allow_hyphen_values = true)]
    pub levels: Option<Levels>,
    /// Random poses off the grid to add (over ±100°, kept when clear of the
    /// limits and collisions): they let the servo curves be identified
    /// between the grid's angles.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_RANDOM_POSES)]
    pub random: usize,
    /// Seed of the random poses.
    #[arg(long, default_value_t = DEFAULT_RANDOM_SEED)]
    pub seed: u64,
    /// Height of the ground plane in the world (measurement) frame, mm
    /// [default: the arm file's `[collision] floor`, else 0].
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = finite_height_mm)]
    pub ground_z_mm: Option<f64>,
    /// Do not test against the ground (e.g. an arm mounted at a table edge).
    #[arg(long, conflicts_with = "ground_z_mm")]
    pub no_ground: bool,
    /// Smallest gap allowed between two bodies, or a body and the ground, mm
    /// [default: the arm file's `[collision] clearance`, else 10].
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = non_negative)]
    pub clearance_mm: Option<f64>,
    /// A camera setup file (TOML): keep only the poses in which its camera
    /// sees the whole board the arm carries, facing it.
    #[arg(long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
    /// Where to write the candidate pose list [default: standard output].
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// Runs `lrmcal plan`.
pub fn run(args: &Args) -> Result<(), Error> {
    let arm = args.arm.load()?;
    // How many poses the levels make depends on the arm's joints: a usage
    // error like the levels' own.
    if let Some(Err(e)) = args
        .levels
        .as_ref()
        .map(|l| l.grid_size(arm.arm.joints.len()))
    {
        return Err(Error::Usage(format!("--levels: {e}")));
    }
    let mut config = match &args.levels {
        Some(levels) => PlanConfig {
            levels: levels.clone(),
            ..PlanConfig::for_arm(&arm.arm, &arm.collision)?
        },
        None => PlanConfig::for_loaded(&arm)?,
    };
    config.random = args.random;
    config.seed = args.seed;
    if args.no_ground {
        config.ground_z_m = None;
    } else if let Some(z) = args.ground_z_mm {
        config.ground_z_m = Some(z * 1e-3);
    }
    if let Some(c) = args.clearance_mm {
        config.clearance_m = c * 1e-3;
    }
    config.camera = args.camera.as_deref().map(setup::read).transpose()?;
    let report = candidates(&arm.arm, &config)?;
    let rows: Vec<PoseRow> = report
        .kept
        .iter()
        .map(|&pose| PoseRow {
            pose,
            load_kg: None,
        })
        .collect();
    match &args.out {
        Some(path) => pose_list::write(path, &rows, &arm.arm.kinds())?,
        None => pose_list::write_to(&mut std::io::stdout().lock(), &rows, &arm.arm.kinds())
            .map_err(|source| lrmcal_core::Error::Write {
                path: "<stdout>".into(),
                source,
            })?,
    }
    eprintln!(
        "{} ({}), levels {} deg:",
        arm.origin, arm.name, config.levels
    );
    eprint!("{report}");
    if let Some(path) = &args.out {
        eprintln!(
            "wrote {} candidate poses to `{}`",
            rows.len(),
            path.display()
        );
    }
    Ok(())
}
