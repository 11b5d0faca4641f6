//! `lrmcal plan` and `lrmcal simulate` run as a user runs them, and the
//! simulator's headline figure: the bundled arm's uncalibrated error.

mod common;

use common::lrmcal;
use model::testing::TEST_ARM_JOINTS as JOINTS;

use std::path::Path;
use std::process::Output;

use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::{arm_source::ArmSource, measurements, pose_list};
use lrmcal_engine::plan::{DEFAULT_RANDOM_POSES, PlanConfig, candidates};
use lrmcal_engine::sim::{DEFAULT_SEED, ServoErrorShape, SimConfig, TrueArm};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn bundled() -> model::Arm<f64> {
    "lrm".parse::<ArmSource>().unwrap().load().unwrap().arm
}

/// Mean distance between the nominal model's prediction and the measurements, mm.
fn mean_nominal_error_mm(arm: &model::Arm<f64>, rows: &[Measurement]) -> f64 {
    let chain = arm.chain();
    let opts = model::SolverOptions::default();
    let sum: f64 = rows
        .iter()
        .map(|m| (chain.tool_point(&m.pose.q, m.load_kg, &opts).unwrap() - m.position).norm())
        .sum();
    sum / rows.len() as f64 * 1e3
}

#[test]
fn default_simulation_has_the_papers_uncalibrated_error() {
    // The paper: 32.9 mm mean error of the uncalibrated model with 66.3 g.
    let nominal = bundled();
    let poses = candidates(&nominal, &PlanConfig::default()).unwrap().kept;
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::default()).unwrap();
    let loaded = truth.measure(&poses, &[0.0663]).unwrap();
    let mean = mean_nominal_error_mm(&nominal, &loaded);
    assert!(
        (25.0..=40.0).contains(&mean),
        "mean uncalibrated error {mean:.2} mm"
    );
    // The load adds sag on top of the arm's own weight.
    let unloaded = truth.measure(&poses, &[0.0]).unwrap();
    assert!(mean_nominal_error_mm(&nominal, &unloaded) < mean);
}

#[test]
fn plan_writes_the_survivors_and_says_why_the_rest_went() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("candidates.csv");
    let run = lrmcal(&["plan", "--out", path(&out)]);
    assert!(run.status.success(), "{}", stderr(&run));
    let rows = pose_list::read(&out).unwrap();
    // The grid's survivors, then the random poses off the grid (ids after the grid's).
    assert_eq!(rows.len(), 405 + DEFAULT_RANDOM_POSES);
    assert!(rows.iter().all(|r| r.load_kg.is_none()));
    assert!(rows[405..].iter().all(|r| r.pose.id >= 729));
    assert!(rows[..405].iter().all(|r| r.pose.id < 729));
    let home = rows
        .iter()
        .find(|r| r.pose.id == 364)
        .expect("the home pose survives");
    assert_eq!(home.pose.q, [0.0; JOINTS]);
    let text = stderr(&run);
    assert!(
        text.contains("405 of 729 grid poses kept, 324 dropped"),
        "{text}"
    );
    assert!(text.contains("ground:             324"), "{text}");

    let fine = dir.path().join("fine.csv");
    let run = lrmcal(&["plan", "--levels", "4", "--no-ground", "--out", path(&fine)]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("of 4096 grid poses kept"),
        "{}",
        stderr(&run)
    );
    let run = lrmcal(&["plan", "--levels", "-100,0,100", "--ground-z-mm", "-300"]);
    assert!(run.status.success(), "{}", stderr(&run));
    // Without a file the pose list goes to stdout: header plus the survivors.
    let lines = String::from_utf8(run.stdout).unwrap().lines().count();
    assert!(lines > 406, "{lines}");
}

#[test]
fn plan_rejects_bad_settings_with_usage_errors() {
    for (args, needle) in [
        (vec!["plan", "--levels", "1"], "at least 2"),
        (vec!["plan", "--levels", "-100,abc"], "`abc`"),
        (vec!["plan", "--levels", "20"], "at most"),
        (vec!["plan", "--clearance-mm", "-1"], ">= 0"),
        (vec!["plan", "--ground-z-mm", "nan"], "finite"),
        (
            vec!["plan", "--no-ground", "--ground-z-mm", "5"],
            "cannot be used with",
        ),
        (vec!["plan", "--arm", "nope"], "bundled arm"),
    ] {
        let run = lrmcal(&args);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {}", stderr(&run));
        assert!(stderr(&run).contains(needle), "{args:?}: {}", stderr(&run));
    }
}

