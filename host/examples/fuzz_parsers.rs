//! The parsers' fuzz campaign: mutated arm descriptions, measurement and
//! pose-list CSVs, calibration files, camera intrinsics and board files,
//! each read as `lrmcal` reads it and
//! held to the invariants of `host::fuzz` (no panic; a refusal names the
//! file and a line or key; what is accepted is finite).
//!
//! ```text
//! cargo run --release -p host --example fuzz_parsers -- \
//!     [--inputs N] [--seed N] [--threads N] [--case FORMAT:K]
//! ```
//!
//! `--inputs` per format (default 10⁵). Seeded and reproducible: input `K`
//! of a format is made from the seed, the format and `K` alone. On a broken
//! invariant it shrinks the input, prints the seed, the invariant, the
//! smallest input that still breaks it and the command that replays it, and
//! exits with 1; bad arguments exit with 2.

use std::process::ExitCode;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

use host::fuzz::{self, Corpus, Counts, Format, Violation};
use tempfile::TempDir;

/// Defaults: the issue's count per format and a fixed seed.
const INPUTS: u64 = 100_000;
const SEED: u64 = 0x5eed_f11e;
/// Inputs a worker takes at a time.
const CHUNK: u64 = 500;

/// What to run.
struct Args {
    inputs: u64,
    seed: u64,
    threads: usize,
    /// One input only, to replay a failure.
    case: Option<(Format, u64)>,
}

const USAGE: &str = "usage: fuzz_parsers [--inputs N] [--seed N] [--threads N] \
                     [--case arm:K|measurements:K|poses:K|calibration:K]";

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        inputs: INPUTS,
        seed: SEED,
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
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
            "--inputs" => args.inputs = number(&value)?,
            "--seed" => args.seed = number(&value)?,
            "--threads" => args.threads = number(&value)?.max(1) as usize,
            "--case" => {
                let (name, index) = value
                    .split_once(':')
                    .ok_or_else(|| format!("--case {value}: expected FORMAT:INDEX\n{USAGE}"))?;
                let format = Format::from_name(name)
                    .ok_or_else(|| format!("--case {value}: no format {name:?}\n{USAGE}"))?;
                args.case = Some((format, number(index)?));
            }
            _ => return Err(format!("unknown argument {flag}\n{USAGE}")),
        }
    }
    Ok(args)
}

/// The first violation found: format, input index, what broke.
type Found = (Format, u64, Violation);

/// Runs `inputs` inputs of every format on one worker per directory of
/// `dirs`; the tallies per format, or the first violation.
fn campaign(
    corpus: &Corpus,
    args: &Args,
    dirs: &[TempDir],
) -> Result<[Counts; Format::ALL.len()], Found> {
    let chunks = args.inputs.div_ceil(CHUNK);
    let next = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let found: Mutex<Option<Found>> = Mutex::new(None);
    let totals = Mutex::new([Counts::default(); Format::ALL.len()]);
    std::thread::scope(|scope| {
        for dir in dirs {
            scope.spawn(|| {
                let mut counts = [Counts::default(); Format::ALL.len()];
                while !stop.load(Ordering::Relaxed) {
                    let task = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&format) = Format::ALL.get((task / chunks) as usize) else {
                        break;
                    };
                    let start = (task % chunks) * CHUNK;
                    let end = (start + CHUNK).min(args.inputs);
                    let tally = &mut counts[format as usize];
                    if let Err((index, violation)) =
                        fuzz::run(corpus, format, args.seed, start..end, dir.path(), tally)
                    {
                        stop.store(true, Ordering::Relaxed);
                        if let Ok(mut first) = found.lock() {
                            first.get_or_insert((format, index, violation));
                        }
                    }
                }
                if let Ok(mut totals) = totals.lock() {
                    for (t, c) in totals.iter_mut().zip(&counts) {
                        t.merge(c);
                    }
                }
            });
        }
    });
    if let Some(found) = found.into_inner().ok().flatten() {
        return Err(found);
    }
    Ok(totals.into_inner().unwrap_or_default())
}

