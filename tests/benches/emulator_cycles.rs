//! Cycle benchmark on the real firmware binary: CPU cycles of one compensation frame
//! (`firmware::compensator::Compensator::step`) and of the whole servo frame
//! (`run_servo_frame`), for an arm of six joints and the same arm without its last, counted by the emulator's cycle counter from function entry to return
//! (interrupt handlers excluded), for payload 0 and 66.3 g, against the 125,000-cycle budget
//! (1 ms at 125 MHz): it exits with an error when a compensation step or a whole servo frame
//! exceeds it.
//!
//! `cargo bench -p e2e --features emulator --bench emulator_cycles` (after `cargo firmware` and
//! `npm ci` in tests/emulator). The counts do not depend on the host machine: holding still they
//! repeat to the cycle; during a move they vary a little with the frame the move starts in.

#[path = "../tests/emulator_support/mod.rs"]
mod emulator_support;

use emulator_support::{EmulatedBoard, RawLink, test_calibration};
use protocol::{CompensationMode, Request, Response, Timing};
use serde_json::{Value, json};

/// The budget of a servo frame's compensation: 1 ms of the RP2040 at 125 MHz.
const BUDGET_CYCLES: f64 = 125_000.0;
/// The functions measured: (label, part of the mangled symbol name).
const PROBES: [(&str, &str); 2] = [
    ("compensation step", "Compensator4step"),
    ("whole servo frame", "run_servo_frame"),
];
/// A move long enough to give a few dozen frames with moving targets.
const MOVE_MS: u32 = 1500;

fn ok(response: Response, what: &str) {
    assert_eq!(response, Response::Done, "{what}");
}

fn stats(board: &mut EmulatedBoard, symbol: &str) -> Value {
    board.request(json!({"cmd": "probe_stats", "symbol": symbol, "clear": true}))
}

/// The test calibration's arm without its last `cut` joints (the tool on
/// the last one left, as on an arm built without them).
fn shorter(calibration: &protocol::Calibration, cut: usize) -> protocol::Calibration {
    let joints = calibration.calibrated.joint_count() - cut;
    let mut shorter = *calibration;
    for arm in [&mut shorter.nominal, &mut shorter.calibrated] {
        arm.joints = model::PerJoint::from_slice(&arm.joints[..joints]).expect("fewer joints");
    }
    shorter.home_rad =
        protocol::PerChannel::from_slice(&calibration.home_rad[..joints]).expect("fewer joints");
    shorter.max_correction_rad =
        protocol::PerChannel::from_slice(&calibration.max_correction_rad[..joints])
            .expect("fewer joints");
    shorter.check().expect("the shorter calibration is valid");
    shorter
}

fn main() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    for (_, symbol) in PROBES {
        board.request(json!({"cmd": "probe", "symbol": symbol}));
    }
    let mut link = RawLink::connect(&board);

    println!("cycles per call on the real firmware (rp2040js cycle count, ISRs excluded)");
    println!("budget: {BUDGET_CYCLES:.0} cycles = 1 ms at 125 MHz");
    println!(
        "{:<7} {:<10} {:<22} {:<8} {:>6} {:>9} {:>9} {:>9} {:>9}",
        "joints", "payload", "function", "phase", "calls", "min", "mean", "max", "max/budget"
    );
    // Worst call of each probe over every arm and phase.
    let mut worst = [0.0f64; PROBES.len()];
    let six = test_calibration(1);
    for calibration in [six, shorter(&six, 1)] {
        measure_arm(&mut board, &mut link, &calibration, &mut worst);
    }
    let mut over = false;
    for ((label, _), worst) in PROBES.iter().zip(worst) {
        println!(
            "worst {label}: {worst:.0} cycles = {:.1}% of the budget",
            100.0 * worst / BUDGET_CYCLES
        );
        if worst > BUDGET_CYCLES {
            eprintln!("the {label} is over the budget of {BUDGET_CYCLES:.0} cycles");
            over = true;
        }
    }
    if over {
        std::process::exit(1);
    }
}

/// Pushes `calibration`, moves between two poses and holds, with and
/// without payload, printing each probe's cycles; raises `worst`.
fn measure_arm(
    board: &mut EmulatedBoard,
    link: &mut RawLink,
    calibration: &protocol::Calibration,
    worst: &mut [f64; PROBES.len()],
) {
    let joints = calibration.calibrated.joint_count();
    link.push(calibration);
    ok(
        link.request(&Request::SetCompensation {
            mode: CompensationMode::Full,
        }),
        "full compensation",
    );
    ok(link.request(&Request::Attach { channel: None }), "attach");
    let poses = [
        [0.5f32, -0.4, 0.6, 0.3, -0.5, 0.4],
        [-0.6, 0.3, -0.5, -0.4, 0.6, -0.8],
    ]
    .map(|pose| protocol::PerChannel::from_slice(&pose[..joints]).expect("at most six joints"));
    for payload_kg in [0.0f32, 0.0663] {
        ok(
            link.request(&Request::SetPayload {
                mass_kg: payload_kg,
            }),
            "payload",
        );
        for (phase, pose) in [("moving", poses[0]), ("moving", poses[1])]
            .into_iter()
            .chain([("holding", poses[1])])
        {
            // A move ends on a frame boundary, which may lie just past the
            // emulated time run for it: let it end before the next one starts.
            for _ in 0..10 {
                if !link.status().moving {
                    break;
                }
                board.run_us(20_000);
            }
            for (_, symbol) in PROBES {
                stats(board, symbol);
            }
            if phase == "moving" {
                ok(
                    link.request(&Request::Move {
                        targets_rad: pose,
                        timing: Timing::DurationMs(MOVE_MS),
                    }),
                    "move",
                );
                board.run_us(u64::from(MOVE_MS) * 1000);
            } else {
                board.run_us(500_000);
            }
            let status = link.status();
            assert!(
                !status.moving || phase == "moving",
                "still moving while holding"
            );
            for (probe, (label, symbol)) in PROBES.into_iter().enumerate() {
                let s = stats(board, symbol);
                let calls = s["calls"].as_u64().unwrap_or(0);
                assert!(
                    calls > 0,
                    "no call of {symbol} during the {phase} phase\n{}",
                    board.log()
                );
                let max = s["max"].as_f64().expect("max");
                worst[probe] = worst[probe].max(max);
                println!(
                    "{:<7} {:<10} {:<22} {:<8} {:>6} {:>9} {:>9} {:>9} {:>8.1}%",
                    joints,
                    format!("{:.1} g", payload_kg * 1000.0),
                    label,
                    phase,
                    calls,
                    s["min"],
                    s["mean"],
                    s["max"],
                    100.0 * max / BUDGET_CYCLES
                );
            }
            let report = status.compensation;
            println!(
                "{:<18} last solve: converged {}, {} iterations, {:.1} µm, {} fallbacks",
                "", report.converged, report.iterations, report.error_um, report.fallbacks
            );
        }
    }
}
