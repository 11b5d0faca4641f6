//! Shared driver of the emulated-board tests: runs the real firmware ELF in the rp2040js
//! harness (`tests/emulator/bin/lrm-emulator.js`) and speaks its JSON-lines control channel.
//!
//! Prerequisites, checked with a message that says how to get them: Node on the PATH (or
//! `LRM_NODE`), `npm ci` done in `tests/emulator`, and the firmware built with `cargo firmware`
//! (or `LRM_FIRMWARE_ELF` naming another ELF). When a test fails, the emulator's log (the
//! firmware's defmt output included) is printed, so the failure shows what the board said.
#![allow(dead_code)] // each test file uses its own part of this driver

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

/// Wall-clock bound on one control request (waits inside are bounded in emulated time too).
const REQUEST_TIMEOUT: Duration = Duration::from_secs(120);
/// Why a control request got no reply.
enum Unanswered {
    /// The request could not be written to the emulator.
    Unsent(std::io::Error),
    /// No reply within the time allowed.
    Timeout,
    /// The emulator closed its output.
    Disconnected,
}
/// GPIOs of servos 1..6 on the board (firmware/src/board).
pub const SERVO_PINS: [u32; 6] = [2, 3, 4, 5, 6, 7];

/// The repository root.
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The firmware ELF the tests run: `LRM_FIRMWARE_ELF`, else where `cargo firmware` puts it
/// (under `CARGO_TARGET_DIR` when that is set, as cargo does).
pub fn firmware_elf() -> PathBuf {
    if let Some(elf) = std::env::var_os("LRM_FIRMWARE_ELF") {
        return PathBuf::from(elf);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo_root().join("target"));
    target.join("thumbv6m-none-eabi/release/firmware")
}

/// A running emulated board.
pub struct EmulatedBoard {
    child: Child,
    stdin: ChildStdin,
    replies: Receiver<Value>,
    events: Arc<Mutex<Vec<Value>>>,
    log: Arc<Mutex<String>>,
    /// Ends when the emulator's stderr closes: joined to have its last words (a crash's trace).
    log_reader: Option<thread::JoinHandle<()>>,
    next_id: u64,
    /// TCP port of the board's USB serial port on 127.0.0.1.
    pub port: u16,
}

