//! How long a calibration commit stalls the servo frames, measured on the real firmware in the
//! emulated RP2040. A commit (`calib/commit`: erase a 4 KiB slot, program the record, read it
//! back) runs in the serial task with the CPU waiting for the flash chip, so the 50 Hz servo
//! frame cannot run. The emulator makes the chip busy for the times of its datasheet (W25Q16JV,
//! the Pico's: sector erase 45 ms typical / 400 ms maximum, page program 0.4 / 3 ms), and the
//! test reads when each servo frame started (a probe on `run_servo_frame`) and the pulses on
//! the six servo pins.
//!
//! What would make it fail: the stall not showing (the flash busy time not modelled), a frame
//! gap longer than the flash busy time plus one frame and 5 ms of the firmware's own work, the
//! watchdog resetting the board, a servo pulse missing or changing width while the frames are
//! stalled (the PWM keeps sending the last pulses by itself, so the servos hold), or the pulses
//! not back where they were once the frames have caught up, or moving at all after the stall:
//! the calibration committed is the one in use under another id, and the compensation goes on
//! from the shape the arm holds.
//!
//! `cargo test -p e2e --features emulator --test emulator_flash_stall -- --nocapture` prints
//! the figures of the README's "Reliability" section.

mod emulator_support;

use emulator_support::{EmulatedBoard, RawLink, SERVO_PINS, calibration_bytes, test_calibration};
use protocol::{CompensationMode, Request, Response, Timing};
use serde_json::{Value, json};

/// The servo frame period, ns.
const FRAME_NS: f64 = 20e6;
/// A frame starting this much after its 20 ms slot counts as late, ns.
const LATE_NS: f64 = 1e6;
/// The firmware's own share of a commit (decode, CRCs, read-back, switching calibration, the
/// compensation's first frame under it) may add this much to the flash chip's busy time, ns:
/// up to 3.2 ms with no busy time, 5.2 ms once behind a 421 ms erase (the 1,338-byte record).
const OWN_WORK_NS: f64 = 8e6;
/// Emulated time watched after the commit: the frames have caught up well before its end.
const AFTER_US: u64 = 600_000;
/// A pose to hold while the calibration is committed.
const POSE_RAD: [f32; 6] = [0.4, -0.3, 0.5, 0.2, -0.6, 0.3];

fn ok(response: Response, what: &str) {
    assert_eq!(response, Response::Done, "{what}");
}

fn as_f64s(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default()
}

