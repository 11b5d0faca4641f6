//! The calibration engine end to end on the bundled arm and the simulator:
//! the consistency check (exact data in, exact parameters out), the demo's
//! claims on the seeds where each holds, and DETMAX against random selection.

use lrmcal_core::dataset::{Measurement, Pose, from_home};
use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::identify::{IdentifyOptions, identify};
use lrmcal_engine::calib::fit::pipeline::{Choice, Inputs, OptionResult, RunSettings};
use lrmcal_engine::calib::fit::validate::validate;
use lrmcal_engine::calib::progress::Silent;
use lrmcal_engine::calib::results::experiments::{
    grid_and_off_grid, outlier_trial, random_baseline,
};
use lrmcal_engine::calib::results::report::IdentifiabilityReport;
use lrmcal_engine::calib::run::{Calibration, Request};
use lrmcal_engine::calib::{ModelOption, ParamKey, ParamVector, Sample};
use lrmcal_engine::plan::{PlanConfig, candidates};
use lrmcal_engine::sim::{DEFAULT_SEED, SimConfig, TrueArm};
use model::Arm;

const LOAD: f64 = 0.0663;

/// DETMAX selection of 50 poses, fitted under `load`, validated across under `other`.
fn settings(load: f64, other: Option<f64>, starts: usize) -> RunSettings {
    RunSettings {
        identify_load_kg: load,
        other_load_kg: other,
        choice: Choice::Detmax(DetmaxOptions {
            starts,
            ..Default::default()
        }),
        identify: IdentifyOptions::default(),
    }
}

fn bundled() -> Arm<f64> {
    lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm
}

fn candidate_poses(nominal: &Arm<f64>) -> Vec<Pose> {
    candidates(nominal, &PlanConfig::default())
        .expect("plan")
        .kept
}

fn exact_measurements(arm: &Arm<f64>, poses: &[Pose], loads: &[f64]) -> Vec<Measurement> {
    let samples: Vec<Sample> = loads
        .iter()
        .flat_map(|&load_kg| {
            poses.iter().map(move |p| Sample {
                id: p.id,
                q: p.q,
                load_kg,
                target: 0,
                approach: from_home(6),
            })
        })
        .collect();
    lrmcal_engine::calib::Rig::from(*arm)
        .tool_points(&samples)
        .expect("model")
        .into_iter()
        .zip(&samples)
        .map(|(position, s)| Measurement {
            pose: Pose { id: s.id, q: s.q },
            load_kg: s.load_kg,
            position,
            pixel: None,
            target: None,
            approach: s.approach,
        })
        .collect()
}

/// Consistency: a true arm whose errors lie in the identifiable set, measured
/// without noise or unmodelled effects, is recovered to 1e-6 (SI units) and
/// predicts the held-out poses to better than 0.01 mm, for every option.
#[test]
fn exact_data_gives_exact_parameters() {
    let nominal = bundled();
    let poses = candidate_poses(&nominal);
    let drawn = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::model_only()).expect("draw");
    for option in ModelOption::ALL {
        // The identifiable set of this option decides which errors the truth may carry.
        let probe = exact_measurements(&nominal, &poses, &[LOAD]);
        let first = Calibration::open(&Request::new(&nominal, &probe))
            .and_then(|c| c.option(option, &settings(LOAD, None, 2), &Silent))
            .expect("calibrate");
        let kept = first.selection.candidates.identifiability.kept.clone();
        let mut truth = ParamVector::new(kept.iter().copied()).expect("distinct keys");
        for (id, error) in drawn.named_errors() {
            if truth.get(id.into()).is_some() {
                truth.set(id.into(), error).expect("held key");
            }
        }
        // Servo knots are corrections of the curves on their grid.
        let start =
            lrmcal_engine::calib::parameters::servo_knots::fit_start(&nominal.into(), &kept);
        let true_arm = truth.apply(&start).arm;
        let all = exact_measurements(&true_arm, &poses, &[0.0, LOAD]);
        let inputs = Inputs::new(&nominal, &poses, &all);
        let chosen: Vec<u32> = first.pose_ids();
        let fit = identify(
            &nominal.into(),
            option,
            &kept,
            &inputs.measurements.of(chosen.iter().copied(), LOAD),
            &IdentifyOptions::default(),
        )
        .expect("identify");
        for e in &fit.estimates {
            let t = truth.get(e.id).expect("fitted key").error;
            assert!(
                (e.error - t).abs() < 1e-6,
                "{option} {}: {} vs true {t}",
                e.id,
                e.error
            );
        }
        let rest = inputs.held_out(&chosen);
        for load in [0.0, LOAD] {
            let v = validate(
                &nominal.into(),
                &fit.rig,
                &inputs.measurements.of(rest.iter().copied(), load),
            )
            .expect("validate");
            assert!(
                v.after.max_m < 1e-5,
                "{option} under {load} kg: max error {} m",
                v.after.max_m
            );
        }
    }
}

