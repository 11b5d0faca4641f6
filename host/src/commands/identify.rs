//! `lrmcal identify`: fit the error parameters to a measurement file, from a
//! DETMAX selection of N poses or an explicit pose list, for one model option
//! or all three; validate on the measured poses not used; write the
//! calibration file(s) and a report. Measurements of several targets per
//! pose (a `target` column) fit one arm and a tool point per target; with
//! `--tool-only`, only the tool points are fitted, the arm of an earlier
//! calibration held fixed (after a tool change).
//! Before the fit the arm is registered in the measurement frame
//! (`crate::calib::registration`, on the first target's rows) unless
//! `--no-register` keeps the arm file's base.

use std::path::PathBuf;

use crate::calib::checks::{
    check_in_candidates, check_measured, check_plausible, identification_load,
};
use crate::calib::detmax::DetmaxOptions;
use crate::calib::export::{calibration_file, target_tools};
use crate::calib::identifiability::check_structure;
use crate::calib::identify::{IdentifyOptions, identify};
use crate::calib::pipeline::{CandidateBlocks, Choice, Inputs, RunSettings, calibrate_blocks};
use crate::calib::registration::{GENERIC_HINT, Gravity, Registration, diagnose, register};
use crate::calib::report::Report;
use crate::calib::targets::{Rig, Targets, tool_keys};
use crate::calib::{CalibError, summary};
use crate::commands::helpers::write_text;
use crate::commands::helpers::{Bar, OptionChoice};
use crate::dataset::{Pose, loads_of, poses_under};
use crate::error::Error;
use crate::io::arm_source::{ArmSource, DEFAULT_ARM};
use crate::io::calibration_file::{CalibrationFile, RegistrationRecord, ValidationSummary};
use crate::io::{measurements, pose_list};
use crate::tracker::axes::Up;
use model::Arm;

