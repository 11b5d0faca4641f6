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

/// Every routine on every pair of `set`, against the FPU.
fn check(set: &str, pairs: &[(u32, u32)]) {
    for &(a, b) in pairs {
        for (name, soft) in OPERATIONS {
            let (got, want) = (soft(a, b), fpu(name, a, b));
            assert!(
                same(got, want),
                "{set}: {name}({a:#010x}, {b:#010x}) = {got:#010x}, the FPU gives {want:#010x}"
            );
        }
    }
}

#[test]
fn edge_values() {
    check("edge values", &edge_pairs());
}

/// A million pairs of each random family.
#[test]
fn random_families() {
    for (seed, family) in FAMILIES.iter().enumerate() {
        check(family.0, &draw(family, 1 + seed as u64, 1_000_000));
    }
}
