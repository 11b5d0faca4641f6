//! The bundled SO-101 (`--arm so101`, five joints): it is its URDF as
//! lrmcal reads it, the demo runs through it end to end with the board in
//! memory, and the board's checks take its calibrations (and refuse one of
//! the URDF's arm, which has no servo curves).

mod common;

use common::{lrmcal, p, text};

use std::path::Path;

use lrmcal_core::io::arm_source::{ArmSource, bundled};
use lrmcal_core::io::arm_urdf;
use lrmcal_core::io::calibration_file::CalibrationFile;
use model::Arm;

/// The SO-101's URDF, shipped for the tests and the bundled arm's numbers.
const URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/core/arms/so101/so101.urdf");

/// The chain's last link: the gripper's frame (the jaw's joint is off the chain).
const TIP: &str = "gripper_frame_link";

/// Asserts that `a` and `b` have the same geometry (gravity, base and tool
/// frames, each joint's kind, DH parameters and twist) to `tolerance`.
fn assert_same_geometry(a: &Arm<f64>, b: &Arm<f64>, tolerance: f64, what: &str) {
    let close = |x: f64, y: f64, name: String| {
        assert!(
            (x - y).abs() <= tolerance,
            "{what}: {name} differs: {x} and {y}"
        );
    };
    let triple = |x: [f64; 3], y: [f64; 3], name: &str| {
        for i in 0..3 {
            close(x[i], y[i], format!("{name}[{i}]"));
        }
    };
    assert_eq!(a.joints.len(), b.joints.len(), "{what}: joint count");
    triple(a.gravity, b.gravity, "gravity");
    triple(a.base.xyz, b.base.xyz, "base.xyz");
    triple(a.base.rpy, b.base.rpy, "base.rpy");
    triple(a.tool.xyz, b.tool.xyz, "tool.xyz");
    triple(a.tool.rpy, b.tool.rpy, "tool.rpy");
    for (i, (ja, jb)) in a.joints.iter().zip(b.joints.iter()).enumerate() {
        let j = i + 1;
        assert_eq!(ja.kind, jb.kind, "{what}: joint {j}'s kind");
        close(ja.theta, jb.theta, format!("j{j}.theta"));
        close(ja.d, jb.d, format!("j{j}.d"));
        close(ja.a, jb.a, format!("j{j}.a"));
        close(ja.alpha, jb.alpha, format!("j{j}.alpha"));
        close(ja.beta, jb.beta, format!("j{j}.beta"));
    }
}

/// The bundled arm's geometry, masses and centres of mass are the URDF's
/// chain as lrmcal reads it (so the bundled file was written from it, not
/// copied by hand); its limits are within the URDF's (wrist_roll's cut to
/// the board's ±150°); what the URDF cannot say the file adds: a servo
/// curve per joint, the rated payload, the grid levels.
#[test]
fn the_bundled_so101_is_its_urdf_read_by_lrmcal() {
    let toml = bundled("so101").unwrap();
    let urdf = arm_urdf::read(Path::new(URDF), None, Some(TIP)).unwrap();
    assert_same_geometry(&toml.arm, &urdf.arm, 1e-12, "so101.toml vs the URDF");
    assert_eq!(toml.joint_names, urdf.joint_names);
    for (i, (t, u)) in toml
        .arm
        .joints
        .iter()
        .zip(urdf.arm.joints.iter())
        .enumerate()
    {
        assert!((t.mass - u.mass).abs() <= 1e-12, "joint {}'s mass", i + 1);
        for k in 0..3 {
            assert!(
                (t.com[k] - u.com[k]).abs() <= 1e-12,
                "joint {}'s com",
                i + 1
            );
        }
        assert_eq!((t.compliance, u.compliance), (0.0, 0.0));
        let ([lo, hi], [ulo, uhi]) = (t.limits, u.limits);
        assert!(ulo <= lo && hi <= uhi, "joint {}'s limits", i + 1);
        if i < 4 {
            assert_eq!(t.limits, u.limits, "joint {}'s limits", i + 1);
        }
        // Monotonic, inside the board's pulse range at the joint's limits.
        t.servo.unwrap().check().unwrap();
        for q in t.limits {
            let us = t.servo.unwrap().pulse_us(q);
            assert!((500.0..=2500.0).contains(&us), "joint {}: {us} µs", i + 1);
        }
    }
    assert_eq!(
        toml.arm.joints[4].limits,
        [-150f64, 150.0].map(f64::to_radians)
    );
    assert_eq!(toml.arm.payload_com, urdf.arm.payload_com);
    assert_eq!(toml.arm.rated_payload_kg, 0.1);
    assert_eq!(toml.levels_deg, Some(vec![-90.0, 0.0, 90.0]));
    // The same arm through `--arm`, by name and as the URDF with its tip.
    let by_name = ArmSource::Bundled("so101").load().unwrap();
    assert_eq!(by_name.arm, toml.arm);
    assert_eq!(
        "so101".parse::<ArmSource>(),
        Ok(ArmSource::Bundled("so101"))
    );
}

