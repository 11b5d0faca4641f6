//! The `lrmcal` device commands against the firmware library served on a
//! local TCP socket (`socket://127.0.0.1:PORT`, the same code path the
//! emulator uses): push, status, payload, compensation, move (to joint
//! angles and to a point), pull, detach, and the error a user sees when the
//! board refuses.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpListener;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use host::commands::device_args::DeviceArgs;
use host::commands::{compensation, detach, move_, payload, pull, push, status};
use lrmcal_core::io::calibration_file::{CalibrationFile, ErrorStats, SCHEMA, SCHEMA_VERSION};
use lrmcal_engine::device::memory::MemoryBoard;
use protocol::CompensationMode;
use protocol::frame::MAX_FRAME;

/// A board on a local socket: the in-memory board behind a TCP bridge, one
/// connection at a time (each command opens its own), servo frames every
/// 20 ms of wall time. Stops when dropped.
struct SocketBoard {
    port: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl SocketBoard {
    fn start() -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = format!("socket://{}", listener.local_addr().unwrap());
        listener.set_nonblocking(true).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = stop.clone();
        let thread = std::thread::spawn(move || {
            let t0 = Instant::now();
            let mut board = MemoryBoard::default();
            // Bounded: a test that forgets to stop the board still ends.
            while !stopped.load(Ordering::Relaxed) && t0.elapsed() < Duration::from_secs(120) {
                let Ok((mut stream, _)) = listener.accept() else {
                    std::thread::sleep(Duration::from_millis(2));
                    continue;
                };
                stream
                    .set_read_timeout(Some(Duration::from_millis(2)))
                    .unwrap();
                let mut buf = [0u8; 512];
                loop {
                    // A servo frame for every 20 ms of wall time.
                    while board.now_us() + 20_000 <= t0.elapsed().as_micros() as u64 {
                        board.frame();
                    }
                    let n = match stream.read(&mut buf) {
                        Ok(0) => break,
                        Ok(n) => n,
                        Err(e)
                            if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) =>
                        {
                            continue;
                        }
                        Err(_) => break,
                    };
                    board.write_all(&buf[..n]).unwrap();
                    let mut out = [0u8; MAX_FRAME];
                    while let Ok(m) = board.read(&mut out) {
                        if stream.write_all(&out[..m]).is_err() {
                            break;
                        }
                    }
                }
            }
        });
        Self {
            port,
            stop,
            thread: Some(thread),
        }
    }

    fn args(&self) -> DeviceArgs {
        DeviceArgs {
            port: self.port.clone(),
            timeout_ms: 500,
            retries: 2,
        }
    }
}