/// Identify the arm's error parameters from measured tool positions.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal identify --measurements m.csv --select 50 --out cal\n  \
lrmcal identify --measurements m.csv --poses selection.csv --option all --out cal\n  \
lrmcal identify --measurements m.csv --load-kg 0.0663 --candidates candidates.csv --no-robust\n  \
lrmcal identify --measurements new-tool.csv --calibration cal/calibration-elasto-kinematic.json --tool-only\n\n\
The fit uses the measurements under one load (--load-kg; the file's only load by default). \
With --select N, DETMAX picks N of the measured poses (D-optimal for the option); with \
--poses, the list's poses are used; with neither, every measured pose is. Measured poses \
not used for the fit validate it, under every load in the file. Measurements far off the \
others are down-weighted (Huber) and named, in the fit and in the validation. Writes \
calibration-<option>.json (the file `lrmcal push` sends to the board) and report.json.\n\n\
The positions may be in any right-handed frame (the tracker's): the arm's base is found \
in it from the measurements first (printed, and recorded in the calibration file), so the \
arm file's [base] need not be known. Gravity is the arm file's `gravity` in that frame, \
or -g along the axis --up names, or along the base's -z with --level-base.\n\n\
Several targets per pose: a `target` column in the measurements names the target of each row; \
the fit shares the arm and gives each target its own tool point (every target needs at least \
3 poses). After a tool change, re-teach only the tool points from a few poses with \
--calibration OLD.json --tool-only: the arm of OLD.json stays as it is.")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, or an arm description `.toml` file.
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Measurement CSV (`pose,load_kg,q1_deg..q6_deg,x_mm,y_mm,z_mm[,target]`).
    #[arg(long, value_name = "FILE")]
    pub measurements: PathBuf,
    /// Candidate pose list: every measured pose must be one of them.
    #[arg(long, value_name = "FILE")]
    pub candidates: Option<PathBuf>,
    /// Select this many poses with DETMAX.
    #[arg(long, value_name = "N", conflicts_with = "poses")]
    pub select: Option<usize>,
    /// Use exactly the poses of this pose list.
    #[arg(long, value_name = "FILE")]
    pub poses: Option<PathBuf>,
    /// Model option: elasto-kinematic-servo (each servo's own curve, backlash
    /// and stiffening too), elasto-kinematic, kinematic, elastic (the paper's
    /// three) or all.
    #[arg(long, default_value_t = OptionChoice::One(crate::calib::option::DEFAULT))]
    pub option: OptionChoice,
    /// Load whose measurements the fit uses, kg.
    #[arg(long, value_name = "KG")]
    pub load_kg: Option<f64>,
    /// Plain least squares: measurements far off keep their full weight
    /// (they are still named, with a warning).
    #[arg(long)]
    pub no_robust: bool,
    /// Fit measured poses outside the arm's joint limits too (with a warning)
    /// instead of refusing the file.
    #[arg(long)]
    pub allow_outside_limits: bool,
    /// The measurement frame's axis that points up: gravity along its minus
    /// direction [default: the arm file's `gravity`, read in the measurement frame].
    #[arg(
        long,
        value_name = "AXIS",
        allow_hyphen_values = true,
        conflicts_with = "level_base"
    )]
    pub up: Option<Up>,
    /// The arm's base stands level: gravity along its frame 0's -z, wherever
    /// registration puts it.
    #[arg(long)]
    pub level_base: bool,
    /// Keep the arm file's base: the measurements are in its world frame.
    #[arg(long, conflicts_with = "level_base")]
    pub no_register: bool,
    /// Re-teach only the tool points (one per target of the measurements)
    /// with the arm of --calibration held fixed: after a tool change.
    #[arg(long, requires = "calibration", conflicts_with_all = ["select", "poses", "candidates"])]
    pub tool_only: bool,
    /// The earlier calibration whose arm --tool-only keeps.
    #[arg(long, value_name = "FILE", requires = "tool_only")]
    pub calibration: Option<PathBuf>,
    /// DETMAX random starts.
    #[arg(long, default_value_t = DetmaxOptions::default().starts)]
    pub starts: usize,
    /// Output folder (created if missing).
    #[arg(long, short, value_name = "DIR", default_value = "lrmcal-calibration")]
    pub out: PathBuf,
}

