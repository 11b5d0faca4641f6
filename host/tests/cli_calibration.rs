//! `lrmcal select`, `identify`, `validate` and `demo` run as a user runs them,
//! and bad inputs: each a clear error naming the problem.

mod common;

use common::{default_calibration_file, lrmcal, p, text};

use std::path::Path;

use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::measurements;
use lrmcal_core::param_key::ParamKey;

/// Plans candidates and simulates both loads on them into `dir`.
fn simulated(dir: &Path) -> (String, String) {
    let cand = dir.join("cand.csv");
    let meas = dir.join("m.csv");
    assert!(lrmcal(&["plan", "--out", p(&cand)]).status.success());
    let out = lrmcal(&["simulate", "--loads", "0,0.0663", "--out", p(&meas)]);
    assert!(out.status.success(), "{}", text(&out));
    (p(&cand).to_owned(), p(&meas).to_owned())
}

#[test]
fn select_identify_validate_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let (cand, meas) = simulated(dir.path());
    let sel = dir.path().join("sel.csv");
    let out = lrmcal(&[
        "select",
        "--candidates",
        &cand,
        "--out",
        p(&sel),
        "--compare-random",
        "5",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains("O1") && text(&out).contains("tool.roll"),
        "{}",
        text(&out)
    );
    let cal = dir.path().join("cal");
    let out = lrmcal(&[
        "identify",
        "--measurements",
        &meas,
        "--load-kg",
        "0.0663",
        "--poses",
        p(&sel),
        "--candidates",
        &cand,
        "--out",
        p(&cal),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let file = cal.join(default_calibration_file());
    let parsed = CalibrationFile::read(&file).expect("a valid calibration file");
    assert_eq!(parsed.poses_used.len(), 60);
    let v = parsed.validation.expect("validated on the other poses");
    assert!(v.after.mean_m < 0.2 * v.before.mean_m, "{v:?}");
    assert!(cal.join("report.json").exists());
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&file),
        "--measurements",
        &meas,
        "--arm",
        "lrm",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("0.0663"), "{}", text(&out));
    // A held-out measurement 20 mm off is named by `validate`.
    let mut rows = measurements::read(Path::new(&meas)).unwrap();
    let off = rows
        .iter_mut()
        .find(|m| m.load_kg == 0.0663 && !parsed.poses_used.contains(&m.pose.id))
        .expect("a held-out pose");
    off.position.z += 0.02;
    let bad = off.pose.id;
    let moved = dir.path().join("moved.csv");
    measurements::write(&moved, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&file),
        "--measurements",
        p(&moved),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains(&format!(
            "validation outlier: pose {bad} (0.0663 kg), error "
        )),
        "{}",
        text(&out)
    );
    // A fitted measurement 20 mm off: named and down-weighted by default;
    // with --no-robust it keeps its weight, and a warning says so.
    let fitted = parsed.poses_used[0];
    for m in rows
        .iter_mut()
        .filter(|m| m.pose.id == fitted && m.load_kg == 0.0663)
    {
        m.position.z += 0.02;
    }
    measurements::write(&moved, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let cal2 = dir.path().join("cal2");
    for flag in [None, Some("--no-robust")] {
        let args = [
            "identify",
            "--measurements",
            p(&moved),
            "--load-kg",
            "0.0663",
            "--poses",
            p(&sel),
            "--out",
            p(&cal2),
        ];
        let out = lrmcal(&[&args[..], flag.as_slice()].concat());
        assert!(out.status.success(), "{}", text(&out));
        let named = format!("outlier: pose {fitted} (0.0663 kg)");
        assert!(text(&out).contains(&named), "{}", text(&out));
        // The moved pose is named first (the farthest); unweighted, it may
        // pull others off with it.
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        let warned = stderr.contains(&format!(
            "warning: {}: ",
            lrmcal_engine::calib::parameters::option::DEFAULT.name()
        )) && stderr.contains(&format!(
            "measurements of {} are far off the others (poses {fitted} (",
            p(&moved)
        ));
        assert_eq!(warned, flag.is_some(), "{}", text(&out));
    }
}

