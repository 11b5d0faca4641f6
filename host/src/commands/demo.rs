//! `lrmcal demo`: the whole method on the bundled arm with no files of your
//! own: plan the candidates, simulate a true arm measured under no load and
//! 66.3 g, select 50 poses per option with DETMAX, identify, validate on the
//! rest, check across loads, compare with random selections, and write the
//! calibrations, the report and the plots to one folder.

use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

use crate::calib::ModelOption;
use crate::calib::detmax::{DetmaxOptions, detmax, random_design};
use crate::calib::export::calibration_file;
use crate::calib::identify::{IdentifyOptions, identify};
use crate::calib::pipeline::{
    CandidateBlocks, Choice, MeasurementIndex, OptionResult, calibrate_option,
};
use crate::calib::plots::{self, Distribution, Series};
use crate::calib::report::{OptionReport, RandomBaseline, Report, table};
use crate::calib::validate::{ErrorStats, Validation, validate};
use crate::commands::write_text;
use crate::dataset::Measurement;
use crate::error::Error;
use crate::io::arm_source::{ArmSource, DEFAULT_ARM};
use crate::io::calibration_file::ValidationSummary;
use crate::io::measurements;
use crate::plan::{PlanConfig, candidates};
use crate::sim::{DEFAULT_SEED, SimConfig, TrueArm};

/// The paper's payload, kg.
const PAPER_LOAD_KG: f64 = 0.0663;

/// Run the whole calibration on a simulated arm and write everything it produces.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal demo\n  \
lrmcal demo --out my-demo --seed 7\n  \
lrmcal demo --model-only      # no unmodelled effects, no noise: a consistency check\n\n\
Writes to the output folder: measurements.csv (every candidate under both loads), \
truth.json (the simulated true arm), calibration-<option>.json (one per option, the file \
the firmware receives), report.json, and the plots errors.svg/png (validation error \
per option), errors-cross-load.svg/png, per-pose.svg/png and o1-vs-poses.svg/png.")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, or an arm description `.toml` file.
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Seed of the simulated true arm.
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Poses to select per option.
    #[arg(long, default_value_t = 50)]
    pub poses: usize,
    /// DETMAX random starts per option.
    #[arg(long, default_value_t = DetmaxOptions::default().starts)]
    pub starts: usize,
    /// Random 50-pose selections to compare DETMAX with (elasto-kinematic); 0 skips it.
    #[arg(long, default_value_t = 20)]
    pub compare_random: usize,
    /// Switch off every effect the model lacks and the tracker noise.
    #[arg(long)]
    pub model_only: bool,
    /// Down-weight outliers (Huber) in the fits.
    #[arg(long)]
    pub robust: bool,
    /// Output folder (created if missing).
    #[arg(long, short, value_name = "DIR", default_value = "lrmcal-demo")]
    pub out: PathBuf,
}

fn bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template("{msg:<40} {bar:30} {pos}/{len} {elapsed}") {
        pb.set_style(style);
    }
    pb.set_message(what.to_owned());
    pb
}