impl EmulatedBoard {
    /// Starts the board on a free port, with a blank flash apart from the firmware.
    pub fn start() -> Self {
        let emulator = repo_root().join("tests/emulator");
        let script = emulator.join("bin/lrm-emulator.js");
        assert!(
            emulator.join("node_modules/rp2040js").is_dir(),
            "the emulator is not installed: run `npm ci` in {}",
            emulator.display()
        );
        let elf = firmware_elf();
        assert!(
            elf.is_file(),
            "no firmware ELF at {}: build it with `cargo firmware` \
             (cargo build -p firmware --release --target thumbv6m-none-eabi)",
            elf.display()
        );
        let node = std::env::var_os("LRM_NODE").unwrap_or_else(|| "node".into());
        let mut child = Command::new(&node)
            .arg(&script)
            .args(["--control", "--port", "0", "--elf"])
            .arg(&elf)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot start {node:?} {}: {e} (is Node installed?)",
                    script.display()
                )
            });

        let log = Arc::new(Mutex::new(String::new()));
        let stderr = child.stderr.take().expect("piped stderr");
        let log_writer = Arc::clone(&log);
        let log_reader = thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let mut log = log_writer.lock().unwrap_or_else(|e| e.into_inner());
                log.push_str(&line);
                log.push('\n');
            }
        });

        let (tx, replies) = channel();
        let events = Arc::new(Mutex::new(Vec::new()));
        let event_writer = Arc::clone(&events);
        let stdout = child.stdout.take().expect("piped stdout");
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let Ok(value) = serde_json::from_str::<Value>(&line) else {
                    continue;
                };
                if value.get("event").is_some() {
                    event_writer
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .push(value.clone());
                }
                if tx.send(value).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take().expect("piped stdin");
        let mut board = Self {
            child,
            stdin,
            replies,
            events,
            log,
            log_reader: Some(log_reader),
            next_id: 1,
            port: 0,
        };
        let listening = board.wait_event("listening");
        board.port = listening["port"]
            .as_u64()
            .expect("listening event has a port") as u16;
        board
    }

    /// The host-side port name of the board's USB serial port.
    pub fn port_name(&self) -> String {
        format!("socket://127.0.0.1:{}", self.port)
    }

    /// The emulator's log so far (its own messages and the firmware's).
    pub fn log(&self) -> String {
        self.log.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// How the emulator ended, once its stdout has closed; its whole log is read by then.
    fn exit_status(&mut self) -> String {
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(status)) = self.child.try_wait() {
                if let Some(reader) = self.log_reader.take() {
                    let _ = reader.join();
                }
                return format!("the emulator exited ({status})");
            }
            thread::sleep(Duration::from_millis(20));
        }
        "the emulator closed its stdout".into()
    }

    /// Events (`configured`, `reset`, `halted`, ...) seen so far.
    pub fn events(&self) -> Vec<Value> {
        self.events
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    fn wait_event(&mut self, name: &str) -> Value {
        let deadline = Instant::now() + REQUEST_TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.replies.recv_timeout(left) {
                Ok(v) if v["event"] == name => return v,
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => {
                    panic!("no '{name}' event from the emulator\n{}", self.log())
                }
                Err(RecvTimeoutError::Disconnected) => {
                    panic!("{} before '{name}'\n{}", self.exit_status(), self.log())
                }
            }
        }
    }

    /// Sends one control request and returns its reply; panics (with the log) on an error reply.
    pub fn request(&mut self, mut request: Value) -> Value {
        let reply = self.try_request(&mut request);
        if reply["ok"] != true {
            panic!(
                "emulator request {request} failed: {}\n{}",
                reply["error"],
                self.log()
            );
        }
        reply
    }

    /// Sends one control request and returns its reply, error replies included.
    pub fn try_request(&mut self, request: &mut Value) -> Value {
        match self.exchange(request, REQUEST_TIMEOUT) {
            Ok(reply) => reply,
            Err(Unanswered::Unsent(e)) => panic!("emulator gone: {e}\n{}", self.log()),
            Err(Unanswered::Timeout) => panic!(
                "no reply to {request} from the emulator within {} s; {}\n{}",
                REQUEST_TIMEOUT.as_secs(),
                self.time_report(),
                self.log()
            ),
            Err(Unanswered::Disconnected) => panic!(
                "{} instead of answering {request}\n{}",
                self.exit_status(),
                self.log()
            ),
        }
    }

    /// Sends `request` with the next id and waits up to `within` for its reply.
    fn exchange(&mut self, request: &mut Value, within: Duration) -> Result<Value, Unanswered> {
        let id = self.next_id;
        self.next_id += 1;
        request["id"] = json!(id);
        writeln!(self.stdin, "{request}").map_err(Unanswered::Unsent)?;
        self.stdin.flush().ok();
        let deadline = Instant::now() + within;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.replies.recv_timeout(left) {
                Ok(v) if v["id"] == json!(id) => return Ok(v),
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => return Err(Unanswered::Timeout),
                Err(RecvTimeoutError::Disconnected) => return Err(Unanswered::Disconnected),
            }
        }
    }

    /// Where the emulator's time stands, asked twice a second apart: tells a board that stopped
    /// advancing emulated time from one that is only slow.
    fn time_report(&mut self) -> String {
        let mut nanos = [0.0; 2];
        for (i, reading) in nanos.iter_mut().enumerate() {
            if i > 0 {
                thread::sleep(Duration::from_secs(1));
            }
            match self.exchange(&mut json!({"cmd": "status"}), Duration::from_secs(5)) {
                Ok(reply) => *reading = reply["nanos"].as_f64().unwrap_or(f64::NAN),
                Err(_) => return "the emulator does not answer a status request either".into(),
            }
        }
        format!(
            "its emulated time stood at {:.3} ms, then {:.3} ms a second later",
            nanos[0] / 1e6,
            nanos[1] / 1e6
        )
    }

    /// Waits until the board's USB serial port is enumerated.
    pub fn wait_configured(&mut self) {
        self.request(json!({"cmd": "wait_configured", "timeout_ms": 3000}));
    }

    /// Lets `micros` of emulated time pass.
    pub fn run_us(&mut self, micros: u64) {
        self.request(json!({"cmd": "run", "us": micros}));
    }

    /// The widths (µs) of the next `count` pulses on each servo pin, in servo order.
    pub fn servo_pulses(&mut self, count: u32) -> (Vec<Vec<f64>>, Vec<Vec<Option<f64>>>) {
        // Each pulse takes a 20 ms frame; allow a few frames more for the first edge.
        let timeout_ms = count * 20 + 300;
        let reply = self.request(
            json!({"cmd": "pulses", "pins": SERVO_PINS, "count": count, "timeout_ms": timeout_ms}),
        );
        let widths = serde_json::from_value(reply["widths_us"].clone()).expect("widths_us");
        let periods = serde_json::from_value(reply["periods_us"].clone()).expect("periods_us");
        (widths, periods)
    }

    /// Resets the chip now; its flash survives.
    pub fn reset(&mut self) {
        self.request(json!({"cmd": "reset"}));
    }

    /// Status of the emulator: time, resets, halted reason, flash operation counts.
    pub fn status(&mut self) -> Value {
        self.request(json!({"cmd": "status"}))
    }

    /// The firmware's raw defmt bytes so far, and decoded lines when defmt-print is installed.
    pub fn rtt(&mut self) -> (Vec<u8>, Vec<String>) {
        let reply = self.request(json!({"cmd": "rtt"}));
        let hex = reply["hex"].as_str().unwrap_or_default();
        let bytes = (0..hex.len() / 2)
            .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).expect("hex from the emulator"))
            .collect();
        let lines = serde_json::from_value(reply["lines"].clone()).unwrap_or_default();
        (bytes, lines)
    }
}

