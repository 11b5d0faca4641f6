//! Operand pairs for checking single-precision arithmetic bit for bit: the
//! host tests run them through the Rust routines, the emulator test
//! (`tests/tests/emulator_soft_float.rs`) through the firmware's exported
//! `__aeabi_f*` on the real binary. Every result is compared with the host's
//! FPU.

use rand::{Rng, SeedableRng, rngs::StdRng};

/// Edge magnitudes of each class; [`edge_pairs`] takes both signs.
const EDGE_MAGNITUDES: [u32; 21] = [
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

/// Every pair of the edge values, both signs.
pub fn edge_pairs() -> Vec<(u32, u32)> {
    let values: Vec<u32> = EDGE_MAGNITUDES
        .iter()
        .flat_map(|&m| [m, m | 1 << 31])
        .collect();
    values
        .iter()
        .flat_map(|&a| values.iter().map(move |&b| (a, b)))
        .collect()
}

/// A family of random operand pairs: its name and how one pair is drawn.
pub type Family = (&'static str, fn(&mut StdRng) -> (u32, u32));

/// The random families, each aimed at some paths of the routines.
pub const FAMILIES: [Family; 5] = [
    // Uniformly random bits: every class, mostly far-apart exponents.
    ("random bits", |rng| (rng.random(), rng.random())),
    // Nearby exponents, where additions carry and subtractions cancel.
    ("nearby exponents", |rng| {
        let a: u32 = rng.random();
        let e = ((a >> 23) & 0xff) as i32 + rng.random_range(-26..=26);
        let b = (rng.random::<u32>() & 0x807f_ffff) | ((e.clamp(0, 255) as u32) << 23);
        (a, b)
    }),
    // Significands with at most three bits set: exact results, exact ties and
    // powers of two, which random significands almost never give.
    ("ties and exact results", |rng| {
        let ea = rng.random_range(100..156);
        let eb = (ea as i32 + rng.random_range(-25..=25)) as u32;
        (sparse(rng, ea), sparse(rng, eb))
    }),
    // The ends of the range: overflow to infinity, underflow into subnormals
    // and to zero, rounding across those boundaries.
    ("overflow and underflow", |rng| {
        let (low, high) = if rng.random::<bool>() {
            (0, 90)
        } else {
            (190, 255)
        };
        let mut pick = || (rng.random::<u32>() & 0x807f_ffff) | (rng.random_range(low..high) << 23);
        (pick(), pick())
    }),
    // A zero and anything, either way round (x ± 0 has a path of its own).
    ("a zero operand", |rng| {
        let x: u32 = rng.random();
        let zero = u32::from(rng.random::<bool>()) << 31;
        if rng.random::<bool>() {
            (x, zero)
        } else {
            (zero, x)
        }
    }),
];

/// A random sign, exponent field `e` and up to three fraction bits.
fn sparse(rng: &mut StdRng, e: u32) -> u32 {
    let mut fraction = 0;
    for _ in 0..rng.random_range(0..=3) {
        fraction |= 1 << rng.random_range(0..23);
    }
    (u32::from(rng.random::<bool>()) << 31) | (e << 23) | fraction
}

/// `count` pairs of `family`, the same for the same `seed`.
pub fn draw(family: &Family, seed: u64, count: usize) -> Vec<(u32, u32)> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count).map(|_| (family.1)(&mut rng)).collect()
}

/// The bits the host's FPU gives for `op` ("add", "sub" or "mul").
pub fn fpu(op: &str, a: u32, b: u32) -> u32 {
    let (a, b) = (f32::from_bits(a), f32::from_bits(b));
    match op {
        "add" => a + b,
        "sub" => a - b,
        "mul" => a * b,
        _ => panic!("unknown operation {op}"),
    }
    .to_bits()
}

/// Whether `got` is what the FPU gives, `want` (any NaN for a NaN: its
/// payload is not specified).
pub fn same(got: u32, want: u32) -> bool {
    got == want || (f32::from_bits(got).is_nan() && f32::from_bits(want).is_nan())
}
