//! The firmware's fuzz campaign: random and mutated frames through the frame
//! reader, decoder and handler, and random request sequences with servo
//! frames, power cuts and reboots, every invariant of `firmware::fuzz`
//! checked after every step.
//!
//! ```text
//! cargo run --release -p firmware --features fuzz --example fuzz_campaign -- \
//!     [--frames N] [--sequences N] [--seed N] [--case frames:K | sequences:K]
//! ```
//!
//! Seeded and reproducible: case `K` of a campaign is generated from the
//! seed and `K` alone. On a broken invariant it shrinks the case, prints the
//! seed, the invariant, the smallest case that still breaks it and the
//! command that replays it, and exits with 1; bad arguments exit with 2.

use std::panic::{self, AssertUnwindSafe};
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Instant;

use firmware::fuzz::{self, Case, Counts, Fault, Fixtures, Invariant, Violation};
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Defaults: the issue's counts (10⁶ frames, 10⁵ sequences) and a fixed seed.
const FRAMES: u64 = 1_000_000;
const SEQUENCES: u64 = 100_000;
const SEED: u64 = 0x1a2b_3c4d;
/// Frames per frame case.
const FRAMES_PER_CASE: u64 = fuzz::FRAMES_PER_CASE as u64;

/// The two campaigns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Frames,
    Sequences,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Self::Frames => "frames",
            Self::Sequences => "sequences",
        }
    }
}

/// What to run.
struct Args {
    frames: u64,
    sequences: u64,
    seed: u64,
    /// One case only, to replay a failure.
    case: Option<(Kind, u64)>,
}

const USAGE: &str =
    "usage: fuzz_campaign [--frames N] [--sequences N] [--seed N] [--case frames:K|sequences:K]";

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        frames: FRAMES,
        sequences: SEQUENCES,
        seed: SEED,
        case: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--help" || flag == "-h" {
            return Err(USAGE.into());
        }
        let value = it
            .next()
            .ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))?;
        let number = |v: &str| {
            v.replace('_', "")
                .parse::<u64>()
                .map_err(|e| format!("{flag} {v}: {e}\n{USAGE}"))
        };
        match flag.as_str() {
            "--frames" => args.frames = number(&value)?,
            "--sequences" => args.sequences = number(&value)?,
            "--seed" => args.seed = number(&value)?,
            "--case" => {
                let (kind, index) = value
                    .split_once(':')
                    .ok_or_else(|| format!("--case {value}: expected KIND:INDEX\n{USAGE}"))?;
                let kind = match kind {
                    "frames" => Kind::Frames,
                    "sequences" => Kind::Sequences,
                    _ => return Err(format!("--case {value}: no campaign {kind:?}\n{USAGE}")),
                };
                args.case = Some((kind, number(index)?));
            }
            _ => return Err(format!("unknown argument {flag}\n{USAGE}")),
        }
    }
    Ok(args)
}

/// The message of the last panic, kept by the hook instead of printed.
static PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Case `index` of `kind` under `seed`: its own ChaCha stream, so any case
/// can be made again without the ones before it.
fn generate(kind: Kind, seed: u64, index: u64, frames: u64, fixtures: &Fixtures) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index << 1 | u64::from(kind == Kind::Sequences));
    let mut src = || rng.next_u64();
    match kind {
        Kind::Frames => fuzz::frames_case(&mut src, fixtures, frames as usize),
        Kind::Sequences => fuzz::sequence_case(&mut src, fixtures),
    }
}

/// Runs one case; a panic becomes a violation of "no panic".
fn attempt(fixtures: &Fixtures, case: &Case, counts: &mut Counts) -> Result<(), Violation> {
    match panic::catch_unwind(AssertUnwindSafe(|| fuzz::run(fixtures, case, counts))) {
        Ok(result) => result,
        Err(_) => {
            let message = PANIC.lock().map(|mut m| m.take()).ok().flatten();
            Err(Violation {
                step: None,
                fault: Fault {
                    invariant: Invariant::Panic,
                    detail: message.unwrap_or_else(|| "a panic".into()),
                },
            })
        }
    }
}

