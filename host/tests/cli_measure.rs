//! `lrmcal measure` for an arm our board does not drive, run as a user runs
//! it: no `--port`, the arm moved by hand or by its own controller. Each pose
//! is announced with its joint angles; a tracker line is the confirmation
//! (file or pipe), and the rows written carry the pose list's angles, in
//! the list's order, resumable like a board's run. A DTrack reading waits
//! for a confirmation on standard input; `--hold-s` needs the board.

use std::io::Write;
use std::process::{Command, Output, Stdio};

use lrmcal_core::io::measurements;

fn lrmcal(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .args(args)
        .env_remove("LRMCAL_PORT")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lrmcal runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(stdin.as_bytes())
        .expect("write stdin");
    child.wait_with_output().expect("lrmcal ends")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const POSES: &str = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\
                     4,0,10,20,30,40,50,60\n\
                     9,0.5,-10,0,15.5,0,-20,5\n\
                     2,0,0,0,0,0,0,0\n";

#[test]
fn positions_piped_for_an_arm_moved_by_its_own_controller() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    let out = dir.path().join("measured.csv");
    std::fs::write(&poses, POSES).unwrap();
    let args = [
        "measure",
        "--poses",
        poses.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--tracker",
        "-",
    ];

    // Two positions, then the pipe ends: both rows are kept.
    let run = lrmcal(&args, "200 -30 180\n201.5,-31,181\n");
    assert!(!run.status.success());
    let text = stderr(&run);
    assert!(
        text.contains(
            "pose 4: move the arm to q = (10.00, 20.00, 30.00, 40.00, 50.00, 60.00) deg with 0 kg"
        ),
        "{text}"
    );
    assert!(text.contains("ended before pose 2"), "{text}");
    let rows = measurements::read(&out).unwrap();
    assert_eq!(rows.len(), 2);

    // Run again: the recorded poses are skipped, the last one is taken.
    let run = lrmcal(&args, "5 6 7\n");
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(!stderr(&run).contains("pose 4:"), "{}", stderr(&run));
    let rows = measurements::read(&out).unwrap();
    let ids: Vec<u32> = rows.iter().map(|m| m.pose.id).collect();
    assert_eq!(ids, [4, 9, 2]);
    assert_eq!(rows[1].load_kg, 0.5);
    let q_deg = rows[1].pose.q.map(f64::to_degrees);
    for (got, want) in q_deg.iter().zip([-10.0, 0.0, 15.5, 0.0, -20.0, 5.0]) {
        assert!((got - want).abs() < 1e-9, "{q_deg:?}");
    }
    assert!((rows[2].position.x - 0.005).abs() < 1e-12);
}

#[test]
fn a_dtrack_reading_waits_for_the_arm_to_be_confirmed_and_hold_needs_the_board() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    std::fs::write(&poses, POSES).unwrap();
    let out = dir.path().join("measured.csv");
    // Nothing on standard input: no confirmation comes, nothing is recorded.
    let run = lrmcal(
        &[
            "measure",
            "--poses",
            poses.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--tracker",
            "dtrack://127.0.0.1:0",
            "--body",
            "0",
        ],
        "",
    );
    assert!(!run.status.success());
    let text = stderr(&run);
    assert!(text.contains("then press Enter"), "{text}");
    assert!(
        text.contains("wait for the arm at pose 4: standard input ended"),
        "{text}"
    );
    assert!(!out.exists());

    let run = lrmcal(
        &[
            "measure",
            "--poses",
            poses.to_str().unwrap(),
            "--hold-s",
            "1",
        ],
        "",
    );
    assert!(!run.status.success());
    assert!(stderr(&run).contains("pass --port"), "{}", stderr(&run));
}