/// Prints the seed, the broken invariant, the smallest input that still
/// breaks it and the replay command.
fn report(corpus: &Corpus, seed: u64, (format, index, violation): &Found) {
    let input = corpus.input(*format, seed, *index);
    let dir = fuzz::scratch_dir().ok();
    let path = dir.as_ref().map_or_else(
        || std::env::temp_dir().join(format.file_name()),
        |d| d.path().join(format.file_name()),
    );
    let invariant = violation.invariant;
    let small = fuzz::mutate::shrink(&input, |trial| {
        fuzz::check(*format, &path, trial).is_err_and(|v| v.invariant == invariant)
    });
    let again = fuzz::check(*format, &path, &small)
        .err()
        .unwrap_or_else(|| violation.clone());
    eprintln!(
        "FAILED: {} input {index}, seed {seed}: invariant \"{invariant}\" broken",
        format.name()
    );
    eprintln!("  {}", violation.detail);
    eprintln!(
        "smallest input that still breaks it: {} of {} bytes ({}):",
        small.len(),
        input.len(),
        format.file_name()
    );
    for line in small.split_inclusive(|&b| b == b'\n') {
        eprintln!("  | {}", line.escape_ascii());
    }
    eprintln!("  then: {}", again.detail);
    eprintln!(
        "replay: cargo run --release -p host --example fuzz_parsers -- --seed {seed} --case {}:{index}",
        format.name()
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
    fuzz::keep_panic_messages();
    let corpus = match Corpus::new() {
        Ok(corpus) => corpus,
        Err(message) => {
            eprintln!("FAILED: {message}");
            return ExitCode::FAILURE;
        }
    };
    println!(
        "parser fuzz campaign, seed {} (--seed {0} replays it)",
        args.seed
    );
    let found = match args.case {
        Some((format, index)) => {
            let mut counts = Counts::default();
            let dir = match fuzz::scratch_dir() {
                Ok(dir) => dir,
                Err(e) => {
                    eprintln!("FAILED: a temporary directory: {e}");
                    return ExitCode::FAILURE;
                }
            };
            match fuzz::run(
                &corpus,
                format,
                args.seed,
                index..index + 1,
                dir.path(),
                &mut counts,
            ) {
                Ok(()) => {
                    println!("{} input {index} holds every invariant", format.name());
                    None
                }
                Err((index, v)) => Some((format, index, v)),
            }
        }
        None => {
            let dirs: Result<Vec<TempDir>, _> =
                (0..args.threads).map(|_| fuzz::scratch_dir()).collect();
            let dirs = match dirs {
                Ok(dirs) => dirs,
                Err(e) => {
                    eprintln!("FAILED: a temporary directory: {e}");
                    return ExitCode::FAILURE;
                }
            };
            let started = Instant::now();
            match campaign(&corpus, &args, &dirs) {
                Ok(totals) => {
                    let seconds = started.elapsed().as_secs_f64();
                    for (format, c) in Format::ALL.iter().zip(&totals) {
                        println!(
                            "{}: {} mutated inputs: {} accepted, {} refused naming the line and \
                             the key or column, {} the line, {} the key",
                            format.name(),
                            c.inputs,
                            c.accepted,
                            c.line_and_field,
                            c.line_only,
                            c.field_only
                        );
                    }
                    println!(
                        "{} inputs in {seconds:.1} s on {} threads",
                        totals.iter().map(|c| c.inputs).sum::<u64>(),
                        args.threads
                    );
                    None
                }
                Err(found) => Some(found),
            }
        }
    };
    match found {
        None => {
            println!("all invariants held");
            ExitCode::SUCCESS
        }
        Some(found) => {
            report(&corpus, args.seed, &found);
            ExitCode::FAILURE
        }
    }
}
