//! Every result bit for bit against the host's FPU, on the pairs of `cases`.

use super::cases::{FAMILIES, draw, edge_pairs, fpu, same};
use super::{add, mul};

/// A routine on the bits of two `f32`s.
type Routine = fn(u32, u32) -> u32;

/// The Rust routines, by the operation names of `cases::fpu`.
const OPERATIONS: [(&str, Routine); 3] = [
    ("add", add),
    ("sub", |a, b| add(a, b ^ super::SIGN)),
    ("mul", mul),
];

fn check(pairs: &[(u32, u32)]) {
    for &(a, b) in pairs {
        for (name, soft) in OPERATIONS {
            let (got, want) = (soft(a, b), fpu(name, a, b));
            assert!(
                same(got, want),
                "{name}({a:#010x}, {b:#010x}) = {got:#010x}, the FPU gives {want:#010x}"
            );
        }
    }
}

#[test]
fn edge_values() {
    check(&edge_pairs());
}

#[test]
fn random_bits() {
    check(&draw(&FAMILIES[0], 1, 1_000_000));
}

#[test]
fn nearby_exponents() {
    check(&draw(&FAMILIES[1], 2, 1_000_000));
}

#[test]
fn ties_and_exact_results() {
    check(&draw(&FAMILIES[2], 3, 1_000_000));
}

#[test]
fn overflow_and_underflow() {
    check(&draw(&FAMILIES[3], 4, 1_000_000));
}
