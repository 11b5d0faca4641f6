//! `lrmcal demo`: the whole method on the bundled arm with no files of your
//! own: plan the candidates (the grid and random poses off it), simulate a
//! true arm measured under no load and 66.3 g, select N poses per option with
//! DETMAX, identify, validate on the rest and on poses off the grid, check
//! across loads, compare with random selections and with fewer poses
//! (`calib::study`), drive the simulated arm through the board's
//! compensation, and write the calibrations, the report and the plots to
//! one folder.

mod camera;

use std::path::PathBuf;
use std::time::Instant;

use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::identify::IdentifyOptions;
use lrmcal_engine::calib::fit::pipeline::{Choice, RunSettings};
use lrmcal_engine::calib::results::export::result_calibration_file;
use lrmcal_engine::calib::results::study::{StudySettings, study};
use lrmcal_engine::calib::results::summary;
use lrmcal_engine::calib::run::{Calibration, Request};
use lrmcal_engine::device::calibration;

use crate::commands::helpers::write_text;
use crate::error::Error;
use crate::plots;
use crate::progress::Steps;
use crate::report_page;
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::measurements;
use lrmcal_engine::plan::{DEFAULT_RANDOM_POSES, PlanConfig, candidates, random_candidates};
use lrmcal_engine::sim::{DEFAULT_SEED, SimConfig, TrueArm, positioning};

/// The paper's payload, kg.
const PAPER_LOAD_KG: f64 = 0.0663;

/// Poses off the grid every option is validated on, none of them a candidate.
pub const OFF_GRID_POSES: usize = 200;

/// Seed of the off-grid validation poses (the candidates' is another).
pub const OFF_GRID_SEED: u64 = 2024;

/// Ids of the off-grid validation poses start here, far from any candidate's.
pub const OFF_GRID_FIRST_ID: u32 = 1_000_000;

/// Run the whole calibration on a simulated arm and write everything it produces.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal demo\n  \
lrmcal demo --out my-demo --seed 7\n  \
lrmcal demo --model-only      # no unmodelled effects, no noise: a consistency check\n  \
lrmcal demo --camera          # the webcam path: images, tags, arm and camera together\n\n\
Writes to the output folder: measurements.csv (every candidate under both loads), \
off-grid.csv (the off-grid validation poses), truth.json (the simulated true arm), calibration-<option>.json (one per option, the file \
the firmware receives), report.json, report.html (the run on one page), and the plots errors.svg/png (validation error \
per option), errors-cross-load.svg/png, per-pose.svg/png, o1-vs-poses.svg/png, \
errors-vs-poses.svg/png (the paper's model and ours from 10 to 60 poses) and \
positioning.svg/png (the error at the tool when the board drives the simulated arm to random \
targets: uncalibrated, the paper's model and ours).")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, an arm description `.toml` file, or a
    /// URDF `.urdf` file (its chain from --base-link to --tip-link).
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Seed of the simulated true arm.
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Poses to select per option.
    #[arg(long, default_value_t = 60)]
    pub poses: usize,
    /// Random poses off the grid added to the candidates.
    #[arg(long, default_value_t = DEFAULT_RANDOM_POSES)]
    pub random: usize,
    /// DETMAX random starts per option.
    #[arg(long, default_value_t = DetmaxOptions::default().starts)]
    pub starts: usize,
    /// Random selections of as many poses (--poses) to compare DETMAX with,
    /// on the paper's elasto-kinematic model; 0 skips it.
    #[arg(long, default_value_t = 20)]
    pub compare_random: usize,
    /// Random tool-point targets the board drives the simulated arm to, for
    /// the positioning error at the tool; 0 skips it.
    #[arg(long, default_value_t = positioning::DEFAULT_TARGETS)]
    pub targets: usize,
    /// Switch off every effect the model lacks and the tracker noise.
    #[arg(long)]
    pub model_only: bool,
    /// Skip the error against the number of poses (the paper's model and
    /// ours calibrated again from 10 to 60 DETMAX poses).
    #[arg(long = "no-error-sweep", action = clap::ArgAction::SetFalse)]
    pub error_sweep: bool,
    /// Plain least squares in the fits, without down-weighting measurements
    /// far off the others.
    #[arg(long)]
    pub no_robust: bool,
    /// The webcam path instead: plan the poses a camera sees, select them
    /// on its pixels, render the images, detect the tags, identify the arm
    /// and the camera together, and judge both against the truth.
    #[arg(long)]
    pub camera: bool,
    /// With --camera, your camera setup (TOML) instead of the bundled one
    /// (a webcam 0.8 m in front of the bundled arm).
    #[arg(long, value_name = "SETUP", requires = "camera")]
    pub camera_setup: Option<PathBuf>,
    /// With --camera, the bundled webcam on the arm's flange and the board
    /// standing 0.55 m before the arm (eye-in-hand).
    #[arg(long, requires = "camera", conflicts_with = "camera_setup")]
    pub eye_in_hand: bool,
    /// Output folder (created if missing).
    #[arg(long, short, value_name = "DIR", default_value = "lrmcal-demo")]
    pub out: PathBuf,
}