#[test]
fn simulate_is_seeded_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let files = |tag: &str, seed: &str| {
        let (m, t, n) = (
            dir.path().join(format!("m{tag}.csv")),
            dir.path().join(format!("t{tag}.json")),
            dir.path().join(format!("n{tag}.csv")),
        );
        let run = lrmcal(&[
            "simulate",
            "--seed",
            seed,
            "--out",
            path(&m),
            "--truth",
            path(&t),
            "--noise-free",
            path(&n),
        ]);
        assert!(run.status.success(), "{}", stderr(&run));
        [m, t, n].map(|p| std::fs::read(p).unwrap())
    };
    let a = files("a", "7");
    let b = files("b", "7");
    let c = files("c", "8");
    assert_eq!(a, b);
    for i in 0..3 {
        assert_ne!(a[i], c[i], "file {i} must depend on the seed");
    }
    // Both loads for every candidate, noisy and noise-free rows line up.
    let noisy = measurements::parse(std::str::from_utf8(&a[0]).unwrap()).unwrap();
    let exact = measurements::parse(std::str::from_utf8(&a[2]).unwrap()).unwrap();
    assert_eq!(noisy.len(), 2 * (405 + DEFAULT_RANDOM_POSES));
    assert!(
        noisy
            .iter()
            .zip(&exact)
            .all(|(n, e)| n.pose == e.pose && n.load_kg == e.load_kg)
    );
    let gap = noisy
        .iter()
        .zip(&exact)
        .map(|(n, e)| (n.position - e.position).norm())
        .fold(0.0, f64::max);
    assert!(gap > 0.0 && gap < 2e-3, "noise {gap} m");
    let truth: serde_json::Value = serde_json::from_slice(&a[1]).unwrap();
    assert_eq!(truth["seed"], 7);
    assert_eq!(truth["errors"].as_object().unwrap().len(), 43);
}

