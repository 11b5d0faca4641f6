//! `lrmcal emulator` as a user runs it, at a terminal (a pseudo-terminal): it says which port
//! to use; `lrmcal status`, `push`, `move` and `pull` work against it from other processes,
//! and the pulses the board reports are the ones measured on its pins; Ctrl-C stops it with
//! exit code 0 and its flash saved in the file named, and the board started again on that
//! file has the calibration; SIGTERM stops it as cleanly.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_command`.
#![cfg(unix)]

mod emulator_support;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use emulator_support::{demo_calibrations, firmware_elf, lrmcal_process};
use rexpect::process::{Signal, WaitStatus};
use rexpect::session::{PtySession, spawn_command};

/// Wall-clock bound on each wait for the terminal's output.
const EXPECT_TIMEOUT_MS: u64 = 120_000;
/// The size of the board's flash, which the flash file holds whole.
const FLASH_BYTES: u64 = 2 * 1024 * 1024;

/// `lrmcal emulator` on a free port in a pseudo-terminal, once the board's USB is up; with the
/// port name it printed.
fn start(flash: &Path) -> (PtySession, String) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_lrmcal-e2e"));
    command
        .arg("emulator")
        .arg("--flash")
        .arg(flash)
        .args(["--port", "0", "--elf"])
        .arg(firmware_elf());
    let mut session = spawn_command(command, Some(EXPECT_TIMEOUT_MS)).expect("a pseudo-terminal");
    let (_, export) = session
        .exp_regex(r"export LRMCAL_PORT=socket://127\.0\.0\.1:\d+")
        .expect("lrmcal emulator prints the port to use");
    let port = export.trim_start_matches("export LRMCAL_PORT=").to_string();
    session
        .exp_string("USB enumerated")
        .expect("the board's USB serial port comes up");
    (session, port)
}

/// Waits for the end of `lrmcal emulator` after a stop request: its last words and exit 0.
fn assert_stops_cleanly(session: &mut PtySession, port: &str) {
    session
        .exp_string("board stopped; flash saved in")
        .expect("lrmcal emulator says the board stopped");
    match session.process().wait() {
        Ok(WaitStatus::Exited(_, 0)) => {}
        other => panic!("lrmcal emulator ended with {other:?}, not exit code 0"),
    }
    let address = port.trim_start_matches("socket://");
    assert!(
        std::net::TcpStream::connect(address).is_err(),
        "the emulated board still serves {port} after lrmcal emulator ended"
    );
}

/// The board's status as `lrmcal status` prints it.
fn status(port: &str) -> String {
    String::from_utf8_lossy(&lrmcal_process(port, &["status"]).stdout).into_owned()
}

/// The six servo pulses (µs) of a status text, `None` for a limp servo.
fn status_pulses(status: &str) -> Vec<Option<u32>> {
    status
        .lines()
        .skip_while(|line| !line.starts_with("joint"))
        .skip(1)
        .take(6)
        .map(|line| line.split_whitespace().last().and_then(|p| p.parse().ok()))
        .collect()
}

#[test]
fn the_emulator_command_serves_every_device_command_and_keeps_its_flash() {
    let dir = tempfile::tempdir().expect("scratch folder");
    let calibration = demo_calibrations(dir.path());
    let flash = dir.path().join("board.flash");
    let (mut session, port) = start(&flash);

    assert!(
        status(&port).contains("calibration none"),
        "a new flash file is a blank board"
    );
    let pushed = lrmcal_process(&port, &["push", calibration.to_str().expect("UTF-8 path")]);
    let pushed = String::from_utf8_lossy(&pushed.stdout).into_owned();
    let id = pushed
        .strip_prefix("calibration ")
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("lrmcal push printed {pushed:?}"))
        .to_string();
    assert!(status(&port).contains(&format!("calibration {id}")));

    lrmcal_process(
        &port,
        &[
            "move",
            "20",
            "-30",
            "35",
            "10",
            "-25",
            "15",
            "--duration-ms",
            "400",
        ],
    );
    let deadline = Instant::now() + Duration::from_secs(60);
    let still = loop {
        let now = status(&port);
        if now.contains("motion still") {
            break now;
        }
        assert!(Instant::now() < deadline, "the move does not end:\n{now}");
        std::thread::sleep(Duration::from_millis(200));
    };
    assert!(
        still.contains("20.00"),
        "joint 1's target is not 20°:\n{still}"
    );
    let reported: Vec<u32> = status_pulses(&still)
        .into_iter()
        .map(|p| p.unwrap_or_else(|| panic!("a servo is limp after the move:\n{still}")))
        .collect();
    // The emulator shows the pulses measured on GPIO 2..7 whenever they change: the last
    // change must be to the pulses the board reports, to the PWM's 1 µs.
    loop {
        let (_, line) = session
            .exp_regex(r"servo pulses \(us\), GPIO 2,3,4,5,6,7: [0-9. ]+")
            .unwrap_or_else(|e| panic!("the emulator never showed pulses {reported:?}: {e}"));
        let measured: Vec<f64> = line
            .rsplit(':')
            .next()
            .unwrap_or_default()
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        if measured.len() == 6
            && measured
                .iter()
                .zip(&reported)
                .all(|(m, r)| (m - f64::from(*r)).abs() <= 1.0)
        {
            break;
        }
    }

    let pulled = dir.path().join("pulled.json");
    lrmcal_process(
        &port,
        &["pull", "--out", pulled.to_str().expect("UTF-8 path")],
    );
    let pulled_text = std::fs::read_to_string(&pulled).expect("lrmcal pull wrote its file");
    assert!(
        pulled_text.contains(&format!("\"id\": \"{id}\"")),
        "{pulled_text}"
    );

    // Ctrl-C at the terminal.
    session.send_control('c').expect("send Ctrl-C");
    assert_stops_cleanly(&mut session, &port);
    let saved = std::fs::metadata(&flash).expect("the flash file is written");
    assert_eq!(saved.len(), FLASH_BYTES);

    // A restart on the saved flash has the calibration, as a board after a power cycle.
    let (mut session, port) = start(&flash);
    assert!(
        status(&port).contains(&format!("calibration {id}")),
        "the restarted board lost calibration {id}"
    );
    let again = dir.path().join("again.json");
    lrmcal_process(
        &port,
        &["pull", "--out", again.to_str().expect("UTF-8 path")],
    );
    assert_eq!(
        std::fs::read_to_string(&again).expect("second pull"),
        pulled_text,
        "the calibration read back after the restart differs"
    );
    // A service manager's SIGTERM stops it the same way.
    session
        .process_mut()
        .signal(Signal::SIGTERM)
        .expect("send SIGTERM");
    assert_stops_cleanly(&mut session, &port);
}
