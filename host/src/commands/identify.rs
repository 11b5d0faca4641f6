//! `lrmcal identify`: fit the error parameters to a measurement file, from a
//! DETMAX selection of N poses or an explicit pose list, for one model option
//! or all three; validate on the measured poses not used; write the
//! calibration file(s) and a report.

use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressStyle};

use crate::calib::checks::{check_in_candidates, check_plausible};
use crate::calib::detmax::DetmaxOptions;
use crate::calib::export::calibration_file;
use crate::calib::identify::IdentifyOptions;
use crate::calib::pipeline::{
    CandidateBlocks, Choice, MeasurementIndex, OptionResult, calibrate_option,
};
use crate::calib::report::{OptionReport, Report, table};
use crate::calib::validate::{ErrorStats, error_norms};
use crate::calib::{CalibError, ModelOption};
use crate::commands::write_text;
use crate::dataset::{Measurement, Pose};
use crate::error::Error;
use crate::io::arm_source::{ArmSource, DEFAULT_ARM};
use crate::io::calibration_file::ValidationSummary;
use crate::io::{measurements, pose_list};

/// Which options to fit: one, or all three for comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptionChoice {
    /// One option.
    One(ModelOption),
    /// All three.
    All,
}

impl std::str::FromStr for OptionChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "all" {
            Ok(Self::All)
        } else {
            s.parse().map(Self::One).map_err(|e| format!("{e}, or all"))
        }
    }
}

impl OptionChoice {
    /// The options to run.
    pub fn options(self) -> Vec<ModelOption> {
        match self {
            Self::One(o) => vec![o],
            Self::All => ModelOption::ALL.to_vec(),
        }
    }
}

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
    /// Model option: elasto-kinematic, kinematic, elastic or all.
    #[arg(long, default_value = "elasto-kinematic")]
    pub option: OptionChoice,
    /// Load whose measurements the fit uses, kg.
    #[arg(long, value_name = "KG")]
    pub load_kg: Option<f64>,
    /// Down-weight outliers (Huber) and name them.
    #[arg(long)]
    pub robust: bool,
    /// DETMAX random starts.
    #[arg(long, default_value_t = DetmaxOptions::default().starts)]
    pub starts: usize,
    /// Output folder (created if missing).
    #[arg(long, short, value_name = "DIR", default_value = "lrmcal-calibration")]
    pub out: PathBuf,
}

/// The distinct loads of a measurement set, ascending.
pub fn loads_of(rows: &[Measurement]) -> Vec<f64> {
    let mut loads: Vec<f64> = rows.iter().map(|m| m.load_kg).collect();
    loads.sort_by(f64::total_cmp);
    loads.dedup();
    loads
}

/// The distinct poses of a measurement set, in file order.
pub fn poses_of(rows: &[Measurement]) -> Vec<Pose> {
    let mut seen = std::collections::HashSet::new();
    rows.iter()
        .filter(|m| seen.insert(m.pose.id))
        .map(|m| m.pose)
        .collect()
}