#[test]
fn simulate_model_only_measures_the_model_of_the_true_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (m, n) = (dir.path().join("m.csv"), dir.path().join("n.csv"));
    let run = lrmcal(&[
        "simulate",
        "--model-only",
        "--loads",
        "0.0663",
        "--out",
        path(&m),
        "--noise-free",
        path(&n),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(std::fs::read(&m).unwrap(), std::fs::read(&n).unwrap());
    // The same as the library with every effect off, to the file's 1 nm resolution.
    let nominal = bundled();
    let truth = TrueArm::draw(&nominal, DEFAULT_SEED, &SimConfig::model_only()).unwrap();
    let chain = truth.arm.chain();
    for row in measurements::read(&m).unwrap() {
        let exact = chain
            .tool_point(&row.pose.q, row.load_kg, &model::SolverOptions::default())
            .unwrap();
        assert!((exact - row.position).norm() < 2e-9, "pose {}", row.pose.id);
    }
    assert!(
        stderr(&run).contains("load 0.0663 kg: mean distance nominal model -> measurement"),
        "{}",
        stderr(&run)
    );
}

/// The second test arm (`tests/data/desk_arm.toml`): its limits hold the
/// whole grid, the floor drops some poses, and `simulate` measures it with
/// stiffening springs and the harmonic servo error exactly as the library
/// draws and solves them, the bundled arm's defaults scaled to it.
#[test]
fn simulate_the_second_arm_with_stiffening_springs_and_harmonics() {
    let dir = tempfile::tempdir().unwrap();
    let arm_file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/desk_arm.toml");
    let arm = path(&arm_file);
    let candidates = dir.path().join("candidates.csv");
    let run = lrmcal(&["plan", "--arm", arm, "--out", path(&candidates)]);
    assert!(run.status.success(), "{}", stderr(&run));
    let text = stderr(&run);
    assert!(text.contains("joint limits:         0"), "{text}");
    let poses: Vec<_> = pose_list::read(&candidates)
        .unwrap()
        .into_iter()
        .map(|r| r.pose)
        .collect();
    assert!(poses.len() > 300 + DEFAULT_RANDOM_POSES, "{}", poses.len());

    let (m, n, t) = (
        dir.path().join("m.csv"),
        dir.path().join("n.csv"),
        dir.path().join("t.json"),
    );
    let run = lrmcal(&[
        "simulate",
        "--arm",
        arm,
        "--poses",
        path(&candidates),
        "--loads",
        "0.0663",
        "--seed",
        "4",
        "--stiffening-per-nm",
        "0.4",
        "--servo-error-shape",
        "harmonics",
        "--out",
        path(&m),
        "--noise-free",
        path(&n),
        "--truth",
        path(&t),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let nominal = lrmcal_core::io::arm_toml::read(&arm_file).unwrap().arm;
    let config = SimConfig {
        softening_per_nm: 0.0,
        stiffening_per_nm: 0.4,
        servo_error_shape: ServoErrorShape::Harmonics,
        ..SimConfig::default().scaled_to(&nominal)
    };
    let expected = TrueArm::draw(&nominal, 4, &config)
        .unwrap()
        .simulate(&poses, &[0.0663])
        .unwrap()
        .noise_free;
    let written = measurements::read(&n).unwrap();
    assert_eq!(written.len(), expected.len());
    for (w, e) in written.iter().zip(&expected) {
        assert_eq!(w.pose.id, e.pose.id);
        // The file's resolution is 1 nm.
        assert!(
            (w.position - e.position).norm() < 2e-9,
            "pose {}",
            w.pose.id
        );
    }
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&t).unwrap()).unwrap();
    assert_eq!(truth["config"]["stiffening_per_nm"], 0.4);
    assert_eq!(truth["config"]["softening_per_nm"], 0.0);
    assert_eq!(truth["config"]["servo_error_shape"], "harmonics");
    assert_eq!(
        truth["servo_errors"][2]["harmonics"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    assert_eq!(truth["servo_errors"][2]["cubic_rad"], 0.0);
}

#[test]
fn simulate_follows_a_pose_list_and_its_loads() {
    let dir = tempfile::tempdir().unwrap();
    let list = dir.path().join("poses.csv");
    std::fs::write(
        &list,
        "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\
         3,0.0663,0,30,40,0,20,0\n5,0,10,-30,60,20,-40,0\n3,0,0,30,40,0,20,0\n",
    )
    .unwrap();
    let out = dir.path().join("m.csv");
    let run = lrmcal(&["simulate", "--poses", path(&list), "--out", path(&out)]);
    assert!(run.status.success(), "{}", stderr(&run));
    let rows = measurements::read(&out).unwrap();
    let keys: Vec<(u32, f64)> = rows.iter().map(|m| (m.pose.id, m.load_kg)).collect();
    assert_eq!(keys, [(3, 0.0663), (5, 0.0), (3, 0.0)]);
    // Explicit loads: every distinct pose under each.
    let run = lrmcal(&[
        "simulate",
        "--poses",
        path(&list),
        "--loads",
        "0,0.1,0.2",
        "--out",
        path(&out),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(measurements::read(&out).unwrap().len(), 6);
}

#[test]
fn simulate_rejects_bad_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.csv");
    let run = lrmcal(&["simulate", "--poses", path(&missing)]);
    assert_eq!(run.status.code(), Some(4), "{}", stderr(&run));
    assert!(stderr(&run).contains("missing.csv"), "{}", stderr(&run));

    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,zero,0,0,0\n",
    )
    .unwrap();
    let run = lrmcal(&["simulate", "--poses", path(&bad)]);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("bad.csv") && stderr(&run).contains("line 2"),
        "{}",
        stderr(&run)
    );

    for (args, needle) in [
        (vec!["simulate", "--loads", "0,-1"], "load >= 0"),
        (
            vec!["simulate", "--joint-compliance", "0.2,0.01"],
            "LO <= HI",
        ),
        (vec!["simulate", "--joint-compliance", "0.2"], "LO,HI"),
        (vec!["simulate", "--noise-mm", "-0.1"], ">= 0"),
        (
            vec!["simulate", "--model-only", "--noise-mm", "0.1"],
            "cannot be used with",
        ),
        (vec!["simulate", "--stiffening-per-nm", "-0.2"], ">= 0"),
        (
            vec![
                "simulate",
                "--stiffening-per-nm",
                "0.2",
                "--softening-per-nm",
                "0.1",
            ],
            "cannot be used with",
        ),
        (
            vec!["simulate", "--model-only", "--stiffening-per-nm", "0.2"],
            "cannot be used with",
        ),
        (
            vec!["simulate", "--servo-error-shape", "kink"],
            "sine-cubic, harmonics",
        ),
    ] {
        let run = lrmcal(&args);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {}", stderr(&run));
        assert!(stderr(&run).contains(needle), "{args:?}: {}", stderr(&run));
    }
    // The same load twice is a simulator error (exit 3), named.
    let run = lrmcal(&["simulate", "--loads", "0.1,0.1"]);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    assert!(stderr(&run).contains("only once"), "{}", stderr(&run));
    // An arm too soft to hold itself up: the model's failure, exit 5, names the pose.
    let run = lrmcal(&[
        "simulate",
        "--model-only",
        "--joint-compliance",
        "80,80",
        "--loads",
        "2",
    ]);
    assert_eq!(run.status.code(), Some(5), "{}", stderr(&run));
    assert!(stderr(&run).contains("pose"), "{}", stderr(&run));
}

#[test]
fn help_teaches() {
    for (command, needles) in [
        ("plan", ["--levels", "capsules", "Examples:"]),
        ("simulate", ["--model-only", "truth file", "Examples:"]),
        (
            "simulate",
            ["--stiffening-per-nm", "--servo-error-shape", "harmonics"],
        ),
    ] {
        let run = lrmcal(&["help", command]);
        assert!(run.status.success());
        let text = String::from_utf8(run.stdout).unwrap();
        for needle in needles {
            assert!(
                text.contains(needle),
                "`lrmcal help {command}` lacks {needle}:\n{text}"
            );
        }
    }
    // The defaults printed in the help are the library's; the compliance
    // ranges and the softening are the bundled arm's, scaled to another.
    let text = String::from_utf8(lrmcal(&["help", "simulate"]).stdout).unwrap();
    let d = SimConfig::default();
    let [lo, hi] = d.joint_compliance;
    let [base_lo, base_hi] = d.base_compliance;
    assert!(
        text.contains("[default: 0.2]")
            && text.contains("[default: sine-cubic]")
            && text.contains(&format!("[default: {lo},{hi} on the bundled arm"))
            && text.contains(&format!("[default: {base_lo},{base_hi} on the bundled arm"))
            && text.contains(&format!(
                "[default: {} on the bundled arm",
                d.softening_per_nm
            )),
        "{text}"
    );
}