/// What `lrmcal demo --seed SEED` prints for one simulated true arm (the
/// simulator's defaults: unmodelled effects and noise on): the mean validation
/// error of each option fitted with the load, mm, the elasto-kinematic
/// model's reduction, and its reductions across loads, %.
#[derive(Debug)]
struct DemoFigures {
    kinematic_mm: f64,
    elastic_mm: f64,
    elasto_kinematic_mm: f64,
    reduction_pct: f64,
    /// Fitted with the load, validated without it.
    cross_load_pct: f64,
    /// Fitted without load, validated with it.
    reverse_cross_load_pct: f64,
}

/// The demo's computation for one seed: the same candidates, measurements,
/// DETMAX and identification settings as `lrmcal demo`, without the files,
/// the random baseline and the O1 sweep.
fn demo_figures(seed: u64) -> DemoFigures {
    let nominal = bundled();
    let poses = candidate_poses(&nominal);
    let truth = TrueArm::draw(&nominal, seed, &SimConfig::default()).expect("draw");
    let all = truth.measure(&poses, &[0.0, LOAD]).expect("measure");
    let calibration = Calibration::open(&Request::new(&nominal, &all).load(LOAD)).expect("open");
    let run = |option, load, other| {
        calibration
            .option(option, &settings(load, Some(other), 8), &Silent)
            .expect("calibrate")
    };
    let held_out = |r: &OptionResult| r.validation.clone().expect("held-out poses");
    let cross = |r: &OptionResult| {
        r.cross_load
            .as_ref()
            .expect("cross-load")
            .validation
            .reduction_pct
    };
    let ek = run(ModelOption::PaperElastoKinematic, LOAD, 0.0);
    let kin = run(ModelOption::PaperKinematic, LOAD, 0.0);
    let ela = run(ModelOption::Elastic, LOAD, 0.0);
    let reverse = run(ModelOption::PaperElastoKinematic, 0.0, LOAD);
    DemoFigures {
        kinematic_mm: held_out(&kin).after.mean_m * 1e3,
        elastic_mm: held_out(&ela).after.mean_m * 1e3,
        elasto_kinematic_mm: held_out(&ek).after.mean_m * 1e3,
        reduction_pct: held_out(&ek).reduction_pct,
        cross_load_pct: cross(&ek),
        reverse_cross_load_pct: cross(&reverse),
    }
}

/// The seeds on which the paper's ranking holds: elasto-kinematic < elastic
/// < kinematic. On the other two (2 and 5) the kinematic model is ahead of
/// the elastic one, by less than 1 mm. `README.md` gives the figures.
const RANKING_SEEDS: [u64; 8] = [1, 3, 4, 6, 7, 8, 9, 10];

/// The seeds on which the paper's figures hold too: at least 85 % reduction,
/// and at least 80 % across loads both ways (elsewhere the reduction is
/// 82–84 %, and fitting with the load keeps 77–80 % without it).
const PAPER_FIGURE_SEEDS: [u64; 5] = [1, 3, 4, 7, 10];

/// The demo's claims on one seed, as far as they hold there. On every seed
/// (1 to 10): the elasto-kinematic model is the best of the three, removes at
/// least 80 % of the mean error, keeps at least 80 % when fitted without load
/// and validated with it, and at least 75 % the other way round.
fn check_demo_claims(seed: u64) {
    let f = demo_figures(seed);
    let best = f.elasto_kinematic_mm < f.elastic_mm.min(f.kinematic_mm);
    assert!(best, "seed {seed}: {f:?}");
    assert!(f.reduction_pct >= 80.0, "seed {seed}: {f:?}");
    assert!(f.reverse_cross_load_pct >= 80.0, "seed {seed}: {f:?}");
    assert!(f.cross_load_pct >= 75.0, "seed {seed}: {f:?}");
    if RANKING_SEEDS.contains(&seed) {
        assert!(f.elastic_mm < f.kinematic_mm, "seed {seed}: {f:?}");
    } else {
        let swapped = f.kinematic_mm < f.elastic_mm && f.elastic_mm < f.kinematic_mm + 1.0;
        assert!(swapped, "seed {seed}: {f:?}");
    }
    if PAPER_FIGURE_SEEDS.contains(&seed) {
        assert!(f.reduction_pct >= 85.0, "seed {seed}: {f:?}");
        assert!(f.cross_load_pct >= 80.0, "seed {seed}: {f:?}");
    }
}

