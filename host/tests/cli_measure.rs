//! `lrmcal measure` for an arm our board does not drive, run as a user runs
//! it: no `--port`, the arm moved by hand or by its own controller. Each pose
//! is announced with its joint angles; a tracker line is the confirmation
//! (file or pipe), and the rows written carry the pose list's angles, in
//! the list's order, resumable like a board's run. A DTrack reading waits
//! for a confirmation on standard input; `--hold-s` needs the board.
//!
//! With `--joints` the angles are those the arm's controller reports it
//! reached: from a file, or standard input read record by record as the
//! controller writes them (each record the arm's word that it is there, a
//! DTrack reading taken after it), checked against the arm's limits,
//! resumable, and refused with the place of a bad record.

use std::io::Write;
use std::net::UdpSocket;
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::measurements;
use model::testing::TEST_ARM_JOINTS as JOINTS;

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .args(args)
        .env_remove("LRMCAL_PORT")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lrmcal runs")
}

fn lrmcal(args: &[&str], stdin: &str) -> Output {
    let mut child = spawn(args);
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

/// Joint angles a controller reports, with loads and angles no pose list
/// of ours would hold.
const REACHED: &str = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\
                       7,0.0663,10.123456,-20.5,30.25,0,45.000001,-60\n\
                       # the controller moved on\n\
                       8,0,-1.5,2.25,-3.125,4,5,6\n";

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The rows' pose ids and angles in degrees.
fn angles(rows: &[Measurement]) -> Vec<(u32, Vec<f64>)> {
    rows.iter()
        .map(|m| (m.pose.id, m.pose.q.iter().map(|q| q.to_degrees()).collect()))
        .collect()
}

fn assert_angles(rows: &[Measurement], want: &[(u32, [f64; JOINTS])]) {
    let got = angles(rows);
    assert_eq!(got.len(), want.len(), "{got:?}");
    for ((id, q), (want_id, want_q)) in got.iter().zip(want) {
        assert_eq!(id, want_id, "{got:?}");
        for (a, b) in q.iter().zip(want_q) {
            assert!((a - b).abs() < 1e-9, "{got:?}");
        }
    }
}

const Q7: [f64; JOINTS] = [10.123456, -20.5, 30.25, 0.0, 45.000001, -60.0];
const Q8: [f64; JOINTS] = [-1.5, 2.25, -3.125, 4.0, 5.0, 6.0];

#[test]
fn joint_angles_from_a_file_are_the_ones_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let joints = dir.path().join("reached.csv");
    let points = dir.path().join("points.txt");
    let out = dir.path().join("measured.csv");
    std::fs::write(&joints, REACHED).unwrap();
    std::fs::write(&points, "212.41 -35.02 188.77\n8 1 2 3\n").unwrap();
    let run = lrmcal(
        &[
            "measure",
            "--joints",
            s(&joints),
            "--tracker",
            s(&points),
            "--out",
            s(&out),
        ],
        "",
    );
    assert!(run.status.success(), "{}", stderr(&run));
    // A file is announced as a pose list is; the tracker line confirms.
    assert!(
        stderr(&run).contains(
            "pose 7: move the arm to q = (10.12, -20.50, 30.25, 0.00, 45.00, -60.00) deg with 0.0663 kg"
        ),
        "{}",
        stderr(&run)
    );
    let rows = measurements::read(&out).unwrap();
    assert_angles(&rows, &[(7, Q7), (8, Q8)]);
    assert_eq!(rows[0].load_kg, 0.0663);
    assert_eq!(rows[1].load_kg, 0.0);
    assert!((rows[0].position.x - 0.21241).abs() < 1e-12);
    assert!((rows[1].position.z - 0.003).abs() < 1e-12);
    // What `predict` and `identify` read it as: a pose list of the reached angles.
    let predicted = lrmcal(&["predict", "--poses", s(&out)], "");
    assert!(predicted.status.success(), "{}", stderr(&predicted));
    assert!(String::from_utf8_lossy(&predicted.stdout).contains("\n8,"));
}

