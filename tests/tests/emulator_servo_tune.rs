//! `lrmcal servo-tune` as a user runs it, at a terminal (a pseudo-terminal) against the real
//! firmware in the emulated RP2040: each jog key moves the pulse measured on the servo's pin by
//! its step (1, 10, 100 µs either way), the three recorded pulses land in the arm file and in
//! the board's calibration, and leaving makes the servo limp.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_servo_tune`.
#![cfg(unix)]

mod emulator_support;

use std::process::Command;

use emulator_support::{EmulatedBoard, RawLink, SERVO_PINS, repo_root, test_calibration};
use model::ServoCurve;
use rexpect::process::WaitStatus;
use rexpect::session::{PtySession, spawn_command};
use serde_json::json;

/// The joint tuned, 1..6.
const JOINT: usize = 3;
/// Wall-clock bound on each wait for the terminal's output.
const EXPECT_TIMEOUT_MS: u64 = 60_000;

/// What the terminal sends for each key servo-tune reads.
const RIGHT: &str = "\x1b[C";
const LEFT: &str = "\x1b[D";
const UP: &str = "\x1b[A";
const DOWN: &str = "\x1b[B";
const PAGE_UP: &str = "\x1b[5~";
const PAGE_DOWN: &str = "\x1b[6~";

/// The pulse (µs) on the tuned servo's pin once the board has applied the last request.
fn measured_pulse(board: &mut EmulatedBoard) -> f64 {
    // The first pulse may have started before the request reached the board; the third starts
    // two 20 ms frames later, after the frame that applies it.
    let reply = board.request(json!({
        "cmd": "pulses", "pins": [SERVO_PINS[JOINT - 1]], "count": 3, "timeout_ms": 400
    }));
    reply["widths_us"][0][2]
        .as_f64()
        .unwrap_or_else(|| panic!("no third pulse in {reply}"))
}

/// Types `keys` at the terminal.
fn type_keys(session: &mut PtySession, keys: &str) {
    session.send(keys).expect("type at the terminal");
    session.flush().expect("type at the terminal");
}

/// Presses `key` and waits until servo-tune shows the pulse `expect_us`. (The session reads the
/// terminal's bytes as Latin-1, so the patterns leave out the "µs" after the number.)
fn press(session: &mut PtySession, key: &str, expect_us: u16) {
    type_keys(session, key);
    session
        .exp_regex(&format!("joint {JOINT}: +{expect_us} "))
        .unwrap_or_else(|e| panic!("servo-tune does not show {expect_us} µs after {key:?}: {e}"));
}

