//! Every result bit for bit against the host's FPU (NaN only as NaN: its
//! payload is not specified).

use super::{add, mul};
use rand::{Rng, SeedableRng, rngs::StdRng};

type Soft = fn(u32, u32) -> u32;
type Hard = fn(f32, f32) -> f32;

const OPERATIONS: [(&str, Soft, Hard); 3] = [
    ("add", add, |a, b| a + b),
    ("sub", |a, b| add(a, b ^ super::SIGN), |a, b| a - b),
    ("mul", mul, |a, b| a * b),
];

fn check(a: u32, b: u32) {
    for (name, soft, hard) in OPERATIONS {
        let got = soft(a, b);
        let want = hard(f32::from_bits(a), f32::from_bits(b)).to_bits();
        let both_nan = f32::from_bits(got).is_nan() && f32::from_bits(want).is_nan();
        assert!(
            got == want || both_nan,
            "{name}({a:#010x}, {b:#010x}) = {got:#010x}, the FPU gives {want:#010x}"
        );
    }
}

/// Every pair of the edge values of each class, both signs.
#[test]
fn edge_values() {
    let magnitudes = [
        0x0000_0000, // zero
        0x0000_0001, // smallest subnormal
        0x0000_0003,
        0x0040_0000,
        0x007f_ffff, // largest subnormal
        0x0080_0000, // smallest normal
        0x0080_0001,
        0x00ff_ffff,
        0x0c00_0000,
        0x3400_0000, // 2^-23
        0x3f7f_ffff, // just below 1
        0x3f80_0000, // 1
        0x3f80_0001, // just above 1
        0x3fc0_0000, // 1.5
        0x4000_0000, // 2
        0x5f80_0000,
        0x7f00_0000,
        0x7f7f_ffff, // largest finite
        0x7f80_0000, // infinity
        0x7f80_0001, // signalling NaN
        0x7fc0_0000, // quiet NaN
    ];
    let values: Vec<u32> = magnitudes
        .iter()
        .flat_map(|&m| [m, m | super::SIGN])
        .collect();
    for &a in &values {
        for &b in &values {
            check(a, b);
        }
    }
}

/// Uniformly random bit patterns: every class, mostly far-apart exponents.
#[test]
fn random_bits() {
    let mut rng = StdRng::seed_from_u64(1);
    for _ in 0..1_000_000 {
        check(rng.random(), rng.random());
    }
}

/// Random operands with nearby exponents, where additions carry and
/// subtractions cancel.
#[test]
fn nearby_exponents() {
    let mut rng = StdRng::seed_from_u64(2);
    for _ in 0..1_000_000 {
        let a: u32 = rng.random();
        let e = ((a >> 23) & 0xff) as i32 + rng.random_range(-26..=26);
        let b = (rng.random::<u32>() & 0x807f_ffff) | ((e.clamp(0, 255) as u32) << 23);
        check(a, b);
    }
}

/// Significands with one to three bits set: exact results and exact ties,
/// which random significands almost never give.
#[test]
fn ties_and_exact_results() {
    let mut rng = StdRng::seed_from_u64(3);
    let sparse = |rng: &mut StdRng, e: u32| {
        let mut fraction = 0;
        for _ in 0..rng.random_range(1..=3) {
            fraction |= 1 << rng.random_range(0..23);
        }
        (u32::from(rng.random::<bool>()) << 31) | (e << 23) | fraction
    };
    for _ in 0..1_000_000 {
        let ea = rng.random_range(100..156);
        let eb = (ea as i32 + rng.random_range(-25..=25)) as u32;
        check(sparse(&mut rng, ea), sparse(&mut rng, eb));
    }
}

/// Products and sums at the ends of the range: overflow to infinity,
/// underflow into subnormals and to zero, rounding across those boundaries.
#[test]
fn overflow_and_underflow() {
    let mut rng = StdRng::seed_from_u64(4);
    for _ in 0..1_000_000 {
        let (low, high) = if rng.random::<bool>() {
            (0, 90)
        } else {
            (190, 255)
        };
        let pick = |rng: &mut StdRng| {
            (rng.random::<u32>() & 0x807f_ffff) | (rng.random_range(low..high) << 23)
        };
        check(pick(&mut rng), pick(&mut rng));
    }
}
