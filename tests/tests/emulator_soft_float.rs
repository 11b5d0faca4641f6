//! The firmware's single-precision add, subtract and multiply on the real binary: its exported
//! `__aeabi_fadd`, `__aeabi_fsub` and `__aeabi_fmul` (Thumb assembly for the common case, Rust
//! for the rest, `firmware/src/soft_float/`) called in the emulated RP2040 on the operand pairs
//! the host tests use, every result bit for bit against the host's FPU. Prints the cycles per
//! call.

mod emulator_support;
#[path = "../../firmware/src/soft_float/cases.rs"]
mod soft_float_cases;

use emulator_support::EmulatedBoard;
use serde_json::json;
use soft_float_cases::{FAMILIES, draw, edge_pairs, fpu, same};

/// The routines, by the operation names of `cases::fpu`.
const ROUTINES: [(&str, &str); 3] = [
    ("add", "__aeabi_fadd"),
    ("sub", "__aeabi_fsub"),
    ("mul", "__aeabi_fmul"),
];
/// Random pairs per family and routine (the host tests take a million of each).
const PAIRS_PER_FAMILY: usize = 100_000;
/// Calls per control request.
const BATCH: usize = 5_000;

/// Results and cycles of `symbol` on `pairs`, called on the emulated core.
fn call(board: &mut EmulatedBoard, symbol: &str, pairs: &[(u32, u32)]) -> (Vec<u32>, Vec<u64>) {
    let (mut results, mut cycles) = (Vec::new(), Vec::new());
    for batch in pairs.chunks(BATCH) {
        let args: Vec<[u32; 2]> = batch.iter().map(|&(a, b)| [a, b]).collect();
        let reply = board.request(json!({"cmd": "call", "symbol": symbol, "args": args}));
        let numbers = |key: &str| -> Vec<u64> {
            reply[key]
                .as_array()
                .unwrap_or_else(|| panic!("reply without '{key}': {reply}"))
                .iter()
                .map(|v| v.as_u64().expect("a number"))
                .collect()
        };
        results.extend(numbers("results").into_iter().map(|r| r as u32));
        cycles.extend(numbers("cycles"));
    }
    (results, cycles)
}

#[test]
fn exported_routines_match_the_fpu_bit_for_bit() {
    let mut board = EmulatedBoard::start();
    let mut sets = vec![("edge values", edge_pairs())];
    for (seed, family) in FAMILIES.iter().enumerate() {
        sets.push((family.0, draw(family, 100 + seed as u64, PAIRS_PER_FAMILY)));
    }
    println!("cycles per call, entry to return: min / mean / max");
    for (op, symbol) in ROUTINES {
        for (set, pairs) in &sets {
            let (results, cycles) = call(&mut board, symbol, pairs);
            assert_eq!(results.len(), pairs.len(), "{symbol}: one result per call");
            for (&(a, b), &got) in pairs.iter().zip(&results) {
                let want = fpu(op, a, b);
                assert!(
                    same(got, want),
                    "{symbol}({a:#010x}, {b:#010x}) = {got:#010x}, the FPU gives {want:#010x}"
                );
            }
            let mean = cycles.iter().sum::<u64>() as f64 / cycles.len() as f64;
            println!(
                "{symbol:<13} {set:<24} {:>4} / {mean:>6.1} / {:>4}",
                cycles.iter().min().unwrap_or(&0),
                cycles.iter().max().unwrap_or(&0),
            );
        }
    }
}