/// From 15 poses of the grid, too few for ours' servo curves and for the
/// geometry alone to beat the arm placed (its springs and servo errors are
/// what the geometry would bend to): `--option all` writes elastic and
/// elasto-kinematic, refuses kinematic saying why, and ours keeps the
/// elasto-kinematic rung of its ladder instead of failing; the other
/// rungs' errors are printed.
#[test]
fn option_all_from_few_poses_writes_what_the_poses_carry_and_says_why_not_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let cand = dir.path().join("grid.csv");
    let meas = dir.path().join("m.csv");
    let sel = dir.path().join("sel.csv");
    assert!(
        lrmcal(&["plan", "--random", "0", "--out", p(&cand)])
            .status
            .success()
    );
    let out = lrmcal(&[
        "simulate",
        "--poses",
        p(&cand),
        "--loads",
        "0.0663",
        "--out",
        p(&meas),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let out = lrmcal(&[
        "select",
        "--candidates",
        p(&cand),
        "--option",
        "elasto-kinematic",
        "--n",
        "15",
        "--out",
        p(&sel),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let cal = dir.path().join("cal");
    let out = lrmcal(&[
        "identify",
        "--measurements",
        p(&meas),
        "--poses",
        p(&sel),
        "--option",
        "all",
        "--out",
        p(&cal),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    for option in ["elastic", "elasto-kinematic", "elasto-kinematic-servo"] {
        let file = cal.join(format!("calibration-{option}.json"));
        assert!(
            CalibrationFile::read(&file).is_ok(),
            "{option}: {}",
            text(&out)
        );
    }
    let t = text(&out);
    assert!(!cal.join("calibration-kinematic.json").exists(), "{t}");
    assert!(
        t.contains("kinematic: not fitted: calibrate with the kinematic model: the fit predicts the fitted poses left out worse than the nominal arm placed")
            && t.contains("no calibration was written"),
        "{t}"
    );
    // Ours holds the elasto-kinematic rung: its servo curves, compared on
    // the same poses, do not predict the left-out ones better.
    let ours = CalibrationFile::read(&cal.join("calibration-elasto-kinematic-servo.json")).unwrap();
    assert!(
        ours.parameters
            .iter()
            .all(|p| !matches!(p.name, ParamKey::ServoKnot { .. })),
        "{t}"
    );
    assert!(
        t.contains("model: elasto-kinematic (the richer models do not predict")
            && t.contains("placement ")
            && t.contains("elasto-kinematic-servo "),
        "{t}"
    );
    // Asked for alone, kinematic is refused: exit code 5, no file.
    let alone = dir.path().join("alone");
    let run = lrmcal(&[
        "identify",
        "--measurements",
        p(&meas),
        "--poses",
        p(&sel),
        "--option",
        "kinematic",
        "--out",
        p(&alone),
    ]);
    assert_eq!(run.status.code(), Some(5), "{}", text(&run));
    assert!(!alone.join("calibration-kinematic.json").exists());
}

/// `validate` judges each measurement against the calibration: one far off
/// (200 mm) is a validation outlier, not a refusal of the file; a file most
/// of whose measurements are far off (here, in metres) is refused, with the
/// hint.
#[test]
fn validate_names_a_far_measurement_and_refuses_a_file_in_the_wrong_unit() {
    let dir = tempfile::tempdir().unwrap();
    let (_, meas) = simulated(dir.path());
    let cal = dir.path().join("cal");
    let out = lrmcal(&[
        "identify",
        "--measurements",
        &meas,
        "--load-kg",
        "0.0663",
        "--option",
        "elasto-kinematic",
        "--out",
        p(&cal),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let file = cal.join("calibration-elasto-kinematic.json");
    let mut rows = measurements::read(Path::new(&meas)).unwrap();
    rows[7].position.x += 0.2;
    let far = rows[7];
    let moved = dir.path().join("far.csv");
    measurements::write(&moved, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&file),
        "--measurements",
        p(&moved),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains(&format!(
            "validation outlier: pose {} ({} kg), error 2",
            far.pose.id, far.load_kg
        )),
        "{}",
        text(&out)
    );
    for m in &mut rows {
        m.position /= 1000.0;
    }
    let metres = dir.path().join("metres.csv");
    measurements::write(&metres, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&file),
        "--measurements",
        p(&metres),
    ]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
    let message = text(&out);
    assert!(
        message.contains("from where the calibrated arm puts its target")
            && message.contains("look like metres"),
        "{message}"
    );
}

#[test]
fn bad_inputs_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (cand, meas) = simulated(dir.path());
    // Several loads and no --load-kg: the user must choose.
    let out = lrmcal(&[
        "identify",
        "--measurements",
        &meas,
        "--select",
        "50",
        "--out",
        p(&dir.path().join("a")),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(text(&out).contains("--load-kg"), "{}", text(&out));
    // Too few poses for the parameters.
    let out = lrmcal(&[
        "identify",
        "--measurements",
        &meas,
        "--load-kg",
        "0",
        "--select",
        "5",
        "--out",
        p(&dir.path().join("b")),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        // 32, or 33 with k1: the registered base leans by the sag, so gravity loads joint 1.
        text(&out).contains("parameters from 5 poses"),
        "{}",
        text(&out)
    );
    // A measured pose beyond a joint limit (the bundled arm's are ±105°):
    // refused with file, line and joint unless the user accepts it.
    let rows = measurements::read(Path::new(&meas)).unwrap();
    let mut beyond = rows.clone();
    let moved = beyond[1].pose.id;
    for m in beyond.iter_mut().filter(|m| m.pose.id == moved) {
        m.pose.q[1] = 120f64.to_radians();
    }
    let bad = dir.path().join("beyond.csv");
    measurements::write(&bad, &beyond, &[model::JointKind::Revolute; 6]).unwrap();
    let identify_beyond = |extra: &[&str]| {
        let out_dir = dir.path().join("beyond");
        let args = [
            &["identify", "--measurements", p(&bad), "--load-kg", "0"][..],
            &["--out", p(&out_dir)],
            extra,
        ]
        .concat();
        lrmcal(&args)
    };
    let out = identify_beyond(&[]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
    assert!(
        text(&out).contains("beyond.csv")
            && text(&out).contains("line 3")
            && text(&out).contains("outside joint 2's limits")
            && text(&out).contains("--allow-outside-limits"),
        "{}",
        text(&out)
    );
    // Accepted, the pose goes on to the next check (its position no longer
    // matches its angles, so the plausibility check names it).
    let out = identify_beyond(&["--allow-outside-limits"]);
    assert!(
        text(&out).contains("warning: 2 of the 1610 rows")
            && text(&out).contains("used anyway")
            && text(&out).contains("from where the nominal arm puts the tool"),
        "{}",
        text(&out)
    );
    // Metres where millimetres are expected.
    let metres: Vec<Measurement> = rows
        .iter()
        .map(|m| Measurement {
            position: m.position / 1000.0,
            ..*m
        })
        .collect();
    let bad = dir.path().join("metres.csv");
    measurements::write(&bad, &metres, &[model::JointKind::Revolute; 6]).unwrap();
    let out = lrmcal(&[
        "identify",
        "--measurements",
        p(&bad),
        "--load-kg",
        "0",
        "--out",
        p(&dir.path().join("c")),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out).contains("metres.csv") && text(&out).contains("look like metres"),
        "{}",
        text(&out)
    );
    assert!(
        !dir.path()
            .join("c")
            .join(default_calibration_file())
            .exists()
    );
    // A measured pose that is not a candidate.
    let mut moved = rows.clone();
    let id = moved[0].pose.id;
    for m in moved.iter_mut().filter(|m| m.pose.id == id) {
        m.pose.q[0] += 0.2;
    }
    let shifted = dir.path().join("shifted.csv");
    measurements::write(&shifted, &moved, &[model::JointKind::Revolute; 6]).unwrap();
    let out = lrmcal(&[
        "identify",
        "--measurements",
        p(&shifted),
        "--candidates",
        &cand,
        "--load-kg",
        "0",
        "--out",
        p(&dir.path().join("d")),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out).contains("not in the candidate pose list"),
        "{}",
        text(&out)
    );
    // Too few poses to pin the compliances down: the fit says so instead of
    // returning a calibration.
    let three = dir.path().join("three.csv");
    let few: Vec<Measurement> = rows
        .iter()
        .filter(|m| m.load_kg == 0.0)
        .take(3)
        .copied()
        .collect();
    measurements::write(&three, &few, &[model::JointKind::Revolute; 6]).unwrap();
    let out = lrmcal(&[
        "identify",
        "--measurements",
        p(&three),
        "--option",
        "elastic",
        "--out",
        p(&dir.path().join("e")),
    ]);
    assert!(!out.status.success());
    assert!(text(&out).contains("poses"), "{}", text(&out));
    // A rank-deficient selection: twelve measurements of one configuration.
    let same = dir.path().join("same.csv");
    let copies: Vec<Measurement> = (1..=12)
        .map(|id| Measurement {
            pose: lrmcal_core::dataset::Pose { id, ..rows[0].pose },
            ..rows[0]
        })
        .collect();
    measurements::write(&same, &copies, &[model::JointKind::Revolute; 6]).unwrap();
    // One point cannot place the arm; in the arm file's frame it cannot
    // determine the parameters either.
    let out = lrmcal(&[
        "identify",
        "--measurements",
        p(&same),
        "--out",
        p(&dir.path().join("f")),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(text(&out).contains("spread in 3D"), "{}", text(&out));
    let out = lrmcal(&[
        "identify",
        "--measurements",
        p(&same),
        "--no-register",
        "--out",
        p(&dir.path().join("f")),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out).contains("leave") && text(&out).contains("undetermined"),
        "{}",
        text(&out)
    );
}

#[test]
fn validate_refuses_a_calibration_of_another_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (_, meas) = simulated(dir.path());
    let cal = dir.path().join("cal");
    let out = lrmcal(&[
        "identify",
        "--measurements",
        &meas,
        "--load-kg",
        "0.0663",
        "--select",
        "40",
        "--option",
        "elastic",
        "--out",
        p(&cal),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let other = dir.path().join("other.toml");
    let arm_text = lrmcal_core::io::arm_source::BUNDLED[0]
        .1
        .replacen("d = 0.09", "d = 0.10", 1);
    assert_ne!(
        arm_text,
        lrmcal_core::io::arm_source::BUNDLED[0].1,
        "the bundled arm has a d = 0.09 line"
    );
    std::fs::write(&other, arm_text).unwrap();
    let file = cal.join("calibration-elastic.json");
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&file),
        "--measurements",
        &meas,
        "--arm",
        p(&other),
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out).contains("another nominal arm") && text(&out).contains("j1.d"),
        "{}",
        text(&out)
    );
    // A truncated calibration file.
    let json = std::fs::read_to_string(&file).unwrap();
    let cut = dir.path().join("cut.json");
    std::fs::write(&cut, &json[..json.len() / 3]).unwrap();
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&cut),
        "--measurements",
        &meas,
    ]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        text(&out).contains("cut.json") && text(&out).contains("not JSON"),
        "{}",
        text(&out)
    );
}

#[test]
fn demo_writes_its_folder_and_prints_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("demo");
    let out = lrmcal(&[
        "demo",
        "--compare-random",
        "2",
        "--starts",
        "2",
        "--poses",
        "40",
        "--targets",
        "20",
        "--out",
        p(&out_dir),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let t = text(&out);
    for needle in [
        "kinematic",
        "elastic",
        "elasto-kinematic",
        "reduction",
        "cross-load",
        // The counts follow --poses and the option's candidates.
        "O1 of the 40 selected poses",
        "DETMAX vs 2 random 40-pose sets (paper-elasto-kinematic)",
        "elasto-kinematic-servo: 81 of 98 parameters identifiable",
        // The error at the tool through the board, per board.
        "Positioning error at the tool through the board, 20 random targets",
        "uncalibrated  ",
        "paper's model",
    ] {
        assert!(t.contains(needle), "{needle} missing from {t}");
    }
    for f in [
        "calibration-paper-elasto-kinematic.json",
        "report.json",
        "errors.svg",
        "errors.png",
        "per-pose.svg",
        "o1-vs-poses.png",
        "positioning.svg",
        "positioning.png",
        "measurements.csv",
    ] {
        assert!(out_dir.join(f).exists(), "{f} not written");
    }
}