/// One test per seed, so the seeds run in parallel and a failure names its seed.
macro_rules! demo_claims {
    ($($name:ident: $seed:expr,)*) => {$(
        #[test]
        fn $name() {
            check_demo_claims($seed);
        }
    )*};
}

demo_claims! {
    demo_claims_seed_1: 1,
    demo_claims_seed_2: 2,
    demo_claims_seed_3: 3,
    demo_claims_seed_4: 4,
    demo_claims_seed_5: 5,
    demo_claims_seed_6: 6,
    demo_claims_seed_7: 7,
    demo_claims_seed_8: 8,
    demo_claims_seed_9: 9,
    demo_claims_seed_10: 10,
}

/// DETMAX's 50 poses beat the median of 20 random 50-pose sets on O1 and on
/// the validation error of the identified model.
#[test]
fn detmax_beats_random_selection() {
    let nominal = bundled();
    let poses = candidate_poses(&nominal);
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::default()).expect("draw");
    let all = truth.measure(&poses, &[LOAD]).expect("measure");
    let calibration = Calibration::open(&Request::new(&nominal, &all)).expect("open");
    let run = settings(LOAD, None, 8);
    let ek = calibration
        .option(ModelOption::PaperElastoKinematic, &run, &Silent)
        .expect("calibrate");
    let b = random_baseline(&calibration, &ek, 20, &run, &Silent).expect("baseline");
    assert_eq!((b.sets, b.poses), (20, 50));
    assert_eq!(b.detmax_o1, ek.selection.observability.o1);
    assert!(b.detmax_o1 > b.random_o1_median, "{b:?}");
    assert!(b.detmax_mean_m < b.random_mean_median_m, "{b:?}");
}

/// Why the bundled arm keeps the parameters it keeps: every removal is one of
/// the arm's known structural redundancies, and the greedy choice and the SVD
/// agree on the rank.
#[test]
fn bundled_arm_removals_are_the_structural_redundancies() {
    let nominal = bundled();
    let poses = candidate_poses(&nominal);
    let name = |n: &str| ParamKey::from_name(n).expect("parameter name");
    let a = lrmcal_engine::calib::analysis::identifiability::analyse(
        &nominal,
        ModelOption::PaperElastoKinematic,
        lrmcal_engine::calib::parameters::servo_knots::KnotSpacing::FINEST,
        &poses
            .iter()
            .map(|p| Sample {
                id: p.id,
                q: p.q,
                load_kg: LOAD,
                target: 0,
                approach: from_home(6),
            })
            .collect::<Vec<_>>(),
    )
    .expect("analyse");
    let explained = IdentifiabilityReport::from(&a);
    assert_eq!(a.kept.len(), a.svd_rank, "{:?}", explained.removed);
    let removed = |n: &str| a.removed.iter().find(|r| r.id == name(n));
    // The measured point is the tool frame's origin: its rotation has no effect.
    for n in ["tool.roll", "tool.pitch", "tool.yaw"] {
        assert!(
            removed(n).is_some_and(|r| r.confounded_with.is_empty()),
            "{n}: {:?}",
            explained.removed
        );
    }
    // On the level nominal base, gravity has no torque about joint 1's vertical axis.
    assert!(removed("k1").is_some_and(|r| r.confounded_with.is_empty()));
    // Joint 1's theta and d repeat the base's yaw and height, which are kept.
    assert_eq!(
        removed("j1.theta").map(|r| r.confounded_with[0].0),
        Some(name("base.yaw"))
    );
    assert_eq!(
        removed("j1.d").map(|r| r.confounded_with[0].0),
        Some(name("base.z"))
    );
    // Joint 6's parameters move the point within frame 6: the tool point is kept.
    for n in ["j6.theta", "j6.d", "j6.a", "j6.alpha"] {
        assert!(removed(n).is_some(), "{n}: {:?}", explained.removed);
    }
    // Every other removal is confounded with kept parameters, not dropped for noise.
    for r in &a.removed {
        assert!(r.residual < 1e-6, "{}: residual {}", r.id, r.residual);
    }
    let kin = lrmcal_engine::calib::analysis::identifiability::analyse(
        &nominal,
        ModelOption::PaperKinematic,
        lrmcal_engine::calib::parameters::servo_knots::KnotSpacing::FINEST,
        &poses
            .iter()
            .map(|p| Sample {
                id: p.id,
                q: p.q,
                load_kg: LOAD,
                target: 0,
                approach: from_home(6),
            })
            .collect::<Vec<_>>(),
    )
    .expect("analyse");
    assert_eq!(
        kin.kept.len() + 6,
        a.kept.len(),
        "the kinematic set plus six compliances"
    );
}