/// Runs `count` cases of `kind`; on a violation, reports it and returns false.
fn campaign(kind: Kind, count: u64, frames: u64, seed: u64, fixtures: &Fixtures) -> bool {
    let started = Instant::now();
    let mut counts = Counts::default();
    for index in 0..count {
        let in_case = match kind {
            Kind::Frames => (frames - index * FRAMES_PER_CASE).min(FRAMES_PER_CASE),
            Kind::Sequences => 0,
        };
        let case = generate(kind, seed, index, in_case, fixtures);
        if let Err(violation) = attempt(fixtures, &case, &mut counts) {
            report(kind, seed, (index, in_case), &case, &violation, fixtures);
            return false;
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    match kind {
        Kind::Frames => println!(
            "frames: {} random and mutated frames in {count} cases, {seconds:.1} s: \
             {} frames read ({} intact, {} over-long dropped), {} servo frames, {} boots",
            counts.frames_sent,
            counts.frames_read,
            counts.intact,
            counts.overflows,
            counts.servo_frames,
            counts.boots
        ),
        Kind::Sequences => println!(
            "sequences: {count} request sequences, {seconds:.1} s: {} requests, {} servo frames, \
             {} calibrations stored, {} power cuts, {} boots",
            counts.requests, counts.servo_frames, counts.stored, counts.power_cuts, counts.boots
        ),
    }
    true
}

/// Prints the seed, the broken invariant and the smallest case that still
/// breaks it; `at` is the case's index and, for a frame case, its frame count.
fn report(
    kind: Kind,
    seed: u64,
    at: (u64, u64),
    case: &Case,
    violation: &Violation,
    fixtures: &Fixtures,
) {
    let (index, frames) = at;
    let invariant = violation.fault.invariant;
    let small = fuzz::shrink(case, |trial| {
        attempt(fixtures, trial, &mut Counts::default())
            .is_err_and(|v| v.fault.invariant == invariant)
    });
    let again = attempt(fixtures, &small, &mut Counts::default())
        .err()
        .unwrap_or_else(|| violation.clone());
    eprintln!(
        "FAILED: {} case {index}, seed {seed}: invariant \"{invariant}\" broken",
        kind.name()
    );
    eprintln!("  {violation}");
    eprintln!(
        "smallest case that still breaks it: {} of {} steps, preload {:?}",
        small.steps.len(),
        case.steps.len(),
        small.preload
    );
    for (i, step) in small.steps.iter().enumerate() {
        eprintln!("  {i:3}: {step:?}");
    }
    eprintln!("  then: {again}");
    let frames = match kind {
        Kind::Frames => format!(" --frames {frames}"),
        Kind::Sequences => String::new(),
    };
    eprintln!(
        "replay: cargo run --release -p firmware --features fuzz --example fuzz_campaign -- \
         --seed {seed}{frames} --case {}:{index}",
        kind.name()
    );
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(args) => args,
        Err(message) => {
            eprintln!("{message}");
            return ExitCode::from(2);
        }
    };
    panic::set_hook(Box::new(|info| {
        if let Ok(mut last) = PANIC.lock() {
            *last = Some(info.to_string());
        }
    }));
    let fixtures = Fixtures::new();
    println!(
        "firmware fuzz campaign, seed {} (--seed {0} replays it)",
        args.seed
    );
    let ok = match args.case {
        Some((kind, index)) => {
            let frames = args.frames.min(FRAMES_PER_CASE);
            let case = generate(kind, args.seed, index, frames, &fixtures);
            match attempt(&fixtures, &case, &mut Counts::default()) {
                Ok(()) => {
                    println!("{} case {index} holds every invariant", kind.name());
                    true
                }
                Err(violation) => {
                    report(
                        kind,
                        args.seed,
                        (index, frames),
                        &case,
                        &violation,
                        &fixtures,
                    );
                    false
                }
            }
        }
        None => {
            let frame_cases = args.frames.div_ceil(FRAMES_PER_CASE);
            campaign(Kind::Frames, frame_cases, args.frames, args.seed, &fixtures)
                && campaign(Kind::Sequences, args.sequences, 0, args.seed, &fixtures)
        }
    };
    if ok {
        println!("all invariants held");
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
