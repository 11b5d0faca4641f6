//! How fast the calibration engine is on large candidate pools,
//! in plain figures (each the median of a few runs, wall clock, on every
//! core the machine has):
//!
//! - the identification Jacobian per pose: exact against central differences
//!   (2 × 43 model evaluations), at the rigid nominal arm (as the candidates'
//!   analysis sees it) and at a compliant one (as the fit sees it);
//! - the pool `plan --levels 5` (5^6 = 15,625 grid poses, filtered by limits
//!   and collisions): the candidates' analysis (Jacobian, rank analysis,
//!   column scale), DETMAX for 60 poses (8 starts) and the fit of those 60
//!   poses as the pipeline makes it (backlash widths, refresh, and for ours
//!   the knot spacing's choice), and their sum, for the paper's model and
//!   for ours;
//! - the whole `lrmcal demo` (the release binary, default arguments);
//! - the camera: detecting the tags of one rendered 1280 × 720 webcam image
//!   (one core), and, on the views `lrmcal demo --camera` planned and
//!   rendered (60 poses × 2 loads), `lrmcal detect` and `lrmcal identify
//!   --camera` through the release binary.
//!
//! Run: `cargo bench -p host --bench speed` (the README's performance
//! section quotes it); `-- jacobian`, `-- pool`, `-- demo` or `-- camera`
//! runs one part.

#![allow(missing_docs, reason = "a benchmark binary")]

use std::hint::black_box;
use std::process::Command;
use std::time::{Duration, Instant};

use lrmcal_core::dataset::Pose;
use lrmcal_engine::calib::analysis::detmax::{DetmaxOptions, detmax};
use lrmcal_engine::calib::analysis::jacobian::jacobian;
use lrmcal_engine::calib::fit::grow::grow;
use lrmcal_engine::calib::fit::identify::IdentifyOptions;
use lrmcal_engine::calib::fit::pipeline::CandidateBlocks;
use lrmcal_engine::calib::parameters::params::Key as _;
use lrmcal_engine::calib::{ModelOption, ParamKey, Rig, Sample};
use lrmcal_engine::plan::{Levels, PlanConfig, candidates};
use lrmcal_engine::sim::{DEFAULT_SEED, SimConfig, TrueArm};
use model::params::ParamKind;

const LOAD: f64 = 0.0663;

/// Median wall-clock time of `runs` calls of `f`.
fn median_time<T>(runs: usize, mut f: impl FnMut() -> T) -> Duration {
    let mut times: Vec<Duration> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            black_box(f());
            start.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// Central differences of the model over `ids`, the way the identification
/// Jacobian was computed before it was exact.
fn central_differences(rig: &Rig, ids: &[ParamKey], samples: &[Sample]) -> Vec<f64> {
    let mut out = Vec::with_capacity(3 * samples.len() * ids.len());
    for &id in ids {
        let typical = match id.kind() {
            ParamKind::Length | ParamKind::Compliance => 0.1,
            ParamKind::Angle => 1.0,
        };
        let h = f64::EPSILON.cbrt() * id.value(rig).abs().max(typical);
        let at = |delta: f64| {
            let mut r = rig.clone();
            *id.slot(&mut r) += delta;
            r.tool_points(samples).expect("deflects")
        };
        let (up, down) = (at(h), at(-h));
        out.extend(
            up.iter()
                .zip(&down)
                .flat_map(|(u, d)| ((u - d) / (2.0 * h)).iter().copied().collect::<Vec<_>>()),
        );
    }
    out
}

fn main() {
    // Parts named on the command line (cargo adds `--bench`), or all.
    let named: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let run = |part: &str| named.is_empty() || named.iter().any(|n| n == part);
    let nominal = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm;
    if run("jacobian") {
        jacobian_per_pose(&nominal);
    }
    if run("pool") {
        pool(&nominal);
    }
    if run("demo") {
        demo();
    }
    if run("camera") {
        camera();
    }
}

fn jacobian_per_pose(nominal: &model::Arm<f64>) {
    let nominal = *nominal;
    let all_ids: Vec<ParamKey> = model::ParamId::all(6).map(ParamKey::Arm).collect();

    println!("identification Jacobian per pose, 43 parameters, one load:");
    let pool_small = candidates(&nominal, &PlanConfig::default())
        .expect("plan")
        .kept;
    let samples: Vec<Sample> = pool_small
        .iter()
        .take(200)
        .map(|p| Sample {
            id: p.id,
            q: p.q,
            load_kg: LOAD,
            target: 0,
            approach: lrmcal_core::dataset::from_home(6),
        })
        .collect();
    let mut compliant = nominal;
    compliant.base_compliance = 0.02;
    for j in &mut compliant.joints {
        j.compliance = 0.1;
    }
    for (name, arm) in [("rigid nominal", nominal), ("compliant", compliant)] {
        let rig = Rig::from(arm);
        let per_pose = |d: Duration| d / samples.len() as u32;
        let exact = median_time(5, || jacobian(&rig, &all_ids, &samples).expect("jacobian"));
        // The exact Jacobian on one core, to compare like with like.
        let one_core = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        let exact_1 = one_core
            .install(|| median_time(5, || jacobian(&rig, &all_ids, &samples).expect("jacobian")));
        let differences = median_time(3, || central_differences(&rig, &all_ids, &samples));
        println!(
            "  {name:13}: exact {:.1} µs ({:.1} µs on one core), central differences {:.1} µs: {:.0}x",
            per_pose(exact).as_secs_f64() * 1e6,
            per_pose(exact_1).as_secs_f64() * 1e6,
            per_pose(differences).as_secs_f64() * 1e6,
            differences.as_secs_f64() / exact_1.as_secs_f64()
        );
    }
}

fn pool(nominal: &model::Arm<f64>) {
    let nominal = *nominal;
    let config = PlanConfig {
        levels: Levels::even(5).expect("levels"),
        ..PlanConfig::default()
    };
    let plan = candidates(&nominal, &config).expect("plan");
    let pool: Vec<Pose> = plan.kept;
    println!(
        "pool: plan --levels 5, {} of {} grid poses kept (limits, collisions)",
        pool.len(),
        plan.grid_size
    );
    let rig = Rig::from(nominal);
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::default()).expect("draw");
    let detmax_options = DetmaxOptions {
        n: 60,
        ..DetmaxOptions::default()
    };
    for option in [
        ModelOption::ElastoKinematic,
        lrmcal_engine::calib::parameters::option::DEFAULT,
    ] {
        let runs = 3;
        let mut rows: Vec<[Duration; 3]> = Vec::new();
        for _ in 0..runs {
            let start = Instant::now();
            let blocks = CandidateBlocks::build(&rig, option, &pool, &[LOAD]).expect("blocks");
            let analysed = start.elapsed();
            let start = Instant::now();
            let design = detmax(
                &blocks.blocks,
                &detmax_options,
                &lrmcal_engine::calib::progress::Silent,
            )
            .expect("detmax");
            let selected = start.elapsed();
            let poses: Vec<Pose> = design.chosen.iter().map(|&c| pool[c]).collect();
            let measured = truth.measure(&poses, &[LOAD]).expect("measure");
            let start = Instant::now();
            black_box(
                grow(
                    &rig,
                    option,
                    &blocks.identifiability.kept,
                    &measured,
                    &IdentifyOptions::default(),
                )
                .expect("fit"),
            );
            rows.push([analysed, selected, start.elapsed()]);
        }
        rows.sort_by_key(|r| r.iter().sum::<Duration>());
        let [analysed, selected, fitted] = rows[rows.len() / 2];
        println!(
            "  {}: candidates' analysis {}, DETMAX (60 poses, {} starts) {}, fit of the 60 {}: {} in all",
            option.name(),
            ms(analysed),
            detmax_options.starts,
            ms(selected),
            ms(fitted),
            ms(analysed + selected + fitted)
        );
    }
}