impl Drop for EmulatedBoard {
    fn drop(&mut self) {
        if thread::panicking() {
            eprintln!(
                "---- emulator log (serial port {}) ----\n{}",
                self.port_name(),
                self.log()
            );
        }
        let _ = writeln!(self.stdin, "{}", json!({"id": 0, "cmd": "quit"}));
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A bare protocol link to the board over its TCP serial port, for the fault tests that must
/// stop a transfer part-way or put garbage between frames (the host client never does either).
pub struct RawLink {
    stream: std::net::TcpStream,
    seq: u16,
    reader: protocol::frame::FrameReader,
}

impl RawLink {
    /// Connects to the board's serial port.
    pub fn connect(board: &EmulatedBoard) -> Self {
        let stream =
            std::net::TcpStream::connect(("127.0.0.1", board.port)).expect("connect to the board");
        stream
            .set_read_timeout(Some(Duration::from_secs(20)))
            .expect("read timeout");
        stream.set_nodelay(true).ok();
        Self {
            stream,
            seq: 0x4000,
            reader: protocol::frame::FrameReader::new(),
        }
    }

    /// Writes raw bytes to the serial line.
    pub fn send_bytes(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).expect("write to the board");
    }

    /// Sends one request frame and returns the response with the same sequence number.
    pub fn request(&mut self, request: &protocol::Request) -> protocol::Response {
        self.request_or_closed(request)
            .expect("the board closed the serial port")
    }
}

/// A calibration for the bundled arm with known errors and compliances, so that compensation
/// has work to do, Hayati's twist of the parallel shoulder and elbow (`j2.beta`, which our
/// option fits: a twisted link is the board's dearer case), servo curves of 5 to 9 knots with
/// a bow between them, so that the board maps angle to pulse through every segment, play in
/// every joint, so that the board offsets it, and springs that soften with torque; `id` tells
/// two of them apart in `status`.
pub fn test_calibration(id: u32) -> protocol::Calibration {
    use model::ParamId;
    let nominal = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm;
    let names = [
        "j2.theta", "j3.a", "j4.alpha", "tool.z", "k2", "k3", "k5", "k0", "j2.beta",
    ];
    let scale = 1.0 + f64::from(id % 7) / 10.0;
    let errors = [0.01, 0.002, -0.008, 0.003, 0.05, 0.08, 0.1, 0.02, 0.004].map(|e| e * scale);
    let ids: Vec<ParamId> = names
        .iter()
        .map(|n| ParamId::from_name(n).expect("known parameter"))
        .collect();
    let mut calibrated = nominal.with_errors(&ids, &errors);
    for (i, joint) in calibrated.joints.iter_mut().enumerate() {
        let n = [5, 9, 7, 6, 9, 5][i];
        let angles: Vec<f64> = (0..n)
            .map(|k| (-100.0 + 200.0 * k as f64 / (n - 1) as f64).to_radians())
            .collect();
        let pulses: Vec<f64> = angles
            .iter()
            .map(|&a| joint.servo.unwrap().pulse_us(a) + (6.0 + i as f64) * (2.0 * a).sin())
            .collect();
        joint.servo = Some(model::ServoCurve::new(&angles, &pulses).expect("5 to 9 knots"));
        // Play of 1° to 3.5° full width: half of it is 4 to 13 µs of pulse.
        joint.backlash = (1.0 + 0.5 * i as f64).to_radians();
        // Springs that soften with torque, so the board works out the
        // nonlinear spring (the cycle benchmark's worst case).
        joint.softening = 0.2 + 0.05 * i as f64;
    }
    calibrated.base_softening = 0.25;
    let calibration = protocol::Calibration {
        id,
        option: protocol::ModelOption::ElastoKinematic,
        nominal: nominal.map(|x| x as f32),
        calibrated: calibrated.map(|x| x as f32),
        home_rad: [0.0; model::testing::TEST_ARM_JOINTS].into(),
        max_correction_rad: lrmcal_engine::device::calibration::max_corrections(
            &nominal,
            &calibrated,
        ),
    };
    calibration.check().expect("the test calibration is valid");
    calibration
}

/// The postcard bytes of a calibration, as pushed and stored.
pub fn calibration_bytes(calibration: &protocol::Calibration) -> Vec<u8> {
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    calibration
        .encode(&mut buf)
        .expect("encode calibration")
        .to_vec()
}

impl RawLink {
    /// Sends one request; `None` if the board dropped the connection (it reset) instead.
    pub fn request_or_closed(&mut self, request: &protocol::Request) -> Option<protocol::Response> {
        self.exchange(protocol::PROTOCOL_VERSION, request)
    }