/// `lrmcal identify --option kinematic` gives the same calibration from the
/// same measurements whether the arm is the bundled `so101` or its URDF:
/// the kinematic fit reads neither servo curves nor masses, and the two
/// arms' geometry is the same.
#[test]
fn identify_calibrates_the_bundled_so101_as_its_urdf() {
    let dir = tempfile::tempdir().unwrap();
    let cand = dir.path().join("cand.csv");
    let meas = dir.path().join("m.csv");
    let out = lrmcal(&["plan", "--arm", "so101", "--random", "0", "--out", p(&cand)]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains("117 of 243 grid poses kept"),
        "{}",
        text(&out)
    );
    let out = lrmcal(&[
        "simulate",
        "--arm",
        "so101",
        "--poses",
        p(&cand),
        "--loads",
        "0.0663",
        "--seed",
        "3",
        "--out",
        p(&meas),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let identify = |arm: &[&str], folder: &str| {
        let out_dir = dir.path().join(folder);
        let mut args = vec!["identify"];
        args.extend_from_slice(arm);
        args.extend([
            "--measurements",
            p(&meas),
            "--option",
            "kinematic",
            "--out",
            p(&out_dir),
        ]);
        let out = lrmcal(&args);
        assert!(out.status.success(), "{}", text(&out));
        CalibrationFile::read(&out_dir.join("calibration-kinematic.json")).unwrap()
    };
    let from_toml = identify(&["--arm", "so101"], "toml");
    let from_urdf = identify(&["--arm", URDF, "--tip-link", TIP], "urdf");
    assert_eq!(from_toml.arm.joints.len(), 5);
    // The fit moved the arm: the comparison is of a calibration, not of two nominal arms.
    let moved = (from_toml.arm.base.xyz[2] - from_toml.nominal.base.xyz[2]).abs();
    assert!(moved > 1e-5, "{moved}");
    assert_same_geometry(&from_toml.arm, &from_urdf.arm, 1e-9, "the two calibrations");
    let names = |f: &CalibrationFile| -> Vec<String> {
        f.parameters.iter().map(|q| q.name.to_string()).collect()
    };
    assert_eq!(names(&from_toml), names(&from_urdf));
    assert_eq!(from_toml.removed, from_urdf.removed);
    for (a, b) in from_toml.parameters.iter().zip(&from_urdf.parameters) {
        assert!(
            (a.value - b.value).abs() <= 1e-9,
            "{}: {} and {}",
            a.name,
            a.value,
            b.value
        );
    }
    let mean = |f: &CalibrationFile| f.fit_residual.mean_m;
    assert!((mean(&from_toml) - mean(&from_urdf)).abs() <= 1e-12);
}

/// `lrmcal demo --arm so101`, quickly: every option identified and
/// validated, the table, the positioning through the board in memory with
/// a row per board, a calibration of five joints that `push --dry-run`
/// accepts; the URDF's arm, which has no servo curves, is refused by
/// `push` with the reason.
#[test]
fn the_demo_runs_on_the_so101_and_the_board_takes_its_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("demo");
    let out = lrmcal(&[
        "demo",
        "--arm",
        "so101",
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
        "117 of the 243 grid poses clear of the joint limits and collisions",
        "mean error before -> after",
        "kinematic  ",
        "elastic  ",
        "elasto-kinematic  ",
        "elasto-kinematic-servo  ",
        "O1 of the 40 selected poses",
        "Positioning error at the tool through the board, 20 random targets",
        "uncalibrated  ",
        "paper's model (paper-elasto-kinematic)  ",
        "ours (elasto-kinematic-servo)  ",
    ] {
        assert!(t.contains(needle), "{needle} missing from {t}");
    }
    for f in [
        "report.html",
        "report.json",
        "errors.png",
        "errors-vs-poses.svg",
        "positioning.svg",
        "positioning.png",
    ] {
        assert!(out_dir.join(f).exists(), "{f} not written");
    }
    let ours = out_dir.join("calibration-elasto-kinematic-servo.json");
    let file = CalibrationFile::read(&ours).unwrap();
    assert_eq!(file.arm.joints.len(), 5);
    assert_eq!(file.nominal, bundled("so101").unwrap().arm);

    let out = lrmcal(&["push", p(&ours), "--dry-run"]);
    assert!(out.status.success(), "{}", text(&out));
    let t = text(&out);
    assert!(t.contains("the board would accept it"), "{t}");
    let corrections = t
        .lines()
        .find_map(|l| l.strip_prefix("largest correction per joint, deg: "))
        .unwrap_or_else(|| panic!("no corrections in {t}"));
    assert_eq!(corrections.split_whitespace().count(), 5, "{t}");

    // The URDF's arm, calibrated from the demo's measurements: the host
    // takes it, the board cannot drive it.
    let cal = dir.path().join("urdf");
    let out = lrmcal(&[
        "identify",
        "--arm",
        URDF,
        "--tip-link",
        TIP,
        "--measurements",
        p(&out_dir.join("off-grid.csv")),
        "--option",
        "elasto-kinematic",
        "--out",
        p(&cal),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let urdf_cal = cal.join("calibration-elasto-kinematic.json");
    let out = lrmcal(&["push", p(&urdf_cal), "--dry-run"]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
    let t = text(&out);
    assert!(
        t.contains("urdf/calibration-elasto-kinematic.json")
            && t.contains("joint 1 has no servo curve")
            && t.contains("`servo` table"),
        "{t}"
    );
    // The calibration knows its arm: exported as a URDF without --arm, its
    // joints keep the URDF's names.
    let exported = dir.path().join("calibrated.urdf");
    let out = lrmcal(&[
        "export",
        "--urdf",
        "--calibration",
        p(&urdf_cal),
        "--out",
        p(&exported),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let urdf = std::fs::read_to_string(&exported).unwrap();
    for name in [
        "shoulder_pan",
        "shoulder_lift",
        "elbow_flex",
        "wrist_flex",
        "wrist_roll",
    ] {
        assert!(
            urdf.contains(&format!("<joint name=\"{name}\"")),
            "{name} missing from\n{urdf}"
        );
    }
    assert!(!urdf.contains("joint_1"), "{urdf}");
}

/// The demo of an arm the board cannot drive (the URDF's, without servo
/// curves) calibrates and validates it all the same and says why it skips
/// the positioning through the board, instead of failing at the end.
#[test]
fn the_demo_of_the_urdf_arm_skips_the_board_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("demo");
    let out = lrmcal(&[
        "--tip-link",
        TIP,
        "demo",
        "--arm",
        URDF,
        "--compare-random",
        "0",
        "--no-error-sweep",
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
    assert!(
        t.contains(
            "Positioning error at the tool through the board: skipped, joint 1 has no servo curve"
        ),
        "{t}"
    );
    assert!(t.contains("elasto-kinematic-servo  "), "{t}");
    assert!(!out_dir.join("positioning.svg").exists());
    assert!(
        out_dir
            .join("calibration-paper-elasto-kinematic.json")
            .exists()
    );
}
