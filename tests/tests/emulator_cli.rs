//! `lrmcal`'s own device commands, unchanged, against the real firmware in the emulated
//! RP2040 through `--port socket://127.0.0.1:PORT`: a calibration made by `lrmcal demo` is
//! pushed, pulled back bit-identical, survives a chip reset, and `payload`, `compensation`,
//! `move`, `home` and `detach` do what the servo pulses (measured from GPIO edges) say.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_cli`.

mod emulator_support;

use std::path::{Path, PathBuf};

use clap::Parser;
use emulator_support::{EmulatedBoard, ExpectedPulses, RawLink, SERVO_PINS, calibration_bytes};
use lrmcal_core::io::calibration_file::CalibrationFile;
use protocol::CompensationMode;
use serde_json::json;

/// Servo pulse timing must match the host's computation to this.
const TOLERANCE_US: f64 = 1.0;

/// Runs one `lrmcal` command line in this process, exactly as the binary would.
/// Device commands get `--timeout-ms 5000`: the emulated board answers in emulated time, which
/// runs slower than the wall clock while the CPU is busy (and CI machines are small).
fn lrmcal(args: &[&str]) {
    let mut args = args.to_vec();
    if args.contains(&"--port") {
        args.extend(["--timeout-ms", "5000"]);
    }
    let argv = std::iter::once("lrmcal").chain(args.iter().copied());
    let cli = host::cli::Cli::try_parse_from(argv)
        .unwrap_or_else(|e| panic!("lrmcal {}: {e}", args.join(" ")));
    if let Err(e) = cli.command.run() {
        panic!("lrmcal {} failed: {}", args.join(" "), e.report());
    }
}

/// A fresh scratch folder for this test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lrmcal-emulator-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

fn path(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

#[test]
fn device_commands_drive_the_emulated_board() {
    let dir = scratch("cli");
    lrmcal(&[
        "demo",
        "--starts",
        "1",
        "--compare-random",
        "0",
        "--out",
        path(&dir),
    ]);
    let file = dir.join("calibration-paper-elasto-kinematic.json");
    let payload = lrmcal_engine::device::calibration::payload(
        &CalibrationFile::read(&file).expect("the demo's calibration file"),
        [0.0; 6].into(),
    )
    .expect("a calibration the board accepts");

    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let port = board.port_name();
    let p = port.as_str();
    lrmcal(&["status", "--port", p]);
    lrmcal(&["push", path(&file), "--port", p]);
    let pulled = dir.join("pulled.json");
    lrmcal(&["pull", "--out", path(&pulled), "--port", p]);
    assert!(pulled.is_file(), "lrmcal pull wrote nothing");
    assert_eq!(
        RawLink::connect(&board).pull(),
        calibration_bytes(&payload),
        "the board's calibration is not bit-identical to the pushed file's payload"
    );

    board.reset();
    board.wait_configured();
    lrmcal(&["status", "--port", p]);
    let mut link = RawLink::connect(&board);
    let status = link.status();
    assert_eq!(
        status.calibration.map(|c| c.id),
        Some(payload.id),
        "{status:?}"
    );
    assert_eq!(
        link.pull(),
        calibration_bytes(&payload),
        "flash lost the calibration"
    );
    drop(link);

    lrmcal(&["payload", "0.0663", "--port", p]);
    lrmcal(&["compensation", "full", "--port", p]);
    let degrees = [20.0f64, -30.0, 35.0, 10.0, -25.0, 15.0];
    let argv: Vec<String> = degrees.iter().map(|d| d.to_string()).collect();
    let mut args: Vec<&str> = vec!["move"];
    args.extend(argv.iter().map(String::as_str));
    args.extend(["--duration-ms", "400", "--port", p]);
    lrmcal(&args);
    let q = degrees.map(|d| f64::from(d.to_radians() as f32));
    let home = payload.home_rad.map(f64::from);
    let expected = ExpectedPulses::from(&home).next(
        &payload,
        &q,
        CompensationMode::Full,
        f64::from(0.0663f32),
    );
    let (widths, _) = board.servo_pulses(3);
    for (servo, widths) in widths.iter().enumerate() {
        for width in widths {
            assert!(
                (width - expected[servo]).abs() <= TOLERANCE_US,
                "servo {} pulse {width} µs after `lrmcal move`, host expects {:.2} µs",
                servo + 1,
                expected[servo]
            );
        }
    }

    lrmcal(&["home", "--duration-ms", "300", "--port", p]);
    lrmcal(&["detach", "--port", p]);
    board.run_us(60_000); // the frame in flight ends
    let since = board.status()["nanos"].clone();
    board.run_us(100_000);
    let quiet =
        board.request(json!({"cmd": "pulses_since", "pins": SERVO_PINS, "since_ns": since}));
    for widths in quiet["widths_us"].as_array().expect("widths") {
        assert!(
            widths.as_array().is_some_and(Vec::is_empty),
            "a detached servo still pulses: {widths}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