#[test]
fn servo_tune_jogs_the_measured_pulse_and_writes_the_curve_to_file_and_board() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    // The board holds a calibration, as after `lrmcal push`.
    let before = test_calibration(31);
    RawLink::connect(&board).push(&before);

    let dir = tempfile::tempdir().expect("scratch folder");
    let arm = dir.path().join("arm.toml");
    std::fs::copy(repo_root().join("host/core/arms/lrm.toml"), &arm).expect("copy the bundled arm");
    let original = lrmcal_core::io::arm_toml::read(&arm).expect("the bundled arm file");
    let start_us = original.arm.joints[JOINT - 1].servo.unwrap().pulse_us(0.0) as u16;

    let mut command = Command::new(env!("CARGO_BIN_EXE_lrmcal-e2e"));
    command
        .args(["servo-tune", &JOINT.to_string(), "--points", "3", "--arm"])
        .arg(&arm)
        .args(["--port", &board.port_name(), "--timeout-ms", "5000"]);
    let mut session = spawn_command(command, Some(EXPECT_TIMEOUT_MS)).expect("a pseudo-terminal");
    session
        .exp_regex(&format!("joint {JOINT}: +{start_us} "))
        .expect("servo-tune starts at the arm file's 0° pulse");
    let mut pulse = measured_pulse(&mut board);
    assert!(
        (pulse - f64::from(start_us)).abs() < 0.5,
        "servo-tune starts the servo at {pulse} µs, not {start_us} µs"
    );

    // Each jog key moves the measured pulse by exactly its step (the PWM counts whole µs).
    let mut shown = start_us;
    for (key, step) in [
        (RIGHT, 1),
        (UP, 10),
        (PAGE_UP, 100),
        (LEFT, -1),
        (DOWN, -10),
        (PAGE_DOWN, -100),
    ] {
        shown = shown.wrapping_add_signed(step);
        press(&mut session, key, shown);
        let now = measured_pulse(&mut board);
        assert!(
            (now - pulse - f64::from(step)).abs() < 0.5,
            "key {key:?} moved the measured pulse from {pulse} to {now} µs, not by {step} µs"
        );
        pulse = now;
    }

    // With three tuning points (keys 1, 2, 3 = -100°, 0°, +100°), record each at a pulse,
    // then write the curve.
    let mut recorded = [0u16; 3];
    let plans: [Vec<(&str, i16)>; 3] = [
        vec![(PAGE_DOWN, -100); 7],
        [vec![(PAGE_UP, 100); 7], vec![(DOWN, -10), (RIGHT, 1)]].concat(),
        vec![(PAGE_UP, 100); 7],
    ];
    for (point, keys) in plans.iter().enumerate() {
        for &(key, step) in keys {
            shown = shown.wrapping_add_signed(step);
            press(&mut session, key, shown);
        }
        let now = measured_pulse(&mut board);
        assert!(
            (now - f64::from(shown)).abs() < 0.5,
            "{now} µs on the pin, {shown} shown"
        );
        let record = char::from(b'1' + point as u8);
        type_keys(&mut session, &record.to_string());
        session
            .exp_string(&format!("recorded {shown} "))
            .expect("servo-tune records the pulse");
        recorded[point] = shown;
    }
    let curve = ServoCurve::from_three_points(
        f64::from(recorded[0]),
        f64::from(recorded[1]),
        f64::from(recorded[2]),
    );
    assert!(
        curve.is_monotonic(),
        "the test records a usable curve: {curve:?}"
    );
    type_keys(&mut session, "w");
    let (_, written) = session
        .exp_regex(r"board calibration updated \([0-9a-f]{8}\)")
        .expect("servo-tune writes the curve to the arm file and the board");
    type_keys(&mut session, "q");
    match session.process().wait() {
        Ok(WaitStatus::Exited(_, 0)) => {}
        other => panic!("servo-tune ended with {other:?}, not exit code 0"),
    }

    // The arm file has the new curve for this joint and nothing else changed.
    let mut expected = original.clone();
    expected.arm.joints[JOINT - 1].servo = Some(curve);
    let rewritten = lrmcal_core::io::arm_toml::read(&arm).expect("the rewritten arm file");
    assert_eq!(rewritten.arm, expected.arm, "the arm file after servo-tune");
    // Written in place: the file's comments are all still there, in order.
    let comments = |text: &str| -> Vec<String> {
        text.lines()
            .filter_map(|l| l.split_once('#').map(|(_, c)| c.to_owned()))
            .collect()
    };
    let source = std::fs::read_to_string(repo_root().join("host/core/arms/lrm.toml")).unwrap();
    let tuned = std::fs::read_to_string(&arm).unwrap();
    assert_eq!(
        comments(&tuned),
        comments(&source),
        "the arm file's comments"
    );

    // The board uses a calibration with the new curve (single precision) and the rest as before.
    let mut link = RawLink::connect(&board);
    let info = link
        .status()
        .calibration
        .expect("the board has a calibration");
    assert_eq!(
        written,
        format!("board calibration updated ({:08x})", info.id),
        "the board uses the calibration servo-tune wrote"
    );
    let stored =
        protocol::Calibration::decode(&link.pull()).expect("the board's calibration decodes");
    let mut want = before;
    want.calibrated.joints[JOINT - 1].servo = Some(curve.map(|v| v as f32));
    want.id = stored.id;
    assert_eq!(stored, want, "the board's calibration after servo-tune");
    assert_ne!(stored.id, before.id, "a changed calibration gets a new id");

    // Leaving made the servo limp: no more pulses on its pin.
    board.run_us(60_000);
    let since = board.status()["nanos"].clone();
    board.run_us(100_000);
    let quiet = board.request(
        json!({"cmd": "pulses_since", "pins": [SERVO_PINS[JOINT - 1]], "since_ns": since}),
    );
    assert_eq!(
        quiet["widths_us"][0],
        json!([]),
        "the servo still pulses after servo-tune ended"
    );
}
