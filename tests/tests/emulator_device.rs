//! The host's device client against the real firmware in the emulated RP2040, over the same
//! link code as a USB serial port (`socket://`): status, push and pull bit-identical, a chip
//! reset that keeps the flash, and moves whose servo pulses (measured from GPIO edges) are
//! within 1 µs of the host's own servo curve + compensation + the play's offset the way each
//! joint arrived, in every compensation mode.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_device`.

mod emulator_support;

use std::time::Duration;

use emulator_support::{
    EmulatedBoard, ExpectedPulses, RawLink, calibration_bytes, curve_pulses, expected_command,
    test_calibration,
};
use host::commands::device_args::DeviceArgs;
use lrmcal_engine::device::{Client, Link};
use model::testing::TEST_ARM_JOINTS as JOINTS;
use protocol::{CompensationMode, Faults, Timing};

/// Servo pulse timing must match the host's computation to this.
const TOLERANCE_US: f64 = 1.0;
/// The paper's payload, kg.
const PAYLOAD_KG: f64 = 0.0663;

fn connect(board: &EmulatedBoard) -> Client<Box<dyn Link>> {
    let args = DeviceArgs {
        port: board.port_name(),
        timeout_ms: 2000,
        retries: 3,
    };
    args.connect()
        .expect("the host client connects to the emulated board")
}

#[test]
fn status_push_pull_and_reset_keep_the_calibration() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut client = connect(&board);
    let status = client.status().expect("status");
    assert!(
        status.calibration.is_none(),
        "a blank board has no calibration: {status:?}"
    );

    let calibration = test_calibration(41);
    let info = client
        .push_calibration(&calibration, |_, _| {})
        .expect("push");
    assert_eq!(info.id, calibration.id);
    let pulled = client.pull_calibration().expect("pull");
    assert_eq!(
        calibration_bytes(&pulled),
        calibration_bytes(&calibration),
        "pull is not bit-identical"
    );
    drop(client);

    board.reset();
    board.wait_configured();
    let mut client = connect(&board);
    let status = client.status().expect("status after reset");
    assert_eq!(
        status.calibration.map(|c| c.id),
        Some(calibration.id),
        "{status:?}"
    );
    let pulled = client.pull_calibration().expect("pull after reset");
    assert_eq!(calibration_bytes(&pulled), calibration_bytes(&calibration));
    assert_eq!(board.status()["resets"], 1);
}

#[test]
fn moves_produce_the_hosts_pulses_in_every_compensation_mode() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut client = connect(&board);
    let calibration = test_calibration(51);
    client
        .push_calibration(&calibration, |_, _| {})
        .expect("push");

    let poses: [[f64; JOINTS]; 3] = [
        [0.0; JOINTS],
        [0.4, -0.3, 0.5, 0.2, -0.6, 0.3],
        [-0.8, 0.5, -0.4, -0.5, 0.7, -1.0],
    ];
    let cases = [
        (CompensationMode::Off, 0.0),
        (CompensationMode::ElasticOnly, PAYLOAD_KG),
        (CompensationMode::Full, 0.0),
        (CompensationMode::Full, PAYLOAD_KG),
    ];
    // The board starts at home; each joint's way into every target is the host's to follow.
    let mut reference = ExpectedPulses::from(&calibration.home_rad.map(f64::from));
    let mut play_shift: f64 = 0.0;
    for (mode, payload) in cases {
        client.set_compensation(mode).expect("compensation mode");
        client.set_payload(payload as f32).expect("payload");
        let mut shift: f64 = 0.0;
        for q in &poses {
            let targets = q.map(|x| x as f32);
            client
                .move_to(targets.into(), Timing::DurationMs(300))
                .expect("move");
            let still = client
                .wait_until_still(Duration::from_millis(50), Duration::from_secs(30))
                .expect("the move ends");
            if mode != CompensationMode::Off {
                assert!(
                    still.compensation.converged
                        && still.faults.0 & Faults::COMPENSATION_FALLBACK.0 == 0,
                    "{mode:?}, payload {payload} kg, targets {q:?}: the board's compensation fell back: {:?}",
                    still.compensation
                );
            }
            // The firmware works in f32 on the f32 calibration; the host redoes it in f64.
            let q32 = targets.map(f64::from);
            let payload = f64::from(payload as f32);
            let expected = reference.next(&calibration, &q32, mode, payload);
            // Guards: each case must tell a compensating board from one that is not, and
            // every move a board that offsets the play from one that does not.
            let command = expected_command(&calibration, &q32, mode, payload);
            let unplayed = curve_pulses(&calibration, &command);
            let uncompensated = curve_pulses(&calibration, &q32);
            let largest = |a: &[f64; JOINTS], b: &[f64; JOINTS], from: f64| {
                a.iter()
                    .zip(b)
                    .map(|(a, b)| (a - b).abs())
                    .fold(from, f64::max)
            };
            shift = largest(&unplayed, &uncompensated, shift);
            play_shift = largest(&expected, &unplayed, play_shift);
            let (widths, _) = board.servo_pulses(3);
            for (servo, widths) in widths.iter().enumerate() {
                for width in widths {
                    assert!(
                        (width - expected[servo]).abs() <= TOLERANCE_US,
                        "{mode:?}, payload {payload} kg, targets {q:?}: servo {} pulse {width} µs, \
                         host expects {:.2} µs (± {TOLERANCE_US})",
                        servo + 1,
                        expected[servo]
                    );
                }
            }
        }
        if mode != CompensationMode::Off {
            assert!(
                shift > 3.0 * TOLERANCE_US,
                "{mode:?} moves the pulses by only {shift} µs"
            );
        }
    }
    assert!(
        play_shift > 3.0 * TOLERANCE_US,
        "the play's offset moves the pulses by only {play_shift} µs"
    );
}

#[test]
fn raw_link_and_client_see_the_same_board() {
    // The bare protocol link of the fault tests agrees with the host client on the status.
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut client = connect(&board);
    let from_client = client.status().expect("status").device;
    drop(client);
    let mut link = RawLink::connect(&board);
    assert_eq!(link.status().device, from_client);
}