impl Drop for SocketBoard {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn calibration_json(dir: &std::path::Path) -> std::path::PathBuf {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let mut arm = nominal;
    arm.joints[1].theta += 0.01;
    arm.joints[2].compliance += 0.05;
    arm.joints[0].servo.as_mut().unwrap().pulses_us_mut()[1] = 1630.0;
    let file = CalibrationFile {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        option: lrmcal_engine::calib::ModelOption::ElastoKinematicServo,
        nominal,
        arm,
        parameters: vec![],
        at_bound: vec![],
        removed: vec![],
        poses_used: vec![],
        loads_kg: vec![],
        fit_residual: ErrorStats::of(&[0.001]),
        converged: true,
        arm_name: None,
        joint_names: vec![],
        validation: None,
        targets: vec![],
        registration: None,
    };
    let path = dir.join("calibration.json");
    std::fs::write(&path, file.to_json()).unwrap();
    path
}

#[test]
fn device_commands_drive_a_board_on_a_socket() {
    let board = SocketBoard::start();
    let dir = tempfile::tempdir().unwrap();

    // Refused before a calibration exists: a clear message and exit code 6.
    let err = compensation::run(&compensation::Args {
        mode: compensation::Mode::Full,
        device: board.args(),
    })
    .unwrap_err();
    assert_eq!(err.exit_code(), 6);
    assert_eq!(
        err.report(),
        "error: failed to talk to the board: `comp/mode`: the board said: no valid calibration on the board"
    );

    let cal = calibration_json(dir.path());
    push::run(&push::Args {
        calibration: cal.clone(),
        home_deg: None,
        target: None,
        dry_run: false,
        device: Some(board.args()),
    })
    .unwrap();
    payload::run(&payload::Args {
        kg: 0.0663,
        device: board.args(),
    })
    .unwrap();
    compensation::run(&compensation::Args {
        mode: compensation::Mode::Full,
        device: board.args(),
    })
    .unwrap();
    move_::run(&move_::Args {
        angles_deg: vec![10.0, 20.0, -30.0, 0.0, 40.0, 0.0],
        xyz: None,
        dry_run: false,
        from_deg: None,
        arm: None,
        calibration: None,
        load_kg: 0.0,
        ground_z_mm: 0.0,
        no_ground: false,
        clearance_mm: 10.0,
        duration_ms: Some(300),
        speed_deg_s: None,
        no_wait: false,
        device: Some(board.args()),
    })
    .unwrap();

    let mut client = board.args().connect().unwrap();
    let s = client.status().unwrap();
    assert!(!s.moving);
    assert_eq!(s.mode, CompensationMode::Full);
    assert!((s.payload_kg - 0.0663).abs() < 1e-7);
    let want = [10.0f32, 20.0, -30.0, 0.0, 40.0, 0.0].map(f32::to_radians);
    assert_eq!(s.nominal_rad, want);
    assert!(s.pulses_us.iter().all(|&p| (500..=2500).contains(&p)));
    // The board keeps the option the file names, ours, and `status` shows it.
    assert_eq!(
        s.calibration.map(|c| c.option),
        Some(protocol::ModelOption::ElastoKinematicServo)
    );
    let shown = status::render(&s);
    assert!(
        shown.contains("(elasto-kinematic-servo, 6 joints)"),
        "{shown}"
    );
    drop(client);

    let out = dir.path().join("pulled.json");
    pull::run(&pull::Args {
        out: Some(out.clone()),
        device: board.args(),
    })
    .unwrap();
    let pulled: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(pulled["option"], "elasto-kinematic-servo");
    assert_eq!(
        pulled["calibrated"]["joints"][0]["servo"]["pulses_us"][1],
        1630.0
    );
    let id = s.calibration.unwrap().id;
    assert_eq!(pulled["id"], format!("{id:08x}"));

    detach::run(&detach::Args {
        joint: None,
        attach: false,
        device: board.args(),
    })
    .unwrap();
    let s = board.args().connect().unwrap().status().unwrap();
    assert_eq!(s.pulses_us, [0; 6]);
}

#[test]
fn a_port_nobody_listens_on_says_so() {
    let port = {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap()
    };
    let args = DeviceArgs {
        port: format!("socket://{port}"),
        timeout_ms: 100,
        retries: 0,
    };
    let err = payload::run(&payload::Args {
        kg: 0.0,
        device: args,
    })
    .unwrap_err();
    assert_eq!(err.exit_code(), 6);
    assert!(
        err.report().contains("is the board plugged in?"),
        "{}",
        err.report()
    );
}

/// A pose list of three poses 1, 2, 3 in `dir`.
fn three_poses(dir: &std::path::Path) -> std::path::PathBuf {
    let poses = dir.join("poses.csv");
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\
         1,0,10,-20,0,30,0\n\
         2,5,15,-25,0,35,0\n\
         3,-5,5,-15,0,25,0\n",
    )
    .unwrap();
    poses
}

