//! `lrmcal identify`: fit the error parameters to a measurement file, from a
//! DETMAX selection of N poses or an explicit pose list, for one model option
//! or all three; validate on the measured poses not used; write the
//! calibration file(s) and a report.

use std::path::PathBuf;

use crate::calib::checks::{
    check_in_candidates, check_measured, check_plausible, identification_load,
};
use crate::calib::detmax::DetmaxOptions;
use crate::calib::export::calibration_file;
use crate::calib::identifiability::check_structure;
use crate::calib::identify::IdentifyOptions;
use crate::calib::pipeline::{CandidateBlocks, Choice, Inputs, RunSettings, calibrate_blocks};
use crate::calib::report::Report;
use crate::calib::{CalibError, summary};
use crate::commands::helpers::write_text;
use crate::commands::helpers::{Bar, OptionChoice};
use crate::dataset::{Pose, loads_of, poses_under};
use crate::error::Error;
use crate::io::arm_source::{ArmSource, DEFAULT_ARM};
use crate::io::calibration_file::ValidationSummary;
use crate::io::{measurements, pose_list};

/// Identify the arm's error parameters from measured tool positions.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal identify --measurements m.csv --select 50 --out cal\n  \
lrmcal identify --measurements m.csv --poses selection.csv --option all --out cal\n  \
lrmcal identify --measurements m.csv --load-kg 0.0663 --candidates candidates.csv --robust\n\n\
The fit uses the measurements under one load (--load-kg; the file's only load by default). \
With --select N, DETMAX picks N of the measured poses (D-optimal for the option); with \
--poses, the list's poses are used; with neither, every measured pose is. Measured poses \
not used for the fit validate it, under every load in the file. Writes \
calibration-<option>.json (the file `lrmcal push` sends to the board) and report.json.")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, or an arm description `.toml` file.
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Measurement CSV (`pose,load_kg,q1_deg..q6_deg,x_mm,y_mm,z_mm`).
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
    /// Model option: elasto-kinematic-servo (each servo's own curve too),
    /// elasto-kinematic, kinematic, elastic (the paper's three) or all.
    #[arg(long, default_value = "elasto-kinematic-servo")]
    pub option: OptionChoice,
    /// Load whose measurements the fit uses, kg.
    #[arg(long, value_name = "KG")]
    pub load_kg: Option<f64>,
    /// Down-weight outliers (Huber) and name them.
    #[arg(long)]
    pub robust: bool,
    /// Fit measured poses outside the arm's joint limits too (with a warning)
    /// instead of refusing the file.
    #[arg(long)]
    pub allow_outside_limits: bool,
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
    check_plausible(&nominal, &all, &file)?;
    let loads = loads_of(&all);
    let load = identification_load(&loads, args.load_kg, &file)?;
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
            robust: args.robust,
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
        let blocks = CandidateBlocks::build(&nominal, option, &measured, &[load])?;
        // The measured poses must identify what positions can reveal on this arm at all.
        check_structure(&nominal, &blocks.identifiability, load)?;
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
        let cal = calibration_file(
            &nominal,
            &r.identified,
            &r.selection.candidates.identifiability.removed_ids(),
            r.pose_ids(),
            vec![load],
            r.identified.fit_residual,
            r.validation.as_ref().map(|v| ValidationSummary {
                load_kg: load,
                before: v.before,
                after: v.after,
            }),
        );
        let path = args.out.join(format!("calibration-{}.json", r.option()));
        write_text(&path, &cal.to_json())?;
        println!("\n{}", summary::option_details(details));
        println!("  wrote {}", path.display());
    }
    write_text(&args.out.join("report.json"), &report.to_json())?;
    println!("\nValidation on the measured poses not used for the fit, {load} kg (mean 3D error):");
    print!("{}", summary::table(&report.options));
    println!("wrote {}", args.out.display());
    Ok(())
}