    /// Sends one request in a frame of protocol `version` (a peer of another version).
    pub fn exchange(
        &mut self,
        version: u8,
        request: &protocol::Request,
    ) -> Option<protocol::Response> {
        self.seq = self.seq.wrapping_add(1);
        let mut frame = [0u8; protocol::frame::MAX_FRAME];
        let n = protocol::frame::encode_with_version(version, self.seq, request, &mut frame)
            .expect("encode request");
        if self.stream.write_all(&frame[..n]).is_err() {
            return None;
        }
        let mut byte = [0u8; 1];
        loop {
            match std::io::Read::read(&mut self.stream, &mut byte) {
                Ok(1) => {}
                _ => return None,
            }
            if let protocol::frame::Feed::Frame(frame) = self.reader.feed(byte[0])
                && let Ok((seq, response)) = protocol::frame::decode::<protocol::Response>(frame)
                && seq == self.seq
            {
                return Some(response);
            }
        }
    }

    /// Announces a calibration and sends its first `chunks` chunks (all: `usize::MAX`).
    pub fn push_chunks(&mut self, bytes: &[u8], chunks: usize) {
        let begin = protocol::Request::CalibrationBegin {
            len_bytes: bytes.len() as u32,
            crc: protocol::frame::crc32(bytes),
        };
        assert_eq!(
            self.request(&begin),
            protocol::Response::CalibrationAck { received: 0 }
        );
        for (i, chunk) in bytes.chunks(protocol::CHUNK_LEN).take(chunks).enumerate() {
            let offset = (i * protocol::CHUNK_LEN) as u32;
            let data = heapless::Vec::from_slice(chunk).expect("chunk fits");
            let ack = self.request(&protocol::Request::CalibrationChunk { offset, data });
            let received = offset + chunk.len() as u32;
            assert_eq!(ack, protocol::Response::CalibrationAck { received });
        }
    }

    /// Pushes a whole calibration and checks that the board stored it.
    pub fn push(&mut self, calibration: &protocol::Calibration) {
        self.push_chunks(&calibration_bytes(calibration), usize::MAX);
        match self.request(&protocol::Request::CalibrationCommit) {
            protocol::Response::CalibrationStored(info) => assert_eq!(info.id, calibration.id),
            other => panic!(
                "commit of calibration {} answered {other:?}",
                calibration.id
            ),
        }
    }

    /// Reads the stored calibration's bytes back.
    pub fn pull(&mut self) -> Vec<u8> {
        let mut bytes = Vec::new();
        loop {
            let offset = bytes.len() as u32;
            match self.request(&protocol::Request::CalibrationRead { offset }) {
                protocol::Response::CalibrationData {
                    len_bytes, data, ..
                } => {
                    bytes.extend_from_slice(&data);
                    if data.is_empty() || bytes.len() as u32 >= len_bytes {
                        return bytes;
                    }
                }
                other => panic!("calib/read at {offset} answered {other:?}"),
            }
        }
    }