fn demo() {
    let out = tempfile::tempdir().expect("temporary folder");
    let demo = median_time(3, || {
        let status = Command::new(env!("CARGO_BIN_EXE_lrmcal"))
            .args(["demo", "--out"])
            .arg(out.path())
            .output()
            .expect("lrmcal demo runs");
        assert!(status.status.success(), "lrmcal demo failed");
    });
    println!(
        "whole lrmcal demo (release binary): {:.2} s",
        demo.as_secs_f64()
    );
}

fn camera() {
    use lrmcal_core::camera::{bundled, setup};
    use lrmcal_engine::camera::detect::{Grey, TagDetector};
    use lrmcal_engine::sim::Webcam;
    use lrmcal_engine::sim::render::Look;

    let out = tempfile::tempdir().expect("temporary folder");
    let dir = out.path();
    let lrmcal = |args: &[&str]| {
        let run = Command::new(env!("CARGO_BIN_EXE_lrmcal"))
            .args(args)
            .current_dir(dir)
            .output()
            .expect("lrmcal runs");
        assert!(run.status.success(), "lrmcal {args:?} failed");
    };
    lrmcal(&["demo", "--camera", "--out", "."]);

    // One image of the board at the setup's first seen pose, as the webcam takes it.
    let setup = setup::read(&dir.join(bundled::SETUP_FILE)).expect("the demo's setup");
    let webcam = Webcam::draw(&setup, DEFAULT_SEED, 0.0);
    let rig = Rig::from(
        lrmcal_core::io::arm_source::bundled("lrm")
            .expect("bundled arm")
            .arm,
    );
    let seen = lrmcal_core::io::pose_list::read(&dir.join("selection.csv")).expect("selection");
    let sample = Sample {
        id: seen[0].pose.id,
        q: seen[0].pose.q,
        load_kg: 0.0,
        target: 0,
        approach: lrmcal_core::dataset::from_home(6),
    };
    let flange = rig
        .evaluate(&sample)
        .expect("the pose")
        .deflection
        .frames
        .frames
        .last_value();
    let pixels = webcam.image(0, &flange, &Look::WEBCAM);
    let mut detector = TagDetector::new().expect("detector");
    let grey = Grey {
        width: setup.intrinsics.width_px,
        height: setup.intrinsics.height_px,
        pixels: &pixels,
    };
    let found = detector.detect(grey, &setup.board).expect("detection");
    let detect_one = median_time(20, || detector.detect(grey, &setup.board));
    println!(
        "camera: tag detection in one 1280 x 720 image ({} tags): {}",
        found.tags.len(),
        ms(detect_one)
    );
    let detect = median_time(3, || {
        lrmcal(&[
            "detect",
            "--images",
            "images",
            "--board",
            "board.yaml",
            "--intrinsics",
            "camera_info.yaml",
            "--poses",
            "images/poses.csv",
            "--out",
            "views.csv",
        ])
    });
    let identify = median_time(3, || {
        lrmcal(&[
            "identify",
            "--camera",
            "setup.toml",
            "--measurements",
            "views.csv",
            "--load-kg",
            "0.0663",
            "--out",
            "cal",
        ])
    });
    println!(
        "camera: lrmcal detect of demo --camera's images (60 poses x 2 loads, the ones the camera saw): {:.2} s; \
         identify --camera of them: {:.2} s; both: {:.2} s",
        detect.as_secs_f64(),
        identify.as_secs_f64(),
        (detect + identify).as_secs_f64()
    );
}
