//! Cost of the calibration engine on the bundled arm: DETMAX over the ~400
//! planner candidates and over the 5^6 = 15,625-pose grid, how DETMAX grows
//! with the number of candidates and with N, the Jacobian over the
//! candidates, one identification from 50 poses, and the whole demo pipeline
//! (three options plus the reverse cross-load fit).
//!
//! Run: `cargo bench -p lrmcal-engine --bench calibration`.

#![allow(
    missing_docs,
    reason = "the criterion macros generate an undocumented public function"
)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lrmcal_core::dataset::{Measurement, Pose};
use lrmcal_engine::calib::ModelOption;
use lrmcal_engine::calib::analysis::detmax::{DetmaxOptions, detmax};
use lrmcal_engine::calib::fit::identify::{IdentifyOptions, identify};
use lrmcal_engine::calib::fit::pipeline::{CandidateBlocks, Choice, MeasurementIndex, RunSettings};
use lrmcal_engine::calib::progress::Silent;
use lrmcal_engine::calib::run::{Calibration, Request};
use lrmcal_engine::plan::{Levels, PlanConfig, candidates};
use lrmcal_engine::sim::{DEFAULT_SEED, SimConfig, TrueArm};
use model::Arm;

const LOAD: f64 = 0.0663;

fn setup() -> (Arm<f64>, Vec<Pose>, Vec<Measurement>) {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm;
    let poses = candidates(&nominal, &PlanConfig::default())
        .expect("plan")
        .kept;
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::default()).expect("draw");
    let all = truth.measure(&poses, &[0.0, LOAD]).expect("measure");
    (nominal, poses, all)
}

/// One DETMAX start (the demo runs 8), N = 50, elasto-kinematic.
fn one_start(n: usize) -> DetmaxOptions {
    DetmaxOptions {
        n,
        starts: 1,
        ..Default::default()
    }
}

fn benches(c: &mut Criterion) {
    let (nominal, poses, all) = setup();
    let ek = ModelOption::ElastoKinematic;

    let mut g = c.benchmark_group("candidates");
    g.sample_size(10);
    g.bench_function("jacobian_405_candidates_ek", |b| {
        b.iter(|| {
            CandidateBlocks::build(&nominal.into(), ek, black_box(&poses), &[LOAD]).expect("blocks")
        })
    });
    let blocks = CandidateBlocks::build(&nominal.into(), ek, &poses, &[LOAD]).expect("blocks");
    g.bench_function("detmax_405_candidates_n50_one_start", |b| {
        b.iter(|| detmax(black_box(&blocks.blocks), &one_start(50), &Silent).expect("detmax"))
    });
    for n in [25, 50, 100] {
        g.bench_with_input(
            BenchmarkId::new("detmax_405_candidates_one_start_n", n),
            &n,
            |b, &n| b.iter(|| detmax(&blocks.blocks, &one_start(n), &Silent).expect("detmax")),
        );
    }
    g.finish();

    let mut g = c.benchmark_group("grid");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for levels in [3, 4, 5] {
        let grid: Vec<Pose> = Levels::even(levels).expect("levels").grid(6).collect();
        let grid_blocks =
            CandidateBlocks::build(&nominal.into(), ek, &grid, &[LOAD]).expect("blocks");
        g.bench_with_input(
            BenchmarkId::new("detmax_grid_candidates_n50_one_start", grid.len()),
            &grid_blocks,
            |b, gb| b.iter(|| detmax(&gb.blocks, &one_start(50), &Silent).expect("detmax")),
        );
    }
    g.finish();

    let mut g = c.benchmark_group("identify");
    g.sample_size(10);
    let design = detmax(&blocks.blocks, &DetmaxOptions::default(), &Silent).expect("detmax");
    let ids: Vec<u32> = design.chosen.iter().map(|&i| poses[i].id).collect();
    let fit = MeasurementIndex::new(&all).of(ids, LOAD);
    let kept = blocks.identifiability.kept.clone();
    g.bench_function("identify_ek_50_poses", |b| {
        b.iter(|| {
            identify(
                &nominal.into(),
                ek,
                &kept,
                black_box(&fit),
                &IdentifyOptions::default(),
            )
            .expect("fit")
        })
    });
    g.finish();

    let mut g = c.benchmark_group("pipeline");
    g.sample_size(10).measurement_time(Duration::from_secs(40));
    g.bench_function("demo_three_options_and_reverse_cross_load", |b| {
        b.iter(|| {
            let calibration =
                Calibration::open(&Request::new(&nominal, &all).load(LOAD)).expect("open");
            let run = |option, load, other| {
                let settings = RunSettings {
                    identify_load_kg: load,
                    other_load_kg: Some(other),
                    choice: Choice::Detmax(DetmaxOptions::default()),
                    identify: IdentifyOptions::default(),
                };
                calibration
                    .option(option, &settings, &Silent)
                    .expect("calibrate")
            };
            for option in ModelOption::ALL {
                black_box(run(option, LOAD, 0.0));
            }
            black_box(run(ek, 0.0, LOAD))
        })
    });
    g.finish();
}

criterion_group!(calibration, benches);
criterion_main!(calibration);