/// One commit with the flash chip timed as `timing`; prints and checks what the servos saw.
fn measure(timing: &str) {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    board.request(json!({"cmd": "flash_timing", "timing": timing}));
    board.request(json!({"cmd": "probe", "symbol": "run_servo_frame"}));
    let mut link = RawLink::connect(&board);
    // Ids 61 and 68 give the same arm (test_calibration scales its errors by id mod 7): the
    // commit changes the calibration's id only, so the pulses must not change at all.
    let (first, second) = (test_calibration(61), test_calibration(68));
    assert_eq!(first.calibrated, second.calibrated);
    link.push(&first);
    ok(
        link.request(&Request::SetCompensation {
            mode: CompensationMode::Full,
        }),
        "full compensation",
    );
    ok(
        link.request(&Request::Move {
            targets_rad: POSE_RAD.into(),
            timing: Timing::DurationMs(300),
        }),
        "move",
    );
    // A commit is refused while moving: hold the pose, compensating every frame.
    for _ in 0..50 {
        if !link.status().moving {
            break;
        }
        board.run_us(20_000);
    }
    assert!(!link.status().moving, "the move does not end");
    board.run_us(200_000);
    let (held, _) = board.servo_pulses(1);
    let held: Vec<f64> = held.iter().map(|w| w[0]).collect();

    let before = board.status();
    // Watched from two frames before the push: the push may take less than a frame, and the
    // frames before the commit are the reference the stalled ones are measured against.
    let since = json!(before["nanos"].as_f64().expect("nanos") - 2.0 * FRAME_NS);
    link.push(&second);
    board.run_us(AFTER_US);
    let after = board.status();
    assert_eq!(
        after["resets"],
        0,
        "the board reset during the commit\n{}",
        board.log()
    );
    assert_eq!(
        link.status().calibration.map(|c| c.id),
        Some(second.id),
        "the commit did not take"
    );
    let busy_ns = after["flash_busy_ns"].as_f64().expect("flash_busy_ns")
        - before["flash_busy_ns"].as_f64().expect("flash_busy_ns");
    let erases = after["erases"].as_u64().unwrap_or(0) - before["erases"].as_u64().unwrap_or(0);
    let programs =
        after["programs"].as_u64().unwrap_or(0) - before["programs"].as_u64().unwrap_or(0);

    let calls = board
        .request(json!({"cmd": "probe_calls", "symbol": "run_servo_frame", "since_ns": since}));
    let starts = as_f64s(&calls["starts_ns"]);
    assert!(starts.len() > 10, "too few servo frames: {calls}");
    let gaps: Vec<f64> = starts.windows(2).map(|w| w[1] - w[0]).collect();
    let longest_gap = gaps.iter().copied().fold(0.0, f64::max);
    // Frames keep to their 20 ms grid (embassy's ticker runs missed ones at once): lateness is
    // the start against the grid of the first frame watched.
    let lateness: Vec<f64> = starts
        .iter()
        .enumerate()
        .map(|(k, s)| s - (starts[0] + k as f64 * FRAME_NS))
        .collect();
    let late = lateness.iter().filter(|l| **l > LATE_NS).count();
    let latest = lateness.iter().copied().fold(0.0, f64::max);

    // The pulses of the whole window, and those from the first frame after the stall on.
    let pin_widths = |board: &mut EmulatedBoard, since: &Value| -> Vec<Vec<f64>> {
        let reply =
            board.request(json!({"cmd": "pulses_since", "pins": SERVO_PINS, "since_ns": since}));
        reply["widths_us"]
            .as_array()
            .expect("widths")
            .iter()
            .map(as_f64s)
            .collect()
    };
    let window = pin_widths(&mut board, &since);
    // The commit's erase starts the wait for the flash; the first frame after it resumes.
    let erase_ns = after["last_erase_ns"]
        .as_f64()
        .expect("the commit erased the flash");
    let resumed = starts
        .iter()
        .copied()
        .find(|s| *s > erase_ns)
        .expect("a servo frame after the commit");
    let after_stall = pin_widths(&mut board, &json!(resumed));
    let window_ns = after["nanos"].as_f64().unwrap_or(0.0) - since.as_f64().unwrap_or(0.0);
    let fewest = window.iter().map(Vec::len).min().unwrap_or(0);
    // Until the frames resume, the pulses are the PWM's last ones; then the compensation
    // under the committed calibration may move them for a few frames; by the end they are back.
    let (mut during_stall, mut transient, mut settled) = (0.0f64, 0.0f64, 0.0f64);
    let mut unsettled = 0;
    for (servo, (all, later)) in window.iter().zip(&after_stall).enumerate() {
        let off = |w: &f64| (w - held[servo]).abs();
        let stalled = all.len() - later.len();
        during_stall = all[..stalled].iter().map(off).fold(during_stall, f64::max);
        transient = later.iter().map(off).fold(transient, f64::max);
        settled = all.iter().rev().take(5).map(off).fold(settled, f64::max);
        unsettled = unsettled.max(
            later
                .iter()
                .rposition(|w| off(w) > 1.0)
                .map_or(0, |i| i + 1),
        );
    }

    let len = calibration_bytes(&second).len();
    println!(
        "flash commit of a {len}-byte calibration, holding a pose with full compensation, \
         flash timing '{timing}':"
    );
    println!(
        "  flash chip busy {:.1} ms ({erases} sector erase, {programs} program calls)",
        busy_ns / 1e6
    );
    println!(
        "  longest gap between servo frame starts {:.1} ms (period 20 ms); {late} frames late, \
         the latest by {:.1} ms",
        longest_gap / 1e6,
        latest / 1e6,
    );
    println!(
        "  servo pulses: at least {fewest} per pin in {:.0} ms; unchanged (within {during_stall:.1} µs) \
         while the frames stall; the compensation, going on from the held shape under the \
         committed calibration, then moves them by up to {transient:.0} µs over {unsettled} \
         frames; back within {settled:.1} µs",
        window_ns / 1e6
    );

    assert!(erases >= 1, "the commit erased nothing");
    assert!(
        (busy_ns > 0.0) == (timing != "none"),
        "flash timing '{timing}' kept the chip busy {busy_ns} ns"
    );
    assert!(
        longest_gap >= busy_ns,
        "the servo frames ran while the CPU waited for the flash: gap {longest_gap} ns, \
         flash busy {busy_ns} ns from {erase_ns} ns; frames started at {starts:?} ns"
    );
    assert!(
        longest_gap <= busy_ns + FRAME_NS + OWN_WORK_NS,
        "a commit stalls the servo frames by {longest_gap} ns, more than the flash's {busy_ns} ns \
         plus a frame and {OWN_WORK_NS} ns"
    );
    assert!(
        lateness.last().is_some_and(|l| *l <= LATE_NS),
        "the servo frames do not catch up after the commit: {lateness:?}"
    );
    // The PWM runs on its own: a pulse every 20 ms on every pin, none changed.
    let expected = (window_ns / FRAME_NS).floor() as usize;
    assert!(
        fewest + 1 >= expected,
        "a pin missed pulses during the commit: {fewest} in {window_ns} ns\n{window:?}"
    );
    assert!(
        during_stall <= 1.0,
        "a servo pulse changed by {during_stall} µs while the frames stalled\n{window:?}"
    );
    // The same arm committed again: the solve goes on from the shape it holds, which
    // has settled already.
    assert!(
        transient <= 1.0,
        "re-committing the same calibration moved a servo pulse by {transient} µs\n{window:?}"
    );
    assert!(
        settled <= 1.0,
        "the pulses are not back where they were after the commit\n{window:?}"
    );
}

#[test]
fn a_flash_commit_delays_the_servo_frames_by_the_flash_time_and_the_pulses_hold() {
    // Without a busy flash chip first: what the commit costs apart from the waiting.
    measure("none");
    measure("typical");
    measure("max");
}