/// Waits until `out` holds `rows` rows, at most 60 s.
fn wait_for_rows(out: &Path, rows: usize) -> Vec<Measurement> {
    let start = Instant::now();
    loop {
        if let Ok(read) = measurements::read(out)
            && read.len() >= rows
        {
            return read;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "`{}` never held {rows} rows",
            out.display()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn joint_angles_on_standard_input_are_measured_as_each_record_arrives() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.txt");
    let out = dir.path().join("measured.csv");
    std::fs::write(&points, "1 2 3\n4 5 6\n").unwrap();
    let mut child = spawn(&[
        "measure",
        "--joints",
        "-",
        "--tracker",
        s(&points),
        "--out",
        s(&out),
    ]);
    let mut stdin = child.stdin.take().unwrap();
    let (header_and_first, second) = REACHED.split_at(REACHED.find("# the").unwrap());
    stdin.write_all(header_and_first.as_bytes()).unwrap();
    stdin.flush().unwrap();
    // The first pose is recorded while the controller has not written the
    // second: the stream is not read to its end first.
    let rows = wait_for_rows(&out, 1);
    assert_angles(&rows, &[(7, Q7)]);
    stdin.write_all(second.as_bytes()).unwrap();
    drop(stdin);
    let run = child.wait_with_output().unwrap();
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).contains(
            "pose 8: the arm reached q = (-1.50, 2.25, -3.12, 4.00, 5.00, 6.00) deg with 0 kg"
        ),
        "{}",
        stderr(&run)
    );
    assert!(!stderr(&run).contains("move the arm"), "{}", stderr(&run));
    let rows = measurements::read(&out).unwrap();
    assert_angles(&rows, &[(7, Q7), (8, Q8)]);
    assert!((rows[1].position.y - 0.005).abs() < 1e-12);
}

#[test]
fn a_joint_stream_resumes_and_keeps_one_configuration_per_pose() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.txt");
    let out = dir.path().join("measured.csv");
    let args = [
        "measure",
        "--joints",
        "-",
        "--tracker",
        s(&points),
        "--out",
        s(&out),
    ];
    // One tracker position for two records: the first is kept.
    std::fs::write(&points, "1 2 3\n").unwrap();
    let run = lrmcal(&args, REACHED);
    assert!(!run.status.success());
    assert!(
        stderr(&run).contains("ended before pose 8"),
        "{}",
        stderr(&run)
    );
    assert_angles(&measurements::read(&out).unwrap(), &[(7, Q7)]);

    // The controller runs again: pose 7 is skipped, pose 8 measured.
    std::fs::write(&points, "4 5 6\n").unwrap();
    let run = lrmcal(&args, REACHED);
    assert!(run.status.success(), "{}", stderr(&run));
    let text = stderr(&run);
    assert!(
        text.contains(&format!(
            "pose 7 with 0.0663 kg: already in `{}`, skipped",
            out.display()
        )),
        "{text}"
    );
    let rows = measurements::read(&out).unwrap();
    assert_angles(&rows, &[(7, Q7), (8, Q8)]);
    assert!((rows[0].position.x - 0.001).abs() < 1e-12);

    // Pose 7 again under another load, but reached elsewhere: refused, as
    // the file would then give one id two configurations.
    let again =
        "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n7,0,10.2,-20.5,30.25,0,45,-60\n";
    let run = lrmcal(&args, again);
    assert_eq!(run.status.code(), Some(3));
    let text = stderr(&run);
    assert!(
        text.contains("record pose 7 of `<stdin>` (line 2)")
            && text.contains("already holds pose 7 with other joint angles"),
        "{text}"
    );
    assert_eq!(measurements::read(&out).unwrap().len(), 2);
}