/// Runs `lrmcal identify`.
pub fn run(args: &Args) -> Result<(), Error> {
    let loaded = args.arm.load()?;
    let nominal = loaded.arm;
    let file = args.measurements.display().to_string();
    let all = measurements::read(&args.measurements)?;
    if let Some(warning) = pose_list::check_file_within_limits(
        &nominal,
        &args.measurements,
        args.allow_outside_limits,
    )? {
        eprintln!("warning: {warning}");
    }
    if all.is_empty() {
        return Err(CalibError::Empty {
            what: format!("identify from {file}"),
        }
        .into());
    }
    let loads = loads_of(&all);
    let load = identification_load(&loads, args.load_kg, &file)?;
    let targets = Targets::of(&all);
    let under_load: Vec<_> = all.iter().filter(|m| m.load_kg == load).copied().collect();
    targets.check_poses(&under_load, &file)?;
    if let Some(path) = &args.calibration {
        return tool_only(args, path, targets, &under_load, load);
    }
    // The nominal arm knows the first target's tool point only: the others
    // may sit anywhere on the flange.
    let first: Vec<_> = all
        .iter()
        .filter(|m| targets.index(m.target) == Some(0))
        .copied()
        .collect();
    let registration = registration(args, &nominal, &first)?;
    // The fit runs in the arm file's world frame, where the base's angles
    // are small corrections; the file gets the result in the measurement frame.
    let nominal = registration.arm_for_fit(&nominal);
    let all = registration.to_arm_frame(&all);
    let first = registration.to_arm_frame(&first);
    // Still 150 mm off after the best rigid motion: say what to check.
    check_plausible(&nominal, &first, &file).map_err(|e| match e {
        CalibError::BadMeasurement {
            pose,
            load_kg,
            file,
            problem,
        } => {
            let hint = diagnose(&nominal, &first).unwrap_or_else(|| GENERIC_HINT.into());
            CalibError::BadMeasurement {
                pose,
                load_kg,
                file,
                problem: format!("{problem}; {hint}"),
            }
        }
        other => other,
    })?;
    if let Some(path) = &args.candidates {
        let candidates: Vec<Pose> = pose_list::read(path)?.into_iter().map(|r| r.pose).collect();
        check_in_candidates(&all, &candidates, &file)?;
    }
    let measured = poses_under(&all, load);
    let choice = match (&args.select, &args.poses) {
        (Some(n), _) => Choice::Detmax(DetmaxOptions {
            n: *n,
            starts: args.starts,
            ..Default::default()
        }),
        (None, Some(path)) => {
            let ids: Vec<u32> = pose_list::read(path)?.iter().map(|r| r.pose.id).collect();
            check_measured(&ids, &measured, &path.display().to_string(), &file, load)?;
            Choice::Given(ids)
        }
        (None, None) => Choice::Given(measured.iter().map(|p| p.id).collect()),
    };
    let settings = RunSettings {
        identify_load_kg: load,
        other_load_kg: loads.iter().copied().find(|l| *l != load),
        choice,
        identify: IdentifyOptions {
            robust: !args.no_robust,
            ..Default::default()
        },
    };
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Write {
        path: args.out.clone(),
        source,
    })?;

    let inputs = Inputs::new(&nominal, &measured, &all);
    let bar = Bar::new();
    let mut results = Vec::new();
    for option in args.option.options() {
        let blocks = CandidateBlocks::build(&inputs.nominal, option, &measured, &[load])?;
        // The measured poses must identify what positions can reveal on this arm at all.
        check_structure(&nominal, &blocks.identifiability, load)?;
        if !args.no_register {
            check_registered_count(&settings.choice, blocks.identifiability.kept.len(), option)?;
        }
        results.push(calibrate_blocks(&inputs, blocks, &settings, &bar)?);
    }

    let report = Report::new(
        loaded.origin,
        measured.len(),
        load,
        serde_json::json!({ "source": file, "loads_kg": loads }),
        &results,
    );
    for (r, details) in results.iter().zip(&report.options) {
        let per_target = r
            .validation
            .as_ref()
            .map(|v| v.after_per_target(targets.len()))
            .unwrap_or_default();
        let mut cal = calibration_file(
            &registration.arm_in_measurement_frame(&nominal),
            &registration.identified_in_measurement_frame(&nominal, &r.identified),
            &r.held(),
            r.pose_ids(),
            vec![load],
            r.identified.fit_residual,
            r.validation.as_ref().map(|v| ValidationSummary {
                load_kg: load,
                before: v.before,
                after: v.after,
            }),
        );
        for (target, after) in cal.targets.iter_mut().zip(per_target) {
            target.validation_after = Some(after);
        }
        let cal = cal.with_registration(record(args, &registration));
        let path = args.out.join(format!("calibration-{}.json", r.option()));
        write_text(&path, &cal.to_json())?;
        println!("\n{}", summary::option_details(details));
        if !cal.targets.is_empty() {
            print!("{}", summary::targets_table(&cal.targets));
        }
        if args.no_robust && !details.fit.outliers.is_empty() {
            let poses: Vec<String> = details
                .fit
                .outliers
                .iter()
                .map(|o| format!("{} ({:.1} mm)", o.pose, o.residual_mm))
                .collect();
            eprintln!(
                "warning: {}: {} measurements of {file} are far off the others (poses {}) and keep their full weight because of --no-robust; without it they are down-weighted",
                r.option(),
                poses.len(),
                poses.join(", ")
            );
        }
        println!("  wrote {}", path.display());
    }
    write_text(&args.out.join("report.json"), &report.to_json())?;
    println!("\nValidation on the measured poses not used for the fit, {load} kg (mean 3D error):");
    print!("{}", summary::table(&report.options));
    println!("wrote {}", args.out.display());
    Ok(())
}

