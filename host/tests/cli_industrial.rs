//! An industrial-scale arm through the CLI as a user would run it: a
//! UR10-like arm (links near a metre, kilograms of mass, limits of ±360° and
//! ±400°, no servo tables) is planned, simulated, calibrated and predicted,
//! and the board commands refuse it, naming the joint without a servo table.

mod common;

use common::lrmcal;

use std::path::{Path, PathBuf};
use std::process::Output;

use host::io::{arm_toml, pose_list, predictions};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn arm_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ur10_like.toml")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn plan_keeps_a_sensible_share_of_an_industrial_arm() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.csv");
    let run = lrmcal(&["plan", "--arm", s(&arm_file()), "--out", s(&out)]);
    let text = stderr(&run);
    assert!(run.status.success(), "{text}");
    let kept = pose_list::read(&out).unwrap().len();
    assert!((150..=450).contains(&kept), "{text}");
    // The shoulder lifts the upper arm 100° up or down from the horizontal:
    // down, it meets the floor in a third of the grid, whatever else moves.
    assert!(
        text.contains("243  link 2 too close to the ground"),
        "{text}"
    );
    // Joint limits of ±360° leave the grid whole.
    assert!(text.contains("joint limits:         0"), "{text}");
}

#[test]
fn predict_uses_the_wide_limits_and_refuses_beyond_them() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,note_where\n\
         1,0,-90,0,-90,0,0,up\n\
         2,350,-45,60,-360,90,400,wound\n",
    )
    .unwrap();
    let out = dir.path().join("p.csv");
    let run = lrmcal(&[
        "predict",
        "--arm",
        s(&arm_file()),
        "--poses",
        s(&poses),
        "--load-kg",
        "5",
        "--out",
        s(&out),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let arm = arm_toml::read(&arm_file()).unwrap().arm;
    let chain = arm.chain();
    let options = model::SolverOptions::default();
    let q = [350.0f64, -45.0, 60.0, -360.0, 90.0, 400.0].map(f64::to_radians);
    let rows = predictions::read(&out).unwrap();
    let expected = chain.tool_point(&q, 5.0, &options).unwrap();
    assert!((rows[1].position - expected).norm() < 1e-8);
    // Upper arm, forearm and wrist straight up: 0.127 + 0.612 + 0.572 +
    // 0.116 = 1.427 m above the base.
    assert!(
        (rows[0].position.z - 1.427).abs() < 1e-3,
        "{:?}",
        rows[0].position
    );
    // 5 kg at a metre bends the arm by millimetres: the masses are in kg, not grams.
    let rigid = chain.rigid_tool_point(&q);
    let sag_mm = (expected - rigid).norm() * 1e3;
    assert!((0.1..50.0).contains(&sag_mm), "{sag_mm} mm");

    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n2,0,0,0,0,0,410\n",
    )
    .unwrap();
    let run = lrmcal(&["predict", "--arm", s(&arm_file()), "--poses", s(&poses)]);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    let msg = stderr(&run);
    assert!(
        msg.contains("poses.csv")
            && msg.contains("line 3, column `q6_deg`")
            && msg.contains("410° is outside joint 6's limits [-400°, 400°]")
            && msg.contains("--allow-outside-limits"),
        "{msg}"
    );
    let run = lrmcal(&[
        "predict",
        "--arm",
        s(&arm_file()),
        "--poses",
        s(&poses),
        "--allow-outside-limits",
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).starts_with("warning: 1 of the 2 rows"),
        "{}",
        stderr(&run)
    );
    assert_eq!(String::from_utf8_lossy(&run.stdout).lines().count(), 3);
}

#[test]
fn an_arm_without_servo_tables_is_calibrated_but_never_sent_to_the_board() {
    let dir = tempfile::tempdir().unwrap();
    let (candidates, measured, cal) = (
        dir.path().join("c.csv"),
        dir.path().join("m.csv"),
        dir.path().join("cal"),
    );
    let arm = arm_file();
    let run = lrmcal(&["plan", "--arm", s(&arm), "--out", s(&candidates)]);
    assert!(run.status.success(), "{}", stderr(&run));
    // The simulator's default compliances are a printed arm's; an
    // industrial one is a hundred thousand times stiffer.
    let run = lrmcal(&[
        "simulate",
        "--arm",
        s(&arm),
        "--poses",
        s(&candidates),
        "--loads",
        "5",
        "--joint-compliance",
        "1e-7,1e-5",
        "--base-compliance",
        "1e-7,1e-6",
        "--out",
        s(&measured),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let run = lrmcal(&[
        "identify",
        "--arm",
        s(&arm),
        "--measurements",
        s(&measured),
        "--candidates",
        s(&candidates),
        "--select",
        "60",
        "--option",
        "elastic",
        "--out",
        s(&cal),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let file = std::fs::read_dir(&cal)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("calibration")
        })
        .expect("a calibration file");
    // Its calibrated arm predicts like any other.
    let run = lrmcal(&["predict", "--arm", s(&file), "--poses", s(&candidates)]);
    assert!(run.status.success(), "{}", stderr(&run));

    // The board is never reached: the refusal comes first, naming the joint.
    let port = ["--port", "socket://127.0.0.1:9"];
    let run = lrmcal(&[&["push", s(&file)][..], &port].concat());
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    let msg = stderr(&run);
    assert!(
        msg.contains("joint 1 has no servo curve") && msg.contains("`servo` table"),
        "{msg}"
    );
    let run = lrmcal(&[&["servo-tune", "3", "--arm", s(&arm)][..], &port].concat());
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    let msg = stderr(&run);
    assert!(
        msg.contains("joint 3 (`elbow`) has no `servo` table"),
        "{msg}"
    );
}