/// A printed arm whose wrist compliances run to 0.2–0.5 rad/Nm while its
/// wrist carries under 0.08 Nm (the bundled arm's light wrist, fitted
/// without load). Both fits finish, and name the compliances the data barely
/// determine, with their deviations, instead of refusing the poses.
#[test]
fn a_soft_light_wrist_is_fitted_and_its_weak_compliances_named() {
    let nominal = bundled();
    let poses = candidate_poses(&nominal);
    let config = SimConfig {
        joint_compliance: [0.2, 0.5],
        ..SimConfig::default()
    };
    let truth = TrueArm::draw(&nominal, 1, &config).expect("draw");
    let all = truth.measure(&poses, &[0.0]).expect("measure");
    let calibration = Calibration::open(&Request::new(&nominal, &all)).expect("open");
    let wrist = ["k4", "k5", "k6"].map(|n| ParamKey::from_name(n).expect("name"));
    for option in [ModelOption::Elastic, ModelOption::PaperElastoKinematic] {
        let r = calibration
            .option(option, &settings(0.0, None, 2), &Silent)
            .unwrap_or_else(|e| panic!("{option}: {e}"));
        let weak: Vec<_> = r.identified.estimates.iter().filter(|e| e.weak).collect();
        assert!(
            weak.iter().any(|e| wrist.contains(&e.id)),
            "{option}: {:?}",
            r.identified.estimates
        );
        for e in weak.iter().filter(|e| wrist.contains(&e.id)) {
            let std = e.std.expect("a weak parameter is free");
            assert!(std > e.value, "{option} {}: {} ± {std}", e.id, e.value);
        }
        let report = lrmcal_engine::calib::results::report::OptionReport::from(&r);
        let line = lrmcal_engine::calib::results::summary::weak(&report).expect("weak line");
        assert!(line.contains(&format!("{} = ", weak[0].id)), "{line}");
        assert!(r.held_out().expect("validation").reduction_pct > 50.0);
    }
}

/// Three of the 50 fitted poses measured 20 mm too high (seed 1, the demo's
/// fit): the default (robust) fit names all three and its held-out error stays
/// within 0.2 mm of the clean fit's; plain least squares is pulled by them.
#[test]
fn three_gross_errors_are_named_and_do_not_pull_the_default_fit() {
    let nominal = bundled();
    let poses = candidate_poses(&nominal);
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::default()).expect("draw");
    let all = truth.measure(&poses, &[LOAD]).expect("measure");
    let request = Request::new(&nominal, &all);
    let up = nalgebra::Vector3::new(0.0, 0.0, 0.02);
    let run = |identify| {
        let s = RunSettings {
            identify,
            ..settings(LOAD, None, 2)
        };
        outlier_trial(&request, ModelOption::PaperElastoKinematic, &s, 3, up).expect("trial")
    };
    let robust = run(IdentifyOptions::default());
    assert_eq!(robust.displaced.len(), 3);
    for p in &robust.displaced {
        assert!(robust.named.contains(p), "{robust:?}");
    }
    assert!(
        robust.contaminated_mean_m < robust.clean_mean_m + 2e-4,
        "{robust:?}"
    );
    let plain = run(IdentifyOptions {
        robust: false,
        ..Default::default()
    });
    assert!(
        plain.contaminated_mean_m > robust.contaminated_mean_m + 2e-4,
        "plain {plain:?}, robust {robust:?}"
    );
}

/// Mean errors (grid, off the grid), mm, of our option and the paper's
/// elasto-kinematic model as `lrmcal demo` runs them: the grid and 400
/// random candidates, DETMAX poses fitted with the load, validated on the
/// grid candidates not selected and on 200 random poses that are no
/// candidate; ours from 60 poses and from 30, the paper's from 60.
#[derive(Debug)]
struct OffGridFigures {
    ours: (f64, f64),
    ours_30: (f64, f64),
    paper: (f64, f64),
}