/// Coordinates of a rigid motion: what registration takes from the
/// measurements before the fit sees them.
const REGISTRATION_DOF: usize = 6;

/// Refuses a fit of `params` parameters from the poses `choice` takes when
/// their coordinates (one point a pose) do not also cover the base's place
/// that registration took from them: three poses register exactly and would
/// leave the fit nothing to check itself against.
fn check_registered_count(
    choice: &Choice,
    params: usize,
    option: crate::calib::ModelOption,
) -> Result<(), CalibError> {
    let poses = match choice {
        Choice::Detmax(d) => d.n,
        Choice::Given(ids) => ids.len(),
    };
    // Fewer coordinates than parameters: the selection and the fit refuse
    // those themselves, with their own counts.
    if 3 * poses >= params && 3 * poses < params + REGISTRATION_DOF {
        return Err(CalibError::Registration {
            problem: format!(
                "the {poses} poses give {} coordinates, fewer than the {REGISTRATION_DOF} the base's place takes plus the {params} parameters of the {option} model; measure more poses, or pass --no-register if the positions are in the arm file's frame",
                3 * poses
            ),
        });
    }
    Ok(())
}

/// Gravity in the measurement frame as the arguments give it.
fn gravity(args: &Args, nominal: &Arm<f64>) -> Gravity {
    let g = nominal.gravity_vector().norm();
    match (args.up, args.level_base) {
        (Some(up), _) => {
            Gravity::Measured(up.rotation().inverse() * nalgebra::Vector3::new(0.0, 0.0, -g))
        }
        (None, true) => Gravity::LevelBase(g),
        (None, false) => Gravity::Measured(nominal.gravity_vector()),
    }
}

/// Registers the arm on `all` (the first target's rows; or keeps the file's base with
/// `--no-register`) and prints where it stands.
fn registration(
    args: &Args,
    nominal: &Arm<f64>,
    all: &[crate::dataset::Measurement],
) -> Result<Registration, Error> {
    let gravity = gravity(args, nominal);
    if args.no_register {
        let g = match gravity {
            Gravity::Measured(g) => g,
            Gravity::LevelBase(_) => nominal.gravity_vector(),
        };
        return Ok(Registration::identity(nominal, g));
    }
    let file = args.measurements.display();
    let reg = register(nominal, all, gravity).map_err(|e| match e {
        CalibError::Registration { problem } => CalibError::Registration {
            problem: format!("{file}: {problem}"),
        },
        other => other,
    })?;
    let base = crate::calib::registration::frame_of(&reg.base);
    println!(
        "Registered the arm in the measurement frame: base at ({:.1}, {:.1}, {:.1}) mm, roll {:.2} pitch {:.2} yaw {:.2} deg",
        base.xyz[0] * 1e3,
        base.xyz[1] * 1e3,
        base.xyz[2] * 1e3,
        base.rpy[0].to_degrees(),
        base.rpy[1].to_degrees(),
        base.rpy[2].to_degrees()
    );
    println!(
        "  nominal arm to the measurements: {:.1} mm RMS as the arm file places it, {:.1} mm after registration (largest {:.1} mm)",
        reg.before_rms_m * 1e3,
        reg.after_rms_m * 1e3,
        reg.after_max_m * 1e3
    );
    let mm = |v: [f64; 3]| {
        format!(
            "({:.1}, {:.1}, {:.1}) mm",
            v[0] * 1e3,
            v[1] * 1e3,
            v[2] * 1e3
        )
    };
    match reg.tool {
        Some(tool) => println!(
            "  tool point found with it: {} in frame 6 (the arm file: {}); the fit starts there",
            mm(tool.into()),
            mm(nominal.tool.xyz)
        ),
        None => println!(
            "  tool point: the arm file's {} kept; the last link turns too little to find it (turn {:.2}, {:.1} needed: measure poses that turn the wrist)",
            mm(nominal.tool.xyz),
            reg.tool_turn,
            crate::calib::registration::MIN_TOOL_TURN
        ),
    }
    if !reg.trimmed.is_empty() {
        let named: Vec<String> = reg
            .trimmed
            .iter()
            .map(|(pose, load)| format!("pose {pose} ({load} kg)"))
            .collect();
        println!(
            "  left out of the registration as far off: {}",
            named.join(", ")
        );
    }
    if reg.base_tilt_rad > crate::calib::registration::TILT_WARNING_RAD {
        eprintln!(
            "warning: the registered base is tilted {:.0} deg from up (-gravity {:?} m/s² in the measurement frame); if the arm stands level, give the frame's up axis with --up or pass --level-base",
            reg.base_tilt_rad.to_degrees(),
            reg.gravity.map(|v| (v * 1e3).round() / 1e3).as_slice()
        );
    }
    Ok(reg)
}

