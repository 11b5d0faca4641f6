//! An industrial-scale arm through the CLI as a user would run it: a
//! UR10-like arm (links near a metre, kilograms of mass, limits of ±360° and
//! ±400°, no servo tables) is planned, simulated, calibrated and predicted,
//! and the board commands refuse it, naming the joint without a servo table.

mod common;

use common::lrmcal;

use std::path::{Path, PathBuf};
use std::process::Output;

use lrmcal_core::io::{arm_toml, pose_list, predictions};
use serde_json::Value;

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
    // The grid's survivors (ids below 729; the random poses off it follow).
    let rows = pose_list::read(&out).unwrap();
    let kept = rows.iter().filter(|r| r.pose.id < 729).count();
    assert!((150..=450).contains(&kept), "{text}");
    assert!(
        text.contains(&format!("{kept} of 729 grid poses kept")),
        "{text}"
    );
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
    // The simulator's default compliances sag an arm like a printed one
    // (scaled to its torques); an industrial one is a thousand times stiffer.
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
    // --dry-run makes the same checks without a board.
    let run = lrmcal(&["push", s(&file), "--dry-run"]);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("joint 1 has no servo curve"),
        "{}",
        stderr(&run)
    );
    let run = lrmcal(&[&["servo-tune", "3", "--arm", s(&arm)][..], &port].concat());
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    let msg = stderr(&run);
    assert!(
        msg.contains("joint 3 (`elbow`) has no `servo` table"),
        "{msg}"
    );
}

/// The held-out mean error (mm) before and after of each option in a report.
fn held_out_mm(report: &Path) -> Vec<(String, f64, f64)> {
    let r: Value = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    r["options"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            let v = &o["validation"];
            (
                o["option"].as_str().unwrap().to_string(),
                v["before"]["mean_m"].as_f64().unwrap() * 1e3,
                v["after"]["mean_m"].as_f64().unwrap() * 1e3,
            )
        })
        .collect()
}

/// The UR10-like arm with an industrial arm's stiffness (1e-6..5e-6
/// rad/Nm, parallel joints 2-4 separated only by micro-radians of sag), 5 kg
/// on the tool and 0.2 mm tracker noise: every option fits from 60 selected
/// poses; the kinematic and the elasto-kinematic one reach the noise on the
/// held-out poses; the elastic one alone cannot move geometry but makes
/// nothing worse. Nothing the data cannot determine is fitted: no standard
/// deviation is infinite or beyond a metre (or a radian).
#[test]
fn every_option_fits_an_industrial_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (candidates, measured, cal) = (
        dir.path().join("c.csv"),
        dir.path().join("m.csv"),
        dir.path().join("cal"),
    );
    let arm = arm_file();
    let run = lrmcal(&["plan", "--arm", s(&arm), "--out", s(&candidates)]);
    assert!(run.status.success(), "{}", stderr(&run));
    let run = lrmcal(&[
        "simulate",
        "--arm",
        s(&arm),
        "--poses",
        s(&candidates),
        "--loads",
        "5",
        "--joint-compliance",
        "1e-6,5e-6",
        "--base-compliance",
        "1e-7,1e-6",
        "--softening-per-nm",
        "0",
        "--servo-error-deg",
        "0",
        "--backlash-deg",
        "0",
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
        "all",
        "--out",
        s(&cal),
    ]);
    let out = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(run.status.success(), "{}{out}", stderr(&run));
    let errors = held_out_mm(&cal.join("report.json"));
    assert_eq!(errors.len(), 4, "{errors:?}");
    for (option, before, after) in &errors {
        assert!(*before > 10.0, "{errors:?}");
        match option.as_str() {
            "elastic" => assert!(*after < 1.02 * before, "{errors:?}"),
            _ => assert!(*after < 0.45, "{option}: {errors:?}\n{out}"),
        }
    }
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(cal.join("report.json")).unwrap()).unwrap();
    for o in r["options"].as_array().unwrap() {
        for p in o["fit"]["parameters"].as_array().unwrap() {
            if let Some(std) = p["std"].as_f64() {
                assert!(std.is_finite() && std < 1.0, "{p}");
            }
        }
    }
}

/// With the defaults, the simulator draws an industrial arm's compliances
/// to sag it like a printed arm, not a thousand times more: the deflection
/// converges and the arm is measured.
#[test]
fn the_simulator_defaults_fit_an_industrial_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (poses, measured, truth) = (
        dir.path().join("p.csv"),
        dir.path().join("m.csv"),
        dir.path().join("t.json"),
    );
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n2,30,-45,60,-90,90,0\n3,0,-90,0,-90,0,0\n",
    )
    .unwrap();
    let run = lrmcal(&[
        "simulate",
        "--arm",
        s(&arm_file()),
        "--poses",
        s(&poses),
        "--loads",
        "0,5",
        "--out",
        s(&measured),
        "--truth",
        s(&truth),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let t: Value = serde_json::from_str(&std::fs::read_to_string(&truth).unwrap()).unwrap();
    let k = t["config"]["joint_compliance"].as_array().unwrap();
    let (lo, hi) = (k[0].as_f64().unwrap(), k[1].as_f64().unwrap());
    // The bundled arm's 0.08..0.2 rad/Nm over a torque ratio of a few hundred.
    assert!(
        (1e-4..1e-3).contains(&lo) && (hi / lo - 2.5).abs() < 1e-9,
        "{lo} {hi}"
    );
}