/// `measure --capture`: the board drives the arm to each pose of the list,
/// and only then the capture command takes its image (here a command that
/// copies a grey image and notes the pose it was run at); the list naming
/// the images is written, and the board stands at the last pose.
#[test]
fn measure_captures_an_image_at_each_pose_the_board_reaches() {
    use host::commands::measure;
    let board = SocketBoard::start();
    let dir = tempfile::tempdir().unwrap();
    let poses = three_poses(dir.path());
    let out = dir.path().join("shots.csv");
    let order = dir.path().join("order.txt");
    let grey = dir.path().join("grey.png");
    image::GrayImage::from_pixel(64, 48, image::Luma([128]))
        .save(&grey)
        .unwrap();
    let args = measure::Args {
        poses: Some(poses.clone()),
        joints: None,
        arm: None,
        allow_outside_limits: false,
        out: Some(out.clone()),
        load_kg: Some(0.0663),
        tracker: None,
        hold_s: None,
        settle_ms: 0,
        capture: Some(format!(
            "cp {} {{image}} && echo {{pose}} >> {}",
            grey.display(),
            order.display()
        )),
        webcam: None,
        webcam_size: (1280, 720),
        capture_frames: 1,
        images: Some(dir.path().join("shots")),
        board: None,
        dtrack: dtrack_args(None),
        device: Some(board.args()),
    };
    measure::run(&args).unwrap();
    assert_eq!(std::fs::read_to_string(&order).unwrap(), "1\n2\n3\n");
    let shots = lrmcal_core::camera::shots::read(&out).unwrap();
    let named: Vec<(u32, f64, &str)> = shots
        .iter()
        .map(|s| (s.pose.id, s.load_kg, s.image.as_str()))
        .collect();
    assert_eq!(
        named,
        [
            (1, 0.0663, "pose1-0.0663kg.png"),
            (2, 0.0663, "pose2-0.0663kg.png"),
            (3, 0.0663, "pose3-0.0663kg.png")
        ]
    );
    assert!(dir.path().join("shots/pose3-0.0663kg.png").is_file());
    let s = board.args().connect().unwrap().status().unwrap();
    let want = [-5.0f32, 5.0, -15.0, 0.0, 25.0, 0.0].map(f32::to_radians);
    assert!(
        s.nominal_rad
            .iter()
            .zip(&want)
            .all(|(a, b)| (a - b).abs() < 1e-6)
    );
}

#[test]
fn measure_records_each_pose_and_resumes_after_an_interruption() {
    use host::commands::measure;
    let board = SocketBoard::start();
    let dir = tempfile::tempdir().unwrap();
    let poses = three_poses(dir.path());
    let out = dir.path().join("measured.csv");
    let tracker = dir.path().join("tracker.txt");
    let args = |tracker: &std::path::Path| measure::Args {
        poses: Some(poses.clone()),
        joints: None,
        arm: None,
        allow_outside_limits: false,
        out: Some(out.clone()),
        load_kg: Some(0.0663),
        tracker: Some(measure::TrackerSource::File(tracker.to_owned())),
        hold_s: None,
        settle_ms: 0,
        capture: None,
        webcam: None,
        webcam_size: (1280, 720),
        capture_frames: 3,
        images: None,
        board: None,
        dtrack: dtrack_args(None),
        device: Some(board.args()),
    };

    // The tracker file runs out after two poses: the run stops, both rows are kept.
    std::fs::write(
        &tracker,
        "x_mm,y_mm,z_mm\n200.5 -30.25 180\n201,-31,181.5\n",
    )
    .unwrap();
    let err = measure::run(&args(&tracker)).unwrap_err();
    assert!(
        err.report().contains("ended before pose 3"),
        "{}",
        err.report()
    );
    let rows = lrmcal_core::io::measurements::read(&out).unwrap();
    assert_eq!(
        rows.iter().map(|m| m.pose.id).collect::<Vec<_>>(),
        vec![1, 2]
    );
    assert!((rows[0].position.x - 0.2005).abs() < 1e-12 && rows[1].load_kg == 0.0663);

    // Run again: only pose 3 is measured (its line names it), rows 1 and 2 stay.
    std::fs::write(&tracker, "3 199 -29 179\n").unwrap();
    measure::run(&args(&tracker)).unwrap();
    let rows = lrmcal_core::io::measurements::read(&out).unwrap();
    assert_eq!(
        rows.iter().map(|m| m.pose.id).collect::<Vec<_>>(),
        vec![1, 2, 3]
    );
    assert!((rows[2].position.z - 0.179).abs() < 1e-12);
    // The board ended at pose 3.
    let s = board.args().connect().unwrap().status().unwrap();
    let want = [-5.0f32, 5.0, -15.0, 0.0, 25.0, 0.0].map(f32::to_radians);
    assert!(
        s.nominal_rad
            .iter()
            .zip(&want)
            .all(|(a, b)| (a - b).abs() < 1e-6)
    );
}