/// Runs `lrmcal demo`.
///
/// `lrmcal` is what runs a command line (the CLI's own parser and
/// dispatch): the camera path runs the commands a user types.
pub fn run(args: &Args, lrmcal: &dyn Fn(&[String]) -> Result<(), Error>) -> Result<(), Error> {
    if args.camera {
        return camera::run(args, lrmcal);
    }
    let started = Instant::now();
    let loaded = args.arm.load()?;
    let nominal = loaded.arm;
    std::fs::create_dir_all(&args.out).map_err(|source| lrmcal_core::Error::Write {
        path: args.out.clone(),
        source,
    })?;

    // The arm file's grid levels, bodies, floor and clearance, as `lrmcal
    // plan` takes them: the candidates, the off-grid poses and the targets
    // through the board are all kept clear the same way.
    let arm_plan = PlanConfig::for_loaded(&loaded).map_err(|source| Error::Plan { source })?;
    let plan_config = PlanConfig {
        random: args.random,
        ..arm_plan.clone()
    };
    let plan = candidates(&nominal, &plan_config).map_err(|source| Error::Plan { source })?;
    let poses = plan.kept;
    let off_grid_poses = random_candidates(
        &nominal,
        &arm_plan,
        OFF_GRID_POSES,
        OFF_GRID_SEED,
        OFF_GRID_FIRST_ID,
    )
    .map_err(|source| Error::Plan { source })?;
    let config = if args.model_only {
        SimConfig::model_only()
    } else {
        SimConfig::default()
    }
    .scaled_to(&nominal);
    let truth =
        TrueArm::draw(&nominal, args.seed, &config).map_err(|source| Error::Simulate { source })?;
    let loads = [0.0, PAPER_LOAD_KG];
    let all = truth
        .measure(&poses, &loads)
        .map_err(|source| Error::Simulate { source })?;
    let off_grid = truth
        .measure(&off_grid_poses, &[PAPER_LOAD_KG])
        .map_err(|source| Error::Simulate { source })?;
    let kinds = truth.nominal.kinds();
    measurements::write(&args.out.join("measurements.csv"), &all, &kinds)?;
    measurements::write(&args.out.join("off-grid.csv"), &off_grid, &kinds)?;
    write_text(&args.out.join("truth.json"), &truth.truth_json(None))?;
    println!(
        "{} candidate poses ({} of the {} grid poses clear of the joint limits and collisions, {} random ones off the grid); true arm seed {}{}",
        poses.len(),
        poses.len() - args.random.min(poses.len()),
        plan.grid_size,
        args.random,
        args.seed,
        if args.model_only {
            ", model-only (no unmodelled effects, no noise)"
        } else {
            ", unmodelled effects on"
        }
    );

    // The measurements are the simulated arm's, in its world frame: the
    // arm stands where its file says, and every fit goes through the one
    // calibration run a user's `identify` makes.
    let identify = IdentifyOptions {
        robust: !args.no_robust,
        ..Default::default()
    };
    let calibration = Calibration::open(
        &Request::new(&nominal, &all)
            .named(loaded.origin.clone(), "the simulated measurements")
            .candidates(&poses)
            .load(PAPER_LOAD_KG)
            .identify(identify),
    )?;
    let settings = StudySettings {
        run: RunSettings {
            identify_load_kg: PAPER_LOAD_KG,
            other_load_kg: Some(0.0),
            choice: Choice::Detmax(DetmaxOptions {
                n: args.poses,
                starts: args.starts,
                ..Default::default()
            }),
            identify,
        },
        compare_random: args.compare_random,
        error_sweep: args.error_sweep,
    };
    let measured = serde_json::json!({
        "source": "simulated",
        "seed": args.seed,
        "loads_kg": loads,
        "config": config,
    });
    let study = study(
        &calibration,
        plan.grid_size,
        &off_grid,
        &settings,
        (loaded.origin.clone(), measured),
        &Steps::new(),
    )?;
    let mut files = Vec::with_capacity(study.results.len());
    for r in &study.results {
        let file = result_calibration_file(&nominal, &r.identified, r)
            .for_arm(&loaded.name, &loaded.joint_names);
        let path = args.out.join(format!("calibration-{}.json", r.option()));
        write_text(&path, &file.to_json())?;
        files.push((r.option(), file));
    }
    write_text(&args.out.join("report.json"), &study.report.to_json())?;
    report_page::write(&args.out, &study.report)?;
    let mut plot_files = plots::demo_figures(
        &args.out,
        &study.report.options[..study.results.len()],
        &study.report.o1_vs_poses,
        &study.report.error_vs_poses,
    )?;
    print!("{}", summary::study(&study, off_grid.len())?);
    let board_refuses = (args.targets > 0)
        .then(|| calibration::drivable(&nominal).err())
        .flatten();
    if let Some(reason) = &board_refuses {
        println!("\nPositioning error at the tool through the board: skipped, {reason}");
    }
    if args.targets > 0 && board_refuses.is_none() {
        let calibrations: Vec<_> = files.iter().map(|(o, f)| (*o, f)).collect();
        let boards = positioning::demo_boards(&calibrations)?;
        let targets = positioning::targets(
            &nominal,
            args.targets,
            args.seed,
            &arm_plan,
            &boards,
            PAPER_LOAD_KG,
        )?;
        let rows = positioning::compare(&truth, &targets.targets, &boards, PAPER_LOAD_KG)?;
        plot_files.extend(plots::positioning(&args.out, &rows, PAPER_LOAD_KG)?);
        println!(
            "\nPositioning error at the tool through the board, {} random targets with {PAPER_LOAD_KG} kg \
             (mm; nominal IK as `move --xyz`, the firmware's servo frames, the true arm; clamped: \
             targets on the way to which a command was clamped to a limit, fell back: targets \
             whose move ended with the compensation fallen back or not converged):",
            args.targets
        );
        print!("{}", positioning::table(&rows));
        if targets.left_out > 0 {
            println!(
                "({} random tool points left out: no solution of a calibrated board's nominal arm \
                 (standing where its calibration found the arm) that the board could command \
                 within its joint ranges)",
                targets.left_out
            );
        }
    }
    println!(
        "\nwrote {} (calibration-*.json, report.json, report.html, measurements.csv, off-grid.csv, truth.json, {} plots) in {:.1} s",
        args.out.display(),
        plot_files.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
