//! Real measurements through the CLI: 34 poses of a PAL Robotics TIAGo
//! measured by motion capture (FIGAROH's public data, Apache-2.0,
//! `tests/data/tiago/NOTICE.md`), three points of a rigid body on the wrist
//! in a frame on the mobile base, with the arm read from PAL's URDF
//! (`tests/data/tiago/tiago.urdf`: a prismatic torso lift and seven
//! revolute arm joints). The measurement files are
//! `tools/figaroh/tiago_to_lrmcal.py`'s, one per fold of `split.csv`.
//!
//! Fold 0 is calibrated with the kinematic option (the arm's DH geometry,
//! the base and one tool point per target) and validated on its 7 held-out
//! poses. `tools/figaroh/lrmcal_tiago_cv.py` runs every fold and option
//! (docs/RESULTS.md, "Real data: a TIAGo"); measured there on this fold:
//! 3.29 mm mean over the three points (FIGAROH 1.0.2's full calibration of
//! the same split: 3.46 mm), and 3.15 mm on point 1 where the registered
//! nominal arm (base and tool point only) misses by 4.64 mm.

mod common;

use common::{lrmcal, p, text};

use std::path::{Path, PathBuf};

use lrmcal_core::io::arm_urdf;
use model::JointKind;

/// The link the markers' frame is on: the URDF has a second leaf
/// (`torso_fixed_column_link`), so the tip must be named.
const TIP: &str = "wrist_ft_tool_link";

/// Measured mean held-out errors of fold 0 (mm), the bounds below allow 20 % more.
const MEASURED_MEAN_MM: f64 = 3.29;
const MEASURED_P1_MEAN_MM: f64 = 3.15;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/tiago")
        .join(name)
}

/// Validates `calibration` on `measurements`: (mean before, mean after), mm.
fn validate(calibration: &Path, measurements: &Path) -> (f64, f64, String) {
    let run = lrmcal(&[
        "validate",
        "--calibration",
        p(calibration),
        "--measurements",
        p(measurements),
    ]);
    let printed = text(&run);
    assert!(run.status.success(), "{printed}");
    // ` load kg  poses | before: mean … | after: mean … | reduction`: one load.
    let row = printed
        .lines()
        .find(|l| l.trim_start().starts_with("0 "))
        .unwrap_or_else(|| panic!("a row for 0 kg\n{printed}"));
    let cells: Vec<&str> = row.split('|').collect();
    let mean = |cell: &str| -> f64 {
        cell.split_whitespace()
            .next()
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("a mean in {cell:?}\n{printed}"))
    };
    (mean(cells[1]), mean(cells[2]), printed)
}

#[test]
fn the_tiago_urdf_is_a_lift_and_seven_revolute_joints() {
    let urdf = data("tiago.urdf");
    let arm = arm_urdf::read(&urdf, None, Some(TIP)).expect("the TIAGo chain");
    assert_eq!(arm.arm.joints.len(), 8);
    assert_eq!(arm.arm.joints[0].kind, JointKind::Prismatic);
    assert!(
        arm.arm.joints[1..]
            .iter()
            .all(|j| j.kind == JointKind::Revolute)
    );
    let names: Vec<String> = std::iter::once("torso_lift_joint".to_owned())
        .chain((1..=7).map(|i| format!("arm_{i}_joint")))
        .collect();
    assert_eq!(arm.joint_names, names);
    // Without the tip, the two leaves are named.
    let text = std::fs::read_to_string(&urdf).expect("the URDF");
    let e = arm_urdf::parse(&text, None, None).unwrap_err().to_string();
    assert!(
        e.contains("torso_fixed_column_link") && e.contains(TIP),
        "{e}"
    );
}