/// `measure`'s DTrack options as clap defaults them, reading `body`.
fn dtrack_args(body: Option<u32>) -> host::commands::measure::DTrackArgs {
    host::commands::measure::DTrackArgs {
        body,
        marker: None,
        frames: 20,
        max_spread_mm: 0.5,
        max_lost: 120,
        tracker_timeout_s: 2.0,
    }
}

/// A fake ART DTrack sending body 0 at `mm` (with 0.05 mm of jitter and every
/// 10th frame without the body) at 250 Hz to `to`, until `stop` is set.
fn dtrack_sender(to: std::net::SocketAddr, mm: [f64; 3], stop: Arc<AtomicBool>) -> JoinHandle<()> {
    use rand::{Rng, SeedableRng};
    std::thread::spawn(move || {
        let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut frame = 0u64;
        while !stop.load(Ordering::Relaxed) {
            let [x, y, z] = mm.map(|v| v + rng.random_range(-0.087..0.087));
            let body = if frame % 10 == 9 {
                String::from("6d 0")
            } else {
                format!("6d 1 [0 1.000][{x:.3} {y:.3} {z:.3}][1 0 0 0 1 0 0 0 1]")
            };
            let datagram = format!(
                "fr {frame}\r\nts {:.6}\r\n6dcal 1\r\n{body}\r\n",
                frame as f64 / 250.0
            );
            let _ = socket.send_to(datagram.as_bytes(), to);
            frame += 1;
            std::thread::sleep(Duration::from_millis(4));
        }
    })
}

