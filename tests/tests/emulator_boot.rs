//! The real firmware binary boots in the emulated RP2040, enumerates as a USB serial port,
//! starts with every servo limp (no pulse at power-on), and once attached drives six 50 Hz
//! pulses at the home pose's pulse of the nominal servo curves, measured from GPIO edges with
//! the emulator's clock. Its defmt log reaches the harness through RTT.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_boot`.

mod emulator_support;

use emulator_support::{EmulatedBoard, RawLink, SERVO_PINS};
use protocol::{PROTOCOL_VERSION, Request, Response};
use serde_json::json;

/// Servo pulse timing must match the host's computation to this.
const TOLERANCE_US: f64 = 1.0;
/// One servo frame at 50 Hz.
const FRAME_US: f64 = 20_000.0;

#[test]
fn boots_limp_enumerates_and_attached_servos_pulse_at_home_at_50_hz() {
    let arm = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm;
    let mut board = EmulatedBoard::start();
    board.wait_configured();

    // Start-up: no pulse on any servo pin for the first frames (the arm must not jerk).
    let since = board.status()["nanos"].clone();
    board.run_us(100_000);
    let quiet =
        board.request(json!({"cmd": "pulses_since", "pins": SERVO_PINS, "since_ns": since}));
    for (servo, widths) in quiet["widths_us"]
        .as_array()
        .expect("widths")
        .iter()
        .enumerate()
    {
        assert!(
            widths.as_array().is_some_and(Vec::is_empty),
            "servo {} pulsed before any command: {widths}",
            servo + 1
        );
    }

    let mut link = RawLink::connect(&board);
    match link.request(&Request::Hello) {
        Response::Hello(info) => assert_eq!(info.protocol, PROTOCOL_VERSION, "{info:?}"),
        other => panic!("hello answered {other:?}"),
    }
    assert_eq!(
        link.request(&Request::Attach { channel: None }),
        Response::Done
    );

    // Home without a calibration is all joints at 0 rad: the nominal curves' centre pulse.
    let (widths, periods) = board.servo_pulses(5);
    for (servo, (widths, periods)) in widths.iter().zip(&periods).enumerate() {
        let home = arm.joints[servo].servo.unwrap().pulse_us(0.0);
        for width in widths {
            assert!(
                (width - home).abs() <= TOLERANCE_US,
                "servo {} pulse {width} µs, expected {home} µs ± {TOLERANCE_US}",
                servo + 1
            );
        }
        for period in periods.iter().flatten() {
            assert!(
                (period - FRAME_US).abs() <= TOLERANCE_US,
                "servo {} period {period} µs, expected {FRAME_US} µs (50 Hz)",
                servo + 1
            );
        }
    }
    let status = board.status();
    assert!(
        status["halted"].is_null(),
        "the firmware stopped: {}",
        status["halted"]
    );
}

#[test]
fn firmware_logs_through_rtt() {
    let mut board = EmulatedBoard::start();
    board.run_us(50_000);
    let (bytes, lines) = board.rtt();
    // defmt frames are rzCOBS-encoded and end in a zero byte; the first message is the boot line.
    assert!(
        !bytes.is_empty(),
        "no defmt output in the _SEGGER_RTT up buffer\n{}",
        board.log()
    );
    assert_eq!(
        bytes.last(),
        Some(&0),
        "defmt frames end in 0x00; got {bytes:02x?}"
    );
    if !lines.is_empty() {
        assert!(
            lines.iter().any(|l| l.contains("booting")),
            "decoded log has no boot line: {lines:?}"
        );
    }
}