#[test]
fn a_malformed_record_names_the_stream_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.txt");
    let out = dir.path().join("measured.csv");
    std::fs::write(&points, "1 2 3\n4 5 6\n").unwrap();
    let bad = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n2,0,1.5.0,0,0,0,0\n";
    let run = lrmcal(
        &[
            "measure",
            "--joints",
            "-",
            "--tracker",
            s(&points),
            "--out",
            s(&out),
        ],
        bad,
    );
    assert_eq!(run.status.code(), Some(3));
    assert_eq!(
        stderr(&run).lines().last().unwrap(),
        "error: failed to parse `<stdin>`: line 3, column `q2_deg`: expected a joint angle in \
         degrees, found `1.5.0`"
    );
    // The pose before it is saved.
    assert_eq!(measurements::read(&out).unwrap().len(), 1);

    // A file is named by its path; a short record by its line and widths.
    let joints = dir.path().join("reached.csv");
    std::fs::write(
        &joints,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\n5,1,2,3\n",
    )
    .unwrap();
    let run = lrmcal(
        &[
            "measure",
            "--joints",
            s(&joints),
            "--tracker",
            s(&points),
            "--out",
            s(&out),
        ],
        "",
    );
    assert_eq!(run.status.code(), Some(3));
    let text = stderr(&run);
    assert!(
        text.contains(&format!(
            "failed to parse `{}`: line 3: expected 7 fields as in the header, found 4",
            joints.display()
        )),
        "{text}"
    );
}

#[test]
fn joint_angles_outside_the_arms_limits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.txt");
    let out = dir.path().join("measured.csv");
    std::fs::write(&points, "1 2 3\n4 5 6\n").unwrap();
    let outside =
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,30,0,0,0,0,0\n2,0,0,0,0,-110,0\n";
    let args = [
        "measure",
        "--joints",
        "-",
        "--tracker",
        s(&points),
        "--out",
        s(&out),
    ];
    let run = lrmcal(&args, outside);
    assert_eq!(run.status.code(), Some(3));
    assert!(
        stderr(&run).contains(
            "failed to parse `<stdin>`: line 3, column `q5_deg`: pose 2: -110° is outside joint \
             5's limits [-105°, 105°]"
        ),
        "{}",
        stderr(&run)
    );
    assert_eq!(measurements::read(&out).unwrap().len(), 1);

    // The limits are --arm's: an arm whose first joint turns ±0.5 rad
    // refuses the 30° of pose 1 (kept from the run above).
    let narrow = dir.path().join("narrow.toml");
    let bundled = include_str!("../core/arms/lrm.toml");
    let wide = "limits = [-1.8325957145940461, 1.8325957145940461]";
    std::fs::write(&narrow, bundled.replacen(wide, "limits = [-0.5, 0.5]", 1)).unwrap();
    std::fs::remove_file(&out).unwrap();
    let mut with_arm = args.to_vec();
    with_arm.extend(["--arm", s(&narrow)]);
    let run = lrmcal(&with_arm, outside);
    assert!(
        stderr(&run).contains("line 2, column `q1_deg`: pose 1: 30° is outside joint 1's limits"),
        "{}",
        stderr(&run)
    );
    assert!(!out.exists());

    // --allow-outside-limits records them, with a warning.
    let mut allowed = args.to_vec();
    allowed.push("--allow-outside-limits");
    let run = lrmcal(&allowed, outside);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("warning: ") && stderr(&run).contains("-110°"),
        "{}",
        stderr(&run)
    );
    assert_eq!(measurements::read(&out).unwrap().len(), 2);
}

