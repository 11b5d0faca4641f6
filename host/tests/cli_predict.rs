//! `lrmcal predict` run as a user runs it: positions agree with the model,
//! loads deflect the arm, bad input gives the documented exit code and a
//! message naming the file, and `--help` teaches.

mod common;

use common::lrmcal;
use model::testing::TEST_ARM_JOINTS as JOINTS;

use std::path::Path;
use std::process::Output;

use lrmcal_core::io::{arm_toml, predictions};

fn fixture() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/arm.toml")
        .to_str()
        .unwrap()
        .to_owned()
}

const POSES: &str = "# two poses\npose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\
                     1,0,0,0,0,0,0\n2,10,-60,45,30,-50,60\n";

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn predictions_match_the_model_and_loads_deflect() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    std::fs::write(&poses, POSES).unwrap();
    let (unloaded, loaded) = (dir.path().join("p0.csv"), dir.path().join("p1.csv"));
    let p = poses.to_str().unwrap();
    for (out, load) in [(&unloaded, "0"), (&loaded, "0.5")] {
        let run = lrmcal(&[
            "predict",
            "--arm",
            &fixture(),
            "--poses",
            p,
            "--load-kg",
            load,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(run.status.success(), "{}", stderr(&run));
    }
    let arm = arm_toml::read(Path::new(&fixture())).unwrap().arm;
    let chain = arm.chain();
    let q2 = [10.0f64, -60.0, 45.0, 30.0, -50.0, 60.0].map(f64::to_radians);
    let opts = model::SolverOptions::default();
    let p0 = predictions::read(&unloaded).unwrap();
    let p1 = predictions::read(&loaded).unwrap();
    assert_eq!(p0.iter().map(|p| p.pose).collect::<Vec<_>>(), [1, 2]);
    let expected0 = chain.tool_point(&q2, 0.0, &opts).unwrap();
    let expected1 = chain.tool_point(&q2, 0.5, &opts).unwrap();
    // Files carry 1e-6 mm.
    assert!((p0[1].position - expected0).norm() < 1e-8);
    assert!((p1[1].position - expected1).norm() < 1e-8);
    // The fixture is compliant: half a kilo moves the tool by millimetres.
    assert!((p1[1].position - p0[1].position).norm() > 1e-3);
}

#[test]
fn bundled_arm_is_the_default_and_stdout_the_default_output() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    std::fs::write(&poses, POSES).unwrap();
    let run = lrmcal(&["predict", "--poses", poses.to_str().unwrap()]);
    assert!(run.status.success(), "{}", stderr(&run));
    let text = String::from_utf8(run.stdout).unwrap();
    let rows = predictions::parse(&text).unwrap();
    let arm = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let expected = arm
        .chain()
        .tool_point(&[0.0; JOINTS], 0.0, &model::SolverOptions::default())
        .unwrap();
    assert!((rows[0].position - expected).norm() < 1e-8);
}