/// Runs `lrmcal identify`.
pub fn run(args: &Args) -> Result<(), Error> {
    let loaded = args.arm.load()?;
    let nominal = loaded.arm;
    let file = args.measurements.display().to_string();
    let all = measurements::read(&args.measurements)?;
    if all.is_empty() {
        return Err(CalibError::Empty {
            what: format!("identify from {file}"),
        }
        .into());
    }
    check_plausible(&nominal, &all, &file)?;
    let loads = loads_of(&all);
    let load = match (args.load_kg, loads.as_slice()) {
        (Some(l), _) if loads.contains(&l) => l,
        (Some(l), _) => {
            return Err(CalibError::Ambiguous {
                what: format!("identify under {l} kg: {file} has no measurement with that load (it has {loads:?} kg)"),
            }
            .into());
        }
        (None, [only]) => *only,
        (None, _) => {
            return Err(CalibError::Ambiguous {
                what: format!("choose the load to identify from: {file} has measurements under {loads:?} kg; pass --load-kg"),
            }
            .into());
        }
    };
    if let Some(path) = &args.candidates {
        let candidates: Vec<Pose> = pose_list::read(path)?.into_iter().map(|r| r.pose).collect();
        check_in_candidates(&all, &candidates, &file)?;
    }
    let measured: Vec<Pose> = poses_of(
        &all.iter()
            .filter(|m| m.load_kg == load)
            .copied()
            .collect::<Vec<_>>(),
    );
    let choice = match (&args.select, &args.poses) {
        (Some(n), _) => Choice::Detmax(DetmaxOptions {
            n: *n,
            starts: args.starts,
            ..Default::default()
        }),
        (None, Some(path)) => {
            let list = pose_list::read(path)?;
            let ids: Vec<u32> = list.iter().map(|r| r.pose.id).collect();
            let as_rows: Vec<Measurement> =
                all.iter().filter(|m| m.load_kg == load).copied().collect();
            for r in &list {
                if !as_rows.iter().any(|m| m.pose.id == r.pose.id) {
                    return Err(CalibError::PoseNotInCandidates {
                        pose: r.pose.id,
                        file: path.display().to_string(),
                        detail: format!("{file} has no measurement of it under {load} kg"),
                    }
                    .into());
                }
            }
            Choice::Given(ids)
        }
        (None, None) => Choice::Given(measured.iter().map(|p| p.id).collect()),
    };
    let other = loads.iter().copied().find(|l| *l != load);
    let identify_options = IdentifyOptions {
        robust: args.robust,
        ..Default::default()
    };
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Write {
        path: args.out.clone(),
        source,
    })?;

    let mut results: Vec<OptionResult> = Vec::new();
    // What the arm's structure lets positions identify, over the whole
    // -100/0/+100° grid: the measured poses must identify no less.
    let grid: Vec<Pose> = crate::plan::Levels::paper().grid().collect();
    for option in args.option.options() {
        let structural = CandidateBlocks::build(&nominal, option, &grid, &[load])?
            .identifiability
            .kept;
        let measured_blocks = CandidateBlocks::build(&nominal, option, &measured, &[load])?;
        let kept = &measured_blocks.identifiability.kept;
        if kept.len() < structural.len() {
            let missing: Vec<&str> = structural
                .iter()
                .filter(|p| !kept.contains(p))
                .map(|p| p.name())
                .collect();
            return Err(CalibError::RankDeficient {
                option: option.name().into(),
                rank: kept.len(),
                params: structural.len(),
                weakest: missing.join(", "),
            }
            .into());
        }
        let pb = ProgressBar::new(args.starts as u64);
        if let Ok(style) = ProgressStyle::with_template("{msg:<30} {bar:30} {pos}/{len} {elapsed}")
        {
            pb.set_style(style);
        }
        pb.set_message(format!("{option}: selecting"));
        let r = calibrate_option(
            &nominal,
            option,
            &measured,
            &all,
            load,
            other,
            &choice,
            &identify_options,
            &pb,
        )?;
        pb.finish_and_clear();
        results.push(r);
    }

    let index = MeasurementIndex::new(&all);
    let mut reports = Vec::new();
    for r in &results {
        let used: Vec<u32> = r.selection.poses.iter().map(|p| p.id).collect();
        let fit = index.of(used.iter().copied(), load);
        let cal = calibration_file(
            &nominal,
            &r.identified,
            &r.selection.candidates.identifiability.removed_ids(),
            used,
            vec![load],
            ErrorStats::of(&error_norms(&r.identified.arm, &fit)?),
            r.validation.as_ref().map(|v| ValidationSummary {
                load_kg: load,
                before: v.before,
                after: v.after,
            }),
        );
        let path = args
            .out
            .join(format!("calibration-{}.json", r.selection.option));
        write_text(&path, &cal.to_json())?;
        print_option(r, &path);
        reports.push(OptionReport::new(r, load));
    }
    let report = Report {
        schema: "lrmcal-report",
        schema_version: crate::calib::report::REPORT_SCHEMA_VERSION,
        arm: loaded.origin,
        candidates: measured.len(),
        identify_load_kg: load,
        measurements: serde_json::json!({ "source": file, "loads_kg": loads }),
        options: reports.clone(),
        random_baseline: None,
        o1_vs_poses: Vec::new(),
    };
    write_text(&args.out.join("report.json"), &report.to_json())?;
    println!("\nValidation on the measured poses not used for the fit, {load} kg (mean 3D error):");
    print!("{}", table(&reports));
    println!("wrote {}", args.out.display());
    Ok(())
}

/// Prints what a person checks first about one fit.
fn print_option(r: &OptionResult, path: &Path) {
    let d = &r.identified.diagnostics;
    let ident = &r.selection.candidates.identifiability;
    println!(
        "\n{}: {} parameters ({} removed as unidentifiable), {} poses, O1 {:.4}; {} after {} evaluations, residual RMS {:.3} mm",
        r.selection.option,
        ident.kept.len(),
        ident.removed.len(),
        r.selection.poses.len(),
        r.selection.observability.o1,
        if d.converged {
            "converged"
        } else {
            "NOT converged"
        },
        d.evaluations,
        d.rms_after_m * 1e3
    );
    for line in ident.explain() {
        println!("  removed {line}");
    }
    for e in &r.identified.estimates {
        let std = e
            .std
            .map(|s| format!("± {s:.3e}"))
            .unwrap_or("(held at 0)".into());
        println!("  {:<11} {:+.6e} {std}", e.id.name(), e.error);
    }
    for o in &r.identified.outliers {
        println!(
            "  outlier: pose {} ({} kg), residual {:.2} mm, weight {:.2}",
            o.pose,
            o.load_kg,
            o.residual_m * 1e3,
            o.weight
        );
    }
    println!("  wrote {}", path.display());
}