#[test]
fn joint_streams_refuse_what_cannot_go_with_them() {
    let dir = tempfile::tempdir().unwrap();
    let joints = dir.path().join("reached.csv");
    let poses = dir.path().join("poses.csv");
    let out = dir.path().join("measured.csv");
    std::fs::write(&joints, REACHED).unwrap();
    std::fs::write(&poses, POSES).unwrap();
    let refused = |args: &[&str], code: i32, says: &str| {
        let run = lrmcal(args, "");
        assert_eq!(run.status.code(), Some(code), "{args:?}: {}", stderr(&run));
        assert!(stderr(&run).contains(says), "{args:?}: {}", stderr(&run));
    };
    let j = s(&joints);
    let o = s(&out);
    refused(
        &["measure", "--joints", j, "--poses", s(&poses), "--out", o],
        2,
        "cannot be used with",
    );
    refused(
        &["measure", "--joints", j, "--hold-s", "1"],
        2,
        "cannot be used with",
    );
    // --arm and --allow-outside-limits check the angles of --joints.
    refused(
        &["measure", "--poses", s(&poses), "--out", o, "--arm", "lrm"],
        2,
        "cannot be used with",
    );
    refused(
        &["measure", "--out", o, "--allow-outside-limits"],
        2,
        "--joints",
    );
    refused(
        &[
            "measure",
            "--joints",
            j,
            "--out",
            o,
            "--tracker",
            "-",
            "--port",
            "/dev/null",
        ],
        3,
        "--joints is for an arm our board does not drive",
    );
    refused(
        &["measure", "--joints", "-", "--out", o, "--tracker", "-"],
        3,
        "--joints - reads the angles from standard input",
    );
    refused(
        &["measure", "--joints", "-", "--out", o],
        3,
        "--joints - reads the angles from standard input",
    );
    assert!(!out.exists());
}

/// A fake DTrack sending body 0 held at the position `at` holds (µm in
/// each axis: x, y = 2x, z = 3x), a frame every 4 ms until dropped.
struct Held {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Held {
    fn start(port: u16, at: Arc<AtomicU64>) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = stop.clone();
        let thread = std::thread::spawn(move || {
            let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
            let rot = "[1 0 0 0 1 0 0 0 1]";
            for frame in 0.. {
                if stopped.load(Ordering::Relaxed) {
                    break;
                }
                let x = at.load(Ordering::Relaxed) as f64 / 1000.0;
                let datagram = format!(
                    "fr {frame}\n6d 1 [0 1.000][{x} {} {}]{rot}\n",
                    2.0 * x,
                    3.0 * x
                );
                let _ = socket.send_to(datagram.as_bytes(), ("127.0.0.1", port));
                std::thread::sleep(Duration::from_millis(4));
            }
        });
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn a_streamed_record_is_the_arrival_a_dtrack_reading_waits_for() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("measured.csv");
    let port = UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let at = Arc::new(AtomicU64::new(100_000));
    let _dtrack = Held::start(port, at.clone());
    let tracker = format!("dtrack://127.0.0.1:{port}");
    let mut child = spawn(&[
        "measure",
        "--joints",
        "-",
        "--tracker",
        &tracker,
        "--body",
        "0",
        "--out",
        s(&out),
    ]);
    let mut stdin = child.stdin.take().unwrap();
    let (header_and_first, second) = REACHED.split_at(REACHED.find("# the").unwrap());
    stdin.write_all(header_and_first.as_bytes()).unwrap();
    stdin.flush().unwrap();
    let rows = wait_for_rows(&out, 1);
    assert!(
        (rows[0].position.x - 0.1).abs() < 1e-9,
        "{:?}",
        rows[0].position
    );
    // The arm moves on; its controller says so once it is there.
    at.store(150_000, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(50));
    stdin.write_all(second.as_bytes()).unwrap();
    drop(stdin);
    let run = child.wait_with_output().unwrap();
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(!stderr(&run).contains("press Enter"), "{}", stderr(&run));
    let rows = measurements::read(&out).unwrap();
    assert_angles(&rows, &[(7, Q7), (8, Q8)]);
    assert!((rows[1].position - nalgebra::Vector3::new(0.15, 0.3, 0.45)).norm() < 1e-9);
}