#[test]
fn measure_reads_a_dtrack_stream_and_keeps_the_poses_when_it_stops() {
    use host::commands::measure;
    let board = SocketBoard::start();
    let dir = tempfile::tempdir().unwrap();
    let poses = three_poses(dir.path());
    let out = dir.path().join("measured.csv");
    // A free port for the listener: bind, note it, let go.
    let addr = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let args = measure::Args {
        poses: Some(poses.clone()),
        joints: None,
        arm: None,
        allow_outside_limits: false,
        out: Some(out.clone()),
        load_kg: None,
        tracker: Some(measure::TrackerSource::parse(&format!("dtrack://{addr}")).unwrap()),
        hold_s: None,
        settle_ms: 0,
        capture: None,
        webcam: None,
        webcam_size: (1280, 720),
        capture_frames: 3,
        images: None,
        board: None,
        dtrack: dtrack_args(Some(0)),
        device: Some(board.args()),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let sender = dtrack_sender(addr, [212.41, -35.02, 188.77], stop.clone());
    // Stop the stream once the first pose is on disk.
    let run =
        std::thread::spawn(move || measure::run(&args).map_err(|e| (e.exit_code(), e.report())));
    let t0 = Instant::now();
    while lrmcal_core::io::measurements::read(&out).map_or(true, |rows| rows.is_empty()) {
        assert!(t0.elapsed() < Duration::from_secs(60), "no pose recorded");
        std::thread::sleep(Duration::from_millis(5));
    }
    stop.store(true, Ordering::Relaxed);
    sender.join().unwrap();
    let (code, report) = run.join().unwrap().unwrap_err();
    assert_eq!(code, 6);
    assert!(
        report.starts_with(&format!(
            "error: failed to read body 0 from the DTrack stream on {addr}: "
        )),
        "{report}"
    );
    assert!(
        report.contains("the stream stopped: no frame for"),
        "{report}"
    );
    let rows = lrmcal_core::io::measurements::read(&out).unwrap();
    assert_eq!(rows.iter().map(|m| m.pose.id).collect::<Vec<_>>(), vec![1]);
    let p = rows[0].position * 1000.0;
    let error_mm = ((p.x - 212.41).powi(2) + (p.y + 35.02).powi(2) + (p.z - 188.77).powi(2)).sqrt();
    assert!(error_mm < 0.05, "{error_mm} mm");
}

#[test]
fn push_refuses_a_calibration_the_board_could_not_run_before_connecting() {
    let dir = tempfile::tempdir().unwrap();
    let path = calibration_json(dir.path());
    let mut file = CalibrationFile::read(&path).unwrap();
    let d = |x: f64| x.to_radians();
    file.arm.joints[1].servo = model::ServoCurve::new(
        &[d(-100.0), d(-50.0), d(0.0), d(50.0), d(100.0)],
        &[900.0, 1280.0, 1650.0, 1600.0, 2400.0],
    )
    .ok();
    std::fs::write(&path, file.to_json()).unwrap();
    // Nobody listens on this port: the check must come first.
    let device = DeviceArgs {
        port: "socket://127.0.0.1:1".into(),
        timeout_ms: 100,
        retries: 0,
    };
    let err = push::run(&push::Args {
        calibration: path.clone(),
        home_deg: None,
        target: None,
        dry_run: false,
        device: Some(device),
    })
    .unwrap_err();
    // --dry-run refuses it alike, without a board.
    let dry = push::run(&push::Args {
        calibration: path,
        home_deg: None,
        target: None,
        dry_run: true,
        device: None,
    })
    .unwrap_err();
    assert_eq!(dry.report(), err.report());
    assert_eq!(err.exit_code(), 3);
    let report = err.report();
    assert!(
        report.contains("joint 2: the servo curve does not map angle to pulse one-to-one")
            && report.contains("from knot 3 to knot 4")
            && report.contains("50.00° 1600 µs")
            && report.contains("not sent"),
        "{report}"
    );
}

#[test]
fn push_refuses_a_play_wider_than_a_few_degrees_naming_the_joint() {
    let dir = tempfile::tempdir().unwrap();
    let path = calibration_json(dir.path());
    let mut file = CalibrationFile::read(&path).unwrap();
    file.arm.joints[2].backlash = 7f64.to_radians();
    std::fs::write(&path, file.to_json()).unwrap();
    let device = DeviceArgs {
        port: "socket://127.0.0.1:1".into(),
        timeout_ms: 100,
        retries: 0,
    };
    let err = push::run(&push::Args {
        calibration: path.clone(),
        home_deg: None,
        target: None,
        dry_run: false,
        device: Some(device),
    })
    .unwrap_err();
    // --dry-run refuses it alike, without a board.
    let dry = push::run(&push::Args {
        calibration: path,
        home_deg: None,
        target: None,
        dry_run: true,
        device: None,
    })
    .unwrap_err();
    assert_eq!(dry.report(), err.report());
    assert_eq!(err.exit_code(), 3);
    // The file's reader refuses it already, as every reader does: the play is
    // outside the physical bounds the board checks too.
    let report = err.report();
    assert!(
        report.contains("arm.joints[3].backlash")
            && report.contains("expected a backlash width within [0.000000, 0.087266] rad")
            && report.contains("found 7.00°"),
        "{report}"
    );
}

/// `lrmcal move --xyz` as a user types it: solved from the board's own pose,
/// on the bundled arm within the board's ±100° without a calibration and on
/// the nominal arm of the board's calibration with one; the board ends at
/// exactly the joint targets the library gives for the same question.
#[test]
fn move_xyz_sends_the_nearest_solution_from_the_boards_pose() {
    use clap::Parser;
    use lrmcal_engine::ik::{IkOptions, solve_position};

    let board = SocketBoard::start();
    let run = |xyz_m: [f64; 3]| {
        let [x, y, z] = xyz_m.map(|c| (c * 1e3).to_string());
        let args = [
            "lrmcal",
            "move",
            "--xyz",
            &x,
            &y,
            &z,
            "--duration-ms",
            "200",
            "--port",
            &board.port,
        ];
        // The exit code and the message a user would see.
        let outcome = host::cli::Cli::try_parse_from(args).unwrap().command.run();
        outcome.map_err(|e| (e.exit_code(), e.report()))
    };
    let nominal_rad = || {
        board
            .args()
            .connect()
            .unwrap()
            .status()
            .unwrap()
            .nominal_rad
    };
    // What the board accepts, as `move --xyz` must find it.
    let within_board = lrmcal_engine::device::commanded::within_board;

    // No calibration: the bundled arm. From base yaw 95°, the target of base
    // yaw 103° is nearest at 103°, within the arm's ±105° but beyond the
    // board's ±100°: another pose must be found.
    let bundled = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let deg = |q: [f64; 6]| q.map(f64::to_radians);
    let start = deg([95.0, 30.0, 30.0, 0.0, 0.0, 0.0]);
    let mut client = board.args().connect().unwrap();
    client
        .move_to(
            start.map(|a| a as f32).into(),
            protocol::Timing::DurationMs(200),
        )
        .unwrap();
    client
        .wait_until_still(Duration::from_millis(20), Duration::from_secs(20))
        .unwrap();
    drop(client);
    let target = bundled
        .chain()
        .rigid_tool_point(&deg([103.0, 30.0, 30.0, 0.0, 0.0, 0.0]));
    let start = nominal_rad().map(f64::from);
    let arms_own = solve_position(&bundled, &target, &start, &IkOptions::default()).unwrap();
    assert!(arms_own.q[0] > 100f64.to_radians(), "{:?}", arms_own.q);
    run(target.into()).unwrap();
    let expected = solve_position(
        &within_board(&bundled, None),
        &target,
        &start,
        &IkOptions::default(),
    )
    .unwrap();
    let q = nominal_rad();
    assert_eq!(q, expected.q.map(|a| a as f32));
    assert!(q.iter().all(|a| a.abs() <= 100f32.to_radians()), "{q:?}");
    let reached = bundled.chain().rigid_tool_point(&q.map(f64::from));
    assert!(
        (reached - target).norm() < 1e-6,
        "{:e} m",
        (reached - target).norm()
    );

    // A calibration whose nominal arm has a 30 mm longer forearm: its joint
    // targets are for that arm, so the solve must be too.
    let mut longer = bundled;
    longer.joints[3].d += 0.03;
    let calibration = protocol::Calibration {
        id: 0x5eed,
        option: protocol::ModelOption::Kinematic,
        nominal: longer.map(|x| x as f32),
        calibrated: longer.map(|x| x as f32),
        home_rad: [0.0; 6].into(),
        max_correction_rad: lrmcal_engine::device::calibration::max_corrections(&longer, &longer),
    };
    let mut client = board.args().connect().unwrap();
    client.push_calibration(&calibration, |_, _| {}).unwrap();
    drop(client);
    let start = nominal_rad().map(f64::from);
    let target = longer
        .chain()
        .rigid_tool_point(&[-0.4, 0.2, 0.4, 0.2, 0.3, 0.0]);
    run(target.into()).unwrap();
    let on_board = within_board(&calibration.nominal.map(f64::from), Some(&calibration));
    let expected = solve_position(&on_board, &target, &start, &IkOptions::default()).unwrap();
    let q = nominal_rad().map(f64::from);
    assert_eq!(q.map(|a| a as f32), expected.q.map(|a| a as f32));
    assert!((longer.chain().rigid_tool_point(&q) - target).norm() < 1e-6);
    assert!((bundled.chain().rigid_tool_point(&q) - target).norm() > 0.01);

    // Out of reach: refused before anything moves.
    let (code, message) = run([0.9, 0.0, 0.1]).unwrap_err();
    assert_eq!(code, 3);
    assert!(
        message.starts_with(
            "error: failed to find joint targets for the tool point (900.0, 0.0, 100.0) mm: out of reach: the target is 905.5 mm"
        ),
        "{message}"
    );
    assert_eq!(nominal_rad().map(f64::from), q);
}

/// The ranges `move --xyz` keeps to are the ones the firmware enforces.
#[test]
fn move_xyz_keeps_to_the_firmwares_joint_ranges() {
    use lrmcal_engine::device::commanded::board_limits;
    let config = firmware::Config::default();
    let firmware = |calibration: Option<&protocol::Calibration>| {
        firmware::servo::joint_limits(
            calibration.map(|c| &c.calibrated),
            config.hard_limits_rad,
            config.default_limits_rad,
        )
    };
    assert_eq!(board_limits(None), firmware(None));
    let mut arm = lrmcal_core::io::arm_source::bundled("lrm")
        .unwrap()
        .arm
        .map(|x| x as f32);
    arm.joints[0].limits = [-3.0, 0.5];
    arm.joints[1].limits = [3.0, 3.1];
    let calibration = protocol::Calibration {
        id: 1,
        option: protocol::ModelOption::Kinematic,
        nominal: arm,
        calibrated: arm,
        home_rad: [0.0; 6].into(),
        max_correction_rad: [0.35; 6].into(),
    };
    assert_eq!(
        board_limits(Some(&calibration)),
        firmware(Some(&calibration))
    );
}