/// What the calibration file records of the registration.
fn record(args: &Args, reg: &Registration) -> RegistrationRecord {
    RegistrationRecord {
        registered: !args.no_register,
        frame: crate::calib::registration::frame_of(&reg.frame),
        base: crate::calib::registration::frame_of(&reg.base),
        gravity: reg.gravity.into(),
        before_rms_m: reg.before_rms_m,
        after_rms_m: reg.after_rms_m,
        trimmed: reg.trimmed.iter().map(|(pose, _)| *pose).collect(),
        tool_m: reg.tool.map(Into::into),
    }
}

/// `--tool-only`: fits the tool point of every target of `measurements`
/// (under `load`) with the arm of the calibration at `path` held fixed, and
/// writes that calibration with the new tool points.
fn tool_only(
    args: &Args,
    path: &std::path::Path,
    targets: Targets,
    measurements: &[crate::dataset::Measurement],
    load: f64,
) -> Result<(), Error> {
    let old = CalibrationFile::read(path)?;
    let mut rig = Rig::new(old.arm, targets);
    // A target the old calibration knows starts from where it was.
    for (t, name) in rig.targets.names().iter().enumerate().skip(1) {
        if let Some(known) = old.targets.iter().find(|k| &k.name == name) {
            rig.tools[t - 1] = known.tool_m.into();
        }
    }
    let keys = tool_keys(0..rig.targets.len());
    let options = IdentifyOptions {
        robust: !args.no_robust,
        ..Default::default()
    };
    let fit = identify(&rig, old.option, &keys, measurements, &options)?;
    let mut poses: Vec<u32> = measurements.iter().map(|m| m.pose.id).collect();
    poses.dedup();
    let mut parameters: Vec<_> = old
        .parameters
        .iter()
        .filter(|p| !p.name.starts_with("tool.") && !p.name.starts_with("tool["))
        .cloned()
        .collect();
    parameters.extend(fit.estimates.iter().map(Into::into));
    let cal = CalibrationFile {
        arm: fit.rig.arm,
        parameters,
        poses_used: poses,
        loads_kg: vec![load],
        fit_residual: fit.fit_residual,
        // Every measurement fitted the tool points: none is left to validate on.
        validation: None,
        targets: target_tools(&fit, &[]),
        ..old
    };
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Write {
        path: args.out.clone(),
        source,
    })?;
    let out = args.out.join(format!("calibration-{}.json", cal.option));
    write_text(&out, &cal.to_json())?;
    println!(
        "tool points re-taught from {} measurements with the arm of {} held fixed:",
        measurements.len(),
        path.display()
    );
    print!("{}", summary::targets_table(&cal.targets));
    println!("  wrote {}", out.display());
    Ok(())
}
