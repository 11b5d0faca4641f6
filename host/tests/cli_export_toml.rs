//! `lrmcal export --toml` run as a user runs it: a nominal arm, a URDF's
//! chain above all, written as lrmcal's own arm file to complete by hand.
//! Read back, the file is the arm it was written from, to the bit (the
//! URDF's chain, the bundled arms with their names, bodies and grid levels),
//! and `predict` puts the tool point where it does with the source; its header
//! says what a URDF could not say, and stays when `servo-tune` writes a curve
//! into the file. A calibration is refused, and nothing is written.

mod common;

use common::{lrmcal, p, text};

use std::path::{Path, PathBuf};

use lrmcal_core::io::arm_source::{ArmSource, bundled};
use lrmcal_core::io::arm_toml;

/// The bundled SO-101's URDF and the link its gripper point sits on.
fn so101_urdf() -> (PathBuf, &'static str) {
    (
        Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/so101/so101.urdf"),
        "gripper_frame_link",
    )
}

/// Runs `lrmcal export --toml` with `args` and `--out` in `dir`; the file written.
fn export_toml(dir: &Path, args: &[&str]) -> PathBuf {
    let out = dir.join("arm.toml");
    let mut all = vec!["export", "--toml"];
    all.extend_from_slice(args);
    all.extend(["--out", p(&out)]);
    let run = lrmcal(&all);
    assert!(run.status.success(), "{}", text(&run));
    out
}

#[test]
fn a_urdf_chain_written_as_an_arm_file_is_the_same_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (urdf, tip) = so101_urdf();
    let file = export_toml(dir.path(), &["--arm", p(&urdf), "--tip-link", tip]);
    let written = arm_toml::read(&file).expect("the written arm file reads back");
    let source = ArmSource::Urdf {
        path: urdf.clone(),
        base_link: None,
        tip_link: Some(tip.to_owned()),
    }
    .load()
    .unwrap();
    assert_eq!(written.arm, source.arm);
    assert_eq!(written.joint_names, source.joint_names);
    assert_eq!(written.collision, source.collision);
    let header = std::fs::read_to_string(&file).unwrap();
    for said in ["Not in a URDF", "no servo", "servo-tune", "compliances 0"] {
        assert!(header.contains(said), "the header does not say `{said}`");
    }

    // The same tool points through `predict`, from the file and from the URDF.
    let poses = dir.path().join("poses.csv");
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg\n1,0,0,0,0,0\n2,30,-40,50,-20,60\n3,-60,20,-30,45,-90\n",
    )
    .unwrap();
    let predict = |arm: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut args = vec!["predict", "--poses", p(&poses), "--out", p(&out)];
        args.extend_from_slice(arm);
        let run = lrmcal(&args);
        assert!(run.status.success(), "{}", text(&run));
        std::fs::read_to_string(out).unwrap()
    };
    assert_eq!(
        predict(&["--arm", p(&file)], "from-toml.csv"),
        predict(&["--arm", p(&urdf), "--tip-link", tip], "from-urdf.csv")
    );
}

#[test]
fn a_bundled_arm_written_out_reads_back_unchanged() {
    for name in ["lrm", "so101"] {
        let dir = tempfile::tempdir().unwrap();
        let file = export_toml(dir.path(), &["--arm", name]);
        let written = arm_toml::read(&file).expect("the written arm file reads back");
        assert_eq!(written, bundled(name).unwrap(), "{name}");
    }
    // Without --arm, the bundled arm; --name renames it.
    let dir = tempfile::tempdir().unwrap();
    let file = export_toml(dir.path(), &["--name", "my_arm"]);
    let written = arm_toml::read(&file).unwrap();
    assert_eq!(written.name, "my_arm");
    assert_eq!(written.arm, bundled("lrm").unwrap().arm);
}

#[test]
fn a_calibration_or_a_urdf_only_flag_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("arm.toml");
    let cal = dir.path().join("calibration.json");
    let run = lrmcal(&["export", "--toml", "--arm", p(&cal), "--out", p(&out)]);
    let said = text(&run);
    assert!(
        !run.status.success() && said.contains("nominal arm"),
        "{said}"
    );
    assert!(said.contains("--urdf"), "{said}");
    for flag in [
        vec!["--calibration", p(&cal)],
        vec!["--world"],
        vec!["--payload-kg", "0.1"],
    ] {
        let mut args = vec!["export", "--toml", "--out", p(&out)];
        args.extend(flag.iter().copied());
        let run = lrmcal(&args);
        assert_eq!(run.status.code(), Some(2), "{flag:?}: {}", text(&run));
        assert!(text(&run).contains("cannot be used with"), "{}", text(&run));
    }
    let run = lrmcal(&["export", "--out", p(&out)]);
    assert_eq!(run.status.code(), Some(2), "{}", text(&run));
    assert!(text(&run).contains("--urdf|--toml"), "{}", text(&run));
    assert!(!out.exists(), "a refused export wrote a file");
}

/// A servo curve tuned into the written file, as `servo-tune` writes it,
/// keeps the header and every other line; the file reads back with it.
#[test]
fn a_tuned_servo_curve_keeps_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let file = export_toml(dir.path(), &["--arm", "lrm"]);
    let before = std::fs::read_to_string(&file).unwrap();
    let angles = [-100.0f64, -50.0, 0.0, 50.0, 100.0].map(f64::to_radians);
    let curve = model::ServoCurve::new(&angles, &[902.0, 1274.0, 1648.0, 2027.0, 2399.0]).unwrap();
    arm_toml::write_servo(&file, 1, &curve).unwrap();
    let after = std::fs::read_to_string(&file).unwrap();
    let header = |t: &str| -> Vec<String> {
        t.lines()
            .take_while(|l| l.starts_with('#'))
            .map(str::to_owned)
            .collect()
    };
    assert!(header(&before).len() > 1);
    assert_eq!(header(&after), header(&before));
    // Its `[joint.servo]` table keeps its place: two lines, the knots, change.
    assert_eq!(before.lines().count(), after.lines().count());
    let changed = before
        .lines()
        .zip(after.lines())
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(changed, 2);
    assert_eq!(
        arm_toml::read(&file).unwrap().arm.joints[1].servo,
        Some(curve)
    );
}