fn off_grid_figures(seed: u64) -> OffGridFigures {
    let nominal = bundled();
    let config = PlanConfig {
        random: lrmcal_engine::plan::DEFAULT_RANDOM_POSES,
        ..PlanConfig::default()
    };
    let plan = candidates(&nominal, &config).expect("plan");
    let off_grid_poses = lrmcal_engine::plan::random_candidates(
        &nominal,
        &PlanConfig::default(),
        host::commands::demo::OFF_GRID_POSES,
        host::commands::demo::OFF_GRID_SEED,
        host::commands::demo::OFF_GRID_FIRST_ID,
    )
    .expect("off-grid poses");
    let truth = TrueArm::draw(&nominal, seed, &SimConfig::default()).expect("draw");
    let all = truth.measure(&plan.kept, &[LOAD]).expect("measure");
    let off_grid = truth.measure(&off_grid_poses, &[LOAD]).expect("measure");
    let calibration = Calibration::open(&Request::new(&nominal, &all)).expect("open");
    let means = |option, n| {
        let mut s = settings(LOAD, None, 8);
        s.choice = Choice::Detmax(DetmaxOptions {
            n,
            starts: 8,
            ..Default::default()
        });
        let r = calibration.option(option, &s, &Silent).expect("calibrate");
        let e = grid_and_off_grid(calibration.inputs(), &r, plan.grid_size, &off_grid)
            .expect("validate");
        (e.grid.mean_m * 1e3, e.off_grid.mean_m * 1e3)
    };
    OffGridFigures {
        ours: means(ModelOption::ElastoKinematicServo, 60),
        ours_30: means(ModelOption::ElastoKinematicServo, 30),
        paper: means(ModelOption::PaperElastoKinematic, 60),
    }
}

/// One test per seed: our option beats the paper's model off the grid, and
/// from 30 poses it beats the paper's model from 60 on the grid and off it,
/// and misses the random poses off the grid by 2 mm or less on average.
macro_rules! off_grid_claims {
    ($($name:ident: $seed:expr,)*) => {$(
        #[test]
        fn $name() {
            let f = off_grid_figures($seed);
            assert!(f.ours.1 < f.paper.1, "seed {}: {f:?}", $seed);
            assert!(f.ours_30.0 < f.paper.0 && f.ours_30.1 < f.paper.1, "seed {}: {f:?}", $seed);
            assert!(f.ours_30.1 <= 2.0, "seed {}: {f:?}", $seed);
        }
    )*};
}

off_grid_claims! {
    servo_beats_paper_seed_1: 1,
    servo_beats_paper_seed_2: 2,
    servo_beats_paper_seed_3: 3,
    servo_beats_paper_seed_4: 4,
    servo_beats_paper_seed_5: 5,
    servo_beats_paper_seed_6: 6,
    servo_beats_paper_seed_7: 7,
    servo_beats_paper_seed_8: 8,
    servo_beats_paper_seed_9: 9,
    servo_beats_paper_seed_10: 10,
}

/// Ours fits its servo curves under its prior on knots every 25°: from 60
/// DETMAX poses, and from 30, DETMAX having selected for a coarser grid (the
/// prior determines the knots the poses do not; seed 1, the demo's
/// candidates). The calibration's leave-one-out error is that spacing's.
#[test]
fn ours_fits_its_curves_every_25_degrees_whatever_the_selection() {
    use lrmcal_engine::calib::parameters::servo_knots::KnotSpacing;
    let nominal = bundled();
    let config = PlanConfig {
        random: lrmcal_engine::plan::DEFAULT_RANDOM_POSES,
        ..PlanConfig::default()
    };
    let poses = candidates(&nominal, &config).expect("plan").kept;
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::default()).expect("draw");
    let all = truth.measure(&poses, &[LOAD]).expect("measure");
    let calibration = Calibration::open(&Request::new(&nominal, &all)).expect("open");
    let run = |n| {
        let mut s = settings(LOAD, None, 4);
        s.choice = Choice::Detmax(DetmaxOptions {
            n,
            starts: 4,
            ..Default::default()
        });
        calibration
            .option(ModelOption::ElastoKinematicServo, &s, &Silent)
            .expect("calibrate")
    };
    for (n, selected_for) in [(60, KnotSpacing::Deg25), (30, KnotSpacing::Deg50)] {
        let r = run(n);
        assert_eq!(
            r.selection.candidates.identifiability.knots,
            Some(selected_for)
        );
        let knots = r.knots.as_ref().expect("ours has a spacing");
        assert_eq!(knots.chosen, KnotSpacing::Deg25, "{n} poses: {knots:?}");
        assert_eq!(knots.trials.len(), 1, "{n} poses: {knots:?}");
        assert_eq!(
            Some(r.identified.diagnostics.loo_mean_m * 1e3),
            knots.trials[0].loo_mean_mm
        );
        let curves = r
            .identified
            .estimates
            .iter()
            .filter(|e| matches!(e.id, ParamKey::ServoKnot { .. }))
            .count();
        // Eight knots a joint, the ninth held (its offset is the joint's zero).
        assert_eq!(curves, 6 * 8, "{n} poses");
    }
}