#[test]
fn pose_list_loads_are_used_and_must_not_conflict() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    let p = poses.to_str().unwrap();
    std::fs::write(&poses, "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,45,0,0,0,0\n1,0.5,0,45,0,0,0,0\n").unwrap();
    let run = lrmcal(&["predict", "--arm", &fixture(), "--poses", p]);
    assert_eq!(run.status.code(), Some(3));
    let msg = stderr(&run);
    assert!(
        msg.contains("poses.csv") && msg.contains("pose 1") && msg.contains("--load-kg"),
        "{msg}"
    );
    // One load for all resolves it (and the repeated pose is written once).
    let run = lrmcal(&[
        "predict",
        "--arm",
        &fixture(),
        "--poses",
        p,
        "--load-kg",
        "0.5",
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(String::from_utf8(run.stdout).unwrap().lines().count(), 2);
}

#[test]
fn bad_input_gives_exit_codes_and_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("typo.csv");
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,zero,0,0,0\n",
    )
    .unwrap();
    let run = lrmcal(&[
        "predict",
        "--arm",
        &fixture(),
        "--poses",
        poses.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(3));
    let msg = stderr(&run);
    assert!(
        msg.starts_with("error: failed to parse `") && msg.contains("typo.csv"),
        "{msg}"
    );
    assert!(
        msg.contains("line 2, column `q3_deg`") && msg.contains("`zero`"),
        "{msg}"
    );

    let missing = dir.path().join("absent.csv");
    let run = lrmcal(&["predict", "--poses", missing.to_str().unwrap()]);
    assert_eq!(run.status.code(), Some(4));
    assert!(stderr(&run).contains("absent.csv"));

    let run = lrmcal(&["predict", "--arm", "arm.yaml", "--poses", "x.csv"]);
    assert_eq!(run.status.code(), Some(2));
    assert!(stderr(&run).contains(".toml") && stderr(&run).contains(".json"));

    // A calibration file (.json) is a kind of arm file: a missing one is a file error.
    let run = lrmcal(&["predict", "--arm", "absent.json", "--poses", "x.csv"]);
    assert_eq!(run.status.code(), Some(4));
    assert!(stderr(&run).contains("absent.json"));

    let run = lrmcal(&["predict", "--poses", "x.csv", "--load-kg", "-1"]);
    assert_eq!(run.status.code(), Some(2));
}

#[test]
fn output_is_not_written_when_input_is_bad() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n2,0,0,0,0,0\n",
    )
    .unwrap();
    let out = dir.path().join("pred.csv");
    let run = lrmcal(&[
        "predict",
        "--poses",
        poses.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(3));
    assert!(!out.exists());
}

#[test]
fn help_teaches() {
    let top = String::from_utf8(lrmcal(&["--help"]).stdout).unwrap();
    assert!(
        top.contains("predict") && top.contains("Examples:") && top.contains("Exit codes"),
        "{top}"
    );
    let sub = String::from_utf8(lrmcal(&["predict", "--help"]).stdout).unwrap();
    assert!(
        sub.contains("--load-kg") && sub.contains("Examples:") && sub.contains("--arm"),
        "{sub}"
    );
}

#[test]
fn a_measurement_file_is_a_pose_list_and_limits_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let measured = dir.path().join("measured.csv");
    std::fs::write(
        &measured,
        "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n\
         1,0.5,0,0,0,0,0,0,1,2,3\n2,0.5,10,-60,45,30,-50,60,4,5,6\n",
    )
    .unwrap();
    let run = lrmcal(&[
        "predict",
        "--arm",
        &fixture(),
        "--poses",
        measured.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let rows = predictions::parse(&String::from_utf8(run.stdout).unwrap()).unwrap();
    // Its loads are the loads predicted with.
    let arm = arm_toml::read(Path::new(&fixture())).unwrap().arm;
    let q = [10.0f64, -60.0, 45.0, 30.0, -50.0, 60.0].map(f64::to_radians);
    let expected = arm
        .chain()
        .tool_point(&q, 0.5, &model::SolverOptions::default())
        .unwrap();
    assert!((rows[1].position - expected).norm() < 1e-8);

    // The fixture's limits are ±105°: 120° on joint 2 is refused, by line and column.
    let text = std::fs::read_to_string(&measured)
        .unwrap()
        .replace("2,0.5,10,-60", "2,0.5,10,120");
    std::fs::write(&measured, text).unwrap();
    let args = [
        "predict",
        "--arm",
        &fixture(),
        "--poses",
        measured.to_str().unwrap(),
    ];
    let run = lrmcal(&args);
    assert_eq!(run.status.code(), Some(3));
    let msg = stderr(&run);
    assert!(
        msg.contains("measured.csv")
            && msg.contains(
                "line 3, column `q2_deg`: pose 2: 120° is outside joint 2's limits [-105°, 105°]"
            ),
        "{msg}"
    );
    let run = lrmcal(&[&args[..], &["--allow-outside-limits"]].concat());
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("warning: 1 of the 2 rows"),
        "{}",
        stderr(&run)
    );
}