/// Runs `lrmcal demo`.
pub fn run(args: &Args) -> Result<(), Error> {
    let started = Instant::now();
    let loaded = args.arm.load()?;
    let nominal = loaded.arm;
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Write {
        path: args.out.clone(),
        source,
    })?;

    let plan =
        candidates(&nominal, &PlanConfig::default()).map_err(|source| Error::Plan { source })?;
    let poses = plan.kept;
    let config = if args.model_only {
        SimConfig::model_only()
    } else {
        SimConfig::default()
    };
    let truth =
        TrueArm::draw(&nominal, args.seed, &config).map_err(|source| Error::Simulate { source })?;
    let loads = [0.0, PAPER_LOAD_KG];
    let all = truth
        .measure(&poses, &loads)
        .map_err(|source| Error::Simulate { source })?;
    measurements::write(&args.out.join("measurements.csv"), &all)?;
    write_text(&args.out.join("truth.json"), &truth.truth_json())?;
    println!(
        "{} candidate poses of {} (grid filtered by joint limits and collisions); true arm seed {}{}",
        poses.len(),
        plan.grid_size,
        args.seed,
        if args.model_only {
            ", model-only (no unmodelled effects, no noise)"
        } else {
            ", unmodelled effects on"
        }
    );

    let detmax_options = DetmaxOptions {
        n: args.poses,
        starts: args.starts,
        ..Default::default()
    };
    let identify_options = IdentifyOptions {
        robust: args.robust,
        ..Default::default()
    };
    let mut results: Vec<OptionResult> = Vec::new();
    for option in ModelOption::ALL {
        let pb = bar(
            detmax_options.starts as u64,
            &format!("{option}: DETMAX starts"),
        );
        let r = calibrate_option(
            &nominal,
            option,
            &poses,
            &all,
            PAPER_LOAD_KG,
            Some(0.0),
            &Choice::Detmax(detmax_options),
            &identify_options,
            &pb,
        )?;
        pb.finish_and_clear();
        if r.validation.is_none() {
            return Err(no_held_out());
        }
        results.push(r);
    }
    // The other direction of the cross-load check: fit without load, validate with it.
    let pb = bar(
        detmax_options.starts as u64,
        "elasto-kinematic (no-load fit): DETMAX",
    );
    let reverse = calibrate_option(
        &nominal,
        ModelOption::ElastoKinematic,
        &poses,
        &all,
        0.0,
        Some(PAPER_LOAD_KG),
        &Choice::Detmax(detmax_options),
        &identify_options,
        &pb,
    )?;
    pb.finish_and_clear();

    let mut reports: Vec<OptionReport> = results
        .iter()
        .map(|r| OptionReport::new(r, PAPER_LOAD_KG))
        .collect();
    let reverse_report = OptionReport::new(&reverse, 0.0);
    let ek = results
        .iter()
        .find(|r| r.selection.option == ModelOption::ElastoKinematic)
        .ok_or_else(|| crate::calib::CalibError::Empty {
            what: "run the elasto-kinematic option".into(),
        })?;

    let baseline = if args.compare_random > 0 {
        Some(random_baseline(
            &nominal,
            &poses,
            &all,
            ek,
            args.compare_random,
            &identify_options,
        )?)
    } else {
        None
    };
    let o1_curve = o1_vs_poses(&nominal, &poses)?;

    for (r, rep) in results.iter().zip(&reports) {
        let validation = held_out(r)?;
        let file = calibration_file(
            &nominal,
            &r.identified,
            &r.selection.candidates.identifiability.removed_ids(),
            rep.selected_poses.clone(),
            vec![PAPER_LOAD_KG],
            fit_residual(&r.identified.arm, &all, &rep.selected_poses)?,
            Some(ValidationSummary {
                load_kg: PAPER_LOAD_KG,
                before: validation.before,
                after: validation.after,
            }),
        );
        write_text(
            &args
                .out
                .join(format!("calibration-{}.json", r.selection.option)),
            &file.to_json(),
        )?;
    }
    reports.push(reverse_report.clone());
    let report = Report {
        schema: "lrmcal-report",
        schema_version: crate::calib::report::REPORT_SCHEMA_VERSION,
        arm: loaded.origin.clone(),
        candidates: poses.len(),
        identify_load_kg: PAPER_LOAD_KG,
        measurements: serde_json::json!({
            "source": "simulated",
            "seed": args.seed,
            "loads_kg": loads,
            "config": config,
        }),
        options: reports.clone(),
        random_baseline: baseline.clone(),
        o1_vs_poses: o1_curve.clone(),
    };
    write_text(&args.out.join("report.json"), &report.to_json())?;
    let plot_files = write_plots(&args.out, &results, &o1_curve)?;

    println!(
        "\nValidation on the {} poses not selected, {} kg load (mean 3D error):",
        held_out(ek)?.before.count,
        PAPER_LOAD_KG
    );
    print!("{}", table(&reports[..results.len()]));
    println!(
        "cross-load: fitted without load, validated with {PAPER_LOAD_KG} kg: {:.2} -> {:.2} mm ({:.1} %)",
        reverse
            .cross_load
            .as_ref()
            .map(|c| c.1.before.mean_m * 1e3)
            .unwrap_or(f64::NAN),
        reverse
            .cross_load
            .as_ref()
            .map(|c| c.1.after.mean_m * 1e3)
            .unwrap_or(f64::NAN),
        reverse
            .cross_load
            .as_ref()
            .map(|c| c.1.reduction_pct)
            .unwrap_or(f64::NAN),
    );
    let ident = &ek.selection.candidates.identifiability;
    println!(
        "\nelasto-kinematic: {} of 43 parameters identifiable; removed: {}",
        ident.kept.len(),
        ident.explain().join("; ")
    );
    println!(
        "O1 of the 50 selected poses: {:.4} (elasto-kinematic)",
        ek.selection.observability.o1
    );
    if let Some(b) = &baseline {
        println!(
            "DETMAX vs {} random {}-pose sets: O1 {:.4} vs median {:.4}; validation mean {:.2} vs median {:.2} mm",
            b.sets,
            args.poses,
            b.detmax_o1,
            b.random_o1_median,
            b.detmax_mean_m * 1e3,
            b.random_mean_median_m * 1e3
        );
    }
    for o in &ek.identified.outliers {
        println!(
            "outlier: pose {} ({} kg), residual {:.2} mm",
            o.pose,
            o.load_kg,
            o.residual_m * 1e3
        );
    }
    println!(
        "\nwrote {} (calibration-*.json, report.json, measurements.csv, truth.json, {} plots) in {:.1} s",
        args.out.display(),
        plot_files.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn no_held_out() -> Error {
    crate::calib::CalibError::Empty {
        what: "validate: every candidate was selected, none is left to validate on".into(),
    }
    .into()
}

/// The held-out validation of a demo run (always present: checked after each run).
fn held_out(r: &OptionResult) -> Result<&Validation, Error> {
    r.validation.as_ref().ok_or_else(no_held_out)
}

/// The 3D error of `arm` on the measurements it was fitted to.
fn fit_residual(
    arm: &model::Arm<f64>,
    all: &[Measurement],
    poses: &[u32],
) -> Result<ErrorStats, Error> {
    let fit = MeasurementIndex::new(all).of(poses.iter().copied(), PAPER_LOAD_KG);
    Ok(ErrorStats::of(&crate::calib::validate::error_norms(
        arm, &fit,
    )?))
}

/// Identifies from random selections of the same size as DETMAX's and compares.
fn random_baseline(
    nominal: &model::Arm<f64>,
    poses: &[crate::dataset::Pose],
    all: &[Measurement],
    ek: &OptionResult,
    sets: usize,
    options: &IdentifyOptions,
) -> Result<RandomBaseline, Error> {
    let index = MeasurementIndex::new(all);
    let ids = &ek.selection.candidates.identifiability.kept;
    let n = ek.selection.poses.len();
    let pb = bar(sets as u64, "random selections: identify + validate");
    let mut o1s = Vec::new();
    let mut means = Vec::new();
    for s in 0..sets {
        let chosen = random_design(poses.len(), n, 1000 + s as u64);
        o1s.push(ek.selection.candidates.observability(&chosen).o1);
        let chosen_ids: Vec<u32> = chosen.iter().map(|&c| poses[c].id).collect();
        let fit = index.of(chosen_ids.iter().copied(), PAPER_LOAD_KG);
        let rest = index.of(
            poses
                .iter()
                .map(|p| p.id)
                .filter(|id| !chosen_ids.contains(id)),
            PAPER_LOAD_KG,
        );
        // A random set may be rank deficient: that is a loss for random selection.
        let mean = match identify(nominal, ModelOption::ElastoKinematic, ids, &fit, options) {
            Ok(f) => validate(nominal, &f.arm, &rest)?.after.mean_m,
            Err(_) => f64::INFINITY,
        };
        means.push(mean);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok(RandomBaseline {
        option: ModelOption::ElastoKinematic,
        sets,
        detmax_o1: ek.selection.observability.o1,
        random_o1_median: median(o1s),
        detmax_mean_m: held_out(ek)?.after.mean_m,
        random_mean_median_m: median(means),
    })
}

/// O1 of DETMAX selections of several sizes, per option (loaded samples).
fn o1_vs_poses(
    nominal: &model::Arm<f64>,
    poses: &[crate::dataset::Pose],
) -> Result<Vec<(ModelOption, usize, f64)>, Error> {
    let mut out = Vec::new();
    let sizes = [10, 15, 20, 30, 40, 50, 60, 80, 100];
    let pb = bar(
        (ModelOption::ALL.len() * sizes.len()) as u64,
        "O1 against the number of poses",
    );
    for option in ModelOption::ALL {
        let blocks = CandidateBlocks::build(nominal, option, poses, &[PAPER_LOAD_KG])?;
        let m = blocks.identifiability.kept.len();
        for n in sizes {
            pb.inc(1);
            if 3 * n < m + 3 || n > poses.len() {
                continue;
            }
            let d = detmax(
                &blocks.blocks,
                &DetmaxOptions {
                    n,
                    starts: 2,
                    ..Default::default()
                },
                &ProgressBar::hidden(),
            )?;
            out.push((option, n, blocks.observability(&d.chosen).o1));
        }
    }
    pb.finish_and_clear();
    Ok(out)
}

/// Writes the demo's figures; returns the files written.
fn write_plots(
    dir: &Path,
    results: &[OptionResult],
    o1: &[(ModelOption, usize, f64)],
) -> Result<Vec<PathBuf>, Error> {
    let mm = |v: Vec<f64>| v.into_iter().map(|x| x * 1e3).collect::<Vec<_>>();
    let mut files = Vec::new();
    let boxes_for = |cross: bool| {
        let mut boxes = Vec::new();
        if let Some(first) = results.first() {
            let v = if cross {
                first.cross_load.as_ref().map(|c| &c.1)
            } else {
                first.validation.as_ref()
            };
            if let Some(v) = v {
                boxes.push(Distribution {
                    label: "uncalibrated".into(),
                    values_mm: mm(v.per_measurement.iter().map(|p| p.2).collect()),
                });
            }
        }
        for r in results {
            let v = if cross {
                r.cross_load.as_ref().map(|c| &c.1)
            } else {
                r.validation.as_ref()
            };
            if let Some(v) = v {
                boxes.push(Distribution {
                    label: r.selection.option.name().into(),
                    values_mm: mm(v.per_measurement.iter().map(|p| p.3).collect()),
                });
            }
        }
        boxes
    };
    files.extend(plots::error_distribution(
        &dir.join("errors"),
        &format!("Validation error, {PAPER_LOAD_KG} kg, poses not used for identification"),
        &boxes_for(false),
    )?);
    files.extend(plots::error_distribution(
        &dir.join("errors-cross-load"),
        &format!("Cross-load: identified with {PAPER_LOAD_KG} kg, validated without load"),
        &boxes_for(true),
    )?);
    if let Some(ek) = results
        .iter()
        .find(|r| r.selection.option == ModelOption::ElastoKinematic)
    {
        let pts = |f: fn(&(u32, f64, f64, f64)) -> f64| {
            held_out(ek)
                .map(|v| v.per_measurement.as_slice())
                .unwrap_or_default()
                .iter()
                .map(|p| (p.0 as f64, f(p) * 1e3))
                .collect::<Vec<_>>()
        };
        files.extend(plots::xy(
            &dir.join("per-pose"),
            "Error per validation pose (elasto-kinematic)",
            "pose id",
            "3D error norm (mm)",
            &[
                Series {
                    label: "uncalibrated".into(),
                    points: pts(|p| p.2),
                },
                Series {
                    label: "calibrated".into(),
                    points: pts(|p| p.3),
                },
            ],
            false,
        )?);
    }
    let series: Vec<Series> = ModelOption::ALL
        .iter()
        .map(|o| Series {
            label: o.name().into(),
            points: o1
                .iter()
                .filter(|(opt, _, _)| opt == o)
                .map(|(_, n, v)| (*n as f64, *v))
                .collect(),
        })
        .collect();
    files.extend(plots::xy(
        &dir.join("o1-vs-poses"),
        "O1 of DETMAX selections",
        "number of poses",
        "O1",
        &series,
        true,
    )?);
    Ok(files)
}
