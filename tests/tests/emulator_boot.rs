//! The real firmware binary boots in the emulated RP2040 and drives six 50 Hz servo pulses at
//! the neutral pulse of the nominal servo curves, measured from GPIO edges with the emulator's
//! clock; its defmt log reaches the harness through RTT.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_boot`.

mod emulator_support;

use emulator_support::EmulatedBoard;

/// Servo pulse timing must match the host's computation to this (issue 5).
const TOLERANCE_US: f64 = 1.0;
/// One servo frame at 50 Hz.
const FRAME_US: f64 = 20_000.0;

#[test]
fn boots_and_drives_six_neutral_pulses_at_50_hz() {
    let arm = host::io::arm_source::bundled("lrm").expect("bundled arm").arm;
    let mut board = EmulatedBoard::start();
    // Past start-up: clocks, PWM set-up and the first frames.
    board.run_us(100_000);

    let (widths, periods) = board.servo_pulses(5);
    for (servo, (widths, periods)) in widths.iter().zip(&periods).enumerate() {
        let neutral = arm.joints[servo].servo.pulse_us(0.0);
        for width in widths {
            assert!(
                (width - neutral).abs() <= TOLERANCE_US,
                "servo {} pulse {width} µs, expected the neutral {neutral} µs ± {TOLERANCE_US}",
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
    assert!(status["halted"].is_null(), "the firmware stopped: {}", status["halted"]);
}

#[test]
fn firmware_logs_through_rtt() {
    let mut board = EmulatedBoard::start();
    board.run_us(50_000);
    let (bytes, lines) = board.rtt();
    // defmt frames are rzCOBS-encoded and end in a zero byte; the first message is the boot line.
    assert!(!bytes.is_empty(), "no defmt output in the _SEGGER_RTT up buffer\n{}", board.log());
    assert_eq!(bytes.last(), Some(&0), "defmt frames end in 0x00; got {bytes:02x?}");
    if !lines.is_empty() {
        assert!(
            lines.iter().any(|l| l.contains("booting")),
            "decoded log has no boot line: {lines:?}"
        );
    }
}