    /// The board's status.
    pub fn status(&mut self) -> protocol::Status {
        match self.request(&protocol::Request::Status) {
            protocol::Response::Status(status) => status,
            other => panic!("status answered {other:?}"),
        }
    }
}

/// The command the host expects the board to settle on for nominal targets `q`, before the
/// play's offset (the firmware's compensation, in f64).
pub fn expected_command(
    calibration: &protocol::Calibration,
    q: &[f64; model::testing::TEST_ARM_JOINTS],
    mode: protocol::CompensationMode,
    payload_kg: f64,
) -> [f64; model::testing::TEST_ARM_JOINTS] {
    let nominal = calibration.nominal.map(f64::from);
    let chain = calibration.calibrated.map(f64::from).chain();
    match mode {
        protocol::CompensationMode::Off => *q,
        _ => {
            let target = if mode == protocol::CompensationMode::Full {
                nominal
                    .chain()
                    .tool_point(q, payload_kg, &Default::default())
                    .expect("nominal tool point")
            } else {
                chain.rigid_tool_point(q)
            };
            let solved = chain
                .compensate(
                    q,
                    &target,
                    payload_kg,
                    None,
                    &model::CompensationOptions::default(),
                )
                .expect("host compensation");
            assert!(
                solved.converged,
                "the host's compensation did not converge for {q:?}"
            );
            std::array::from_fn(|i| solved.q[i])
        }
    }
}

/// The pulses of the calibrated servo curves for `command`, clamped to the joint limits, µs.
pub fn curve_pulses(
    calibration: &protocol::Calibration,
    command: &[f64; model::testing::TEST_ARM_JOINTS],
) -> [f64; model::testing::TEST_ARM_JOINTS] {
    let calibrated = calibration.calibrated.map(f64::from);
    let command = calibrated.clamp_to_limits(command);
    std::array::from_fn(|i| calibrated.joints[i].servo.unwrap().pulse_us(command[i]))
}

/// The host's side of a board's moves: which way each joint arrives at each target, and
/// the pulses with half the play added that way (the firmware's rule, in f64, for moves
/// whose commands run one way per joint, as a move between two poses does).
pub struct ExpectedPulses {
    approach: model::backlash::ApproachTracker<f64>,
}

impl ExpectedPulses {
    /// A board standing at `home`, rad, every joint taken to have arrived rising.
    pub fn from(home: &[f64]) -> Self {
        Self {
            approach: model::backlash::ApproachTracker::new(home),
        }
    }

    /// The pulses for nominal targets `q` reached after the targets passed before, µs.
    pub fn next(
        &mut self,
        calibration: &protocol::Calibration,
        q: &[f64; model::testing::TEST_ARM_JOINTS],
        mode: protocol::CompensationMode,
        payload_kg: f64,
    ) -> [f64; model::testing::TEST_ARM_JOINTS] {
        let command = expected_command(calibration, q, mode, payload_kg);
        let ways = self.approach.visit(&command);
        let joints = &calibration.calibrated.joints;
        let played = std::array::from_fn(|i| {
            model::backlash::command_for(command[i], f64::from(joints[i].backlash), ways[i])
        });
        curve_pulses(calibration, &played)
    }
}

/// `lrmcal` run as a process (this package's `lrmcal-e2e`, the same program) against the
/// board's serial port `port`. Device commands wait up to 5 s per reply: the emulated board
/// answers in emulated time, which runs slower than the wall clock while the CPU is busy.
pub fn lrmcal_process(port: &str, args: &[&str]) -> std::process::Output {
    let output = Command::new(env!("CARGO_BIN_EXE_lrmcal-e2e"))
        .args(args)
        .args(["--timeout-ms", "5000"])
        .env("LRMCAL_PORT", port)
        .output()
        .expect("lrmcal runs");
    assert!(
        output.status.success(),
        "lrmcal {} failed ({}): {}",
        args.join(" "),
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// The calibration files of `lrmcal demo` (quick settings), made in `dir` by the CLI.
pub fn demo_calibrations(dir: &std::path::Path) -> PathBuf {
    let status = Command::new(env!("CARGO_BIN_EXE_lrmcal-e2e"))
        .args(["demo", "--starts", "1", "--compare-random", "0", "--out"])
        .arg(dir)
        .stdout(Stdio::null())
        .status()
        .expect("lrmcal demo runs");
    assert!(status.success(), "lrmcal demo failed: {status}");
    dir.join("calibration-paper-elasto-kinematic.json")
}