#[test]
fn a_real_tiago_calibrates_from_three_mocap_points_per_pose() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = data("tiago.urdf");
    let train = data("lrmcal/train-0.csv");
    let out = dir.path().join("cal");
    let identify = |extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--measurements",
            p(&train),
            "--arm",
            p(&urdf),
            "--tip-link",
            TIP,
            "--option",
            "kinematic",
            "--out",
            p(&out),
        ];
        args.extend_from_slice(extra);
        lrmcal(&args)
    };

    // Pose 2's torso lift is 0.18 mm above the URDF's 0.35 m: refused by
    // default, naming the flag that takes it.
    let refused = identify(&[]);
    assert_eq!(refused.status.code(), Some(3), "{}", text(&refused));
    assert!(
        text(&refused).contains("--allow-outside-limits"),
        "{}",
        text(&refused)
    );

    let run = identify(&["--allow-outside-limits"]);
    let printed = text(&run);
    assert!(run.status.success(), "{printed}");
    println!("{printed}");
    // The frame is a marker body on the mobile base: registration places the
    // nominal arm within millimetres (3.9 mm RMS measured).
    // `…, 3.9 mm after registration (largest 7.1 mm)`
    let after = printed
        .split(" mm after registration")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("the RMS after registration\n{printed}"));
    assert!(after < 5.0, "{after} mm after registration\n{printed}");

    let cal = out.join("calibration-kinematic.json");
    let (_, mean, printed) = validate(&cal, &data("lrmcal/test-0.csv"));
    println!("{printed}");
    assert!(
        mean < 1.2 * MEASURED_MEAN_MM,
        "held-out mean {mean} mm over points 1-3\n{printed}"
    );
    // Point 1 alone: "before" is the nominal arm as registration placed it
    // on the training poses (base and tool point); the calibration beats it.
    let (registered, mean, printed) = validate(&cal, &data("lrmcal/test-0-p1.csv"));
    println!("{printed}");
    assert!(
        mean < 1.2 * MEASURED_P1_MEAN_MM && mean < registered,
        "point 1: {registered} mm registered, {mean} mm calibrated\n{printed}"
    );
}

/// Few real poses and the default option: on seeded draws of 24 of the 34
/// poses (point 1), 10 held out, `identify` either refuses (exit 5, no
/// calibration file) or writes one that misses the held-out poses by no
/// more than the registered nominal arm does, within their noise. Before
/// the default sized its model from the data and refused what leaves the
/// arm worse, such draws wrote a diverged fit (56 mm RMS where
/// registration left 3.9 mm) and fits three to six times worse than the
/// registered arm.
#[test]
fn the_default_never_writes_a_calibration_worse_than_the_registered_arm() {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;

    let dir = tempfile::tempdir().unwrap();
    let all = std::fs::read_to_string(data("lrmcal/all-p1.csv")).unwrap();
    let mut lines = all.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    let mut poses: Vec<&str> = rows.iter().map(|r| r.split(',').next().unwrap()).collect();
    poses.dedup();
    assert_eq!(poses.len(), 34);
    let mut worst: f64 = 0.0;
    for seed in 1..=12u64 {
        let mut order = poses.clone();
        order.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
        let held: Vec<&str> = order[..10].to_vec();
        let write = |name: &str, keep: &dyn Fn(&str) -> bool| {
            let path = dir.path().join(format!("{name}-{seed}.csv"));
            let body: Vec<&str> = rows
                .iter()
                .copied()
                .filter(|r| keep(r.split(',').next().unwrap()))
                .collect();
            std::fs::write(&path, format!("{header}\n{}\n", body.join("\n"))).unwrap();
            path
        };
        let fit = write("fit", &|p| !held.contains(&p));
        let check = write("held", &|p| held.contains(&p));
        let out = dir.path().join(format!("cal-{seed}"));
        let run = lrmcal(&[
            "identify",
            "--measurements",
            p(&fit),
            "--arm",
            p(&data("tiago.urdf")),
            "--tip-link",
            TIP,
            "--allow-outside-limits",
            "--out",
            p(&out),
        ]);
        let printed = text(&run);
        let cal = out.join(common::default_calibration_file());
        if run.status.code() == Some(5) {
            assert!(
                !cal.exists(),
                "seed {seed}: refused, yet written\n{printed}"
            );
            continue;
        }
        assert!(run.status.success(), "seed {seed}\n{printed}");
        assert!(printed.contains("model: "), "seed {seed}\n{printed}");
        let (registered, calibrated, printed) = validate(&cal, &check);
        worst = worst.max(calibrated / registered);
        assert!(
            calibrated < 1.5 * registered,
            "seed {seed}: {registered} mm registered, {calibrated} mm calibrated\n{printed}"
        );
    }
    println!("worst held-out ratio to the registered arm: {worst:.2}");
}
