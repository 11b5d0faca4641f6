//! Every chain under every option that fits geometry: random serial chains
//! of 1 to 10 joints (revolute and prismatic, axes parallel, perpendicular
//! and skewed, fixed joints between moving ones) are written as URDF, every
//! joint placement is moved by a 6-DOF error, and noisy points of the true
//! chain are calibrated through `lrmcal identify` and checked through
//! `lrmcal predict` against the truth. The bar is an independent fit of the
//! placements' errors themselves (`chain_support`, no DH): what a complete
//! parametrisation reaches from the same points.

mod chain_support;

use std::path::Path;

use chain_support::{calibrate, random_chain_urdf};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The options whose parameters include the geometry.
const GEOMETRIC_OPTIONS: [&str; 3] = ["kinematic", "elasto-kinematic", "elasto-kinematic-servo"];

#[test]
fn random_chains_are_calibrated_as_well_as_their_placements_allow() {
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    let lrmcal = Path::new(env!("CARGO_BIN_EXE_lrmcal"));
    // Sixteen chains, every length from 1 to 10 joints among them.
    for seed in 1..=16u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
        let joints = 1 + (seed as usize * 7) % 10;
        let urdf = dir.path().join(format!("chain-{seed}.urdf"));
        std::fs::write(&urdf, random_chain_urdf(&mut rng, joints)).unwrap();
        for option in GEOMETRIC_OPTIONS {
            let o = calibrate(lrmcal, &urdf, ("base", "tip"), option, seed, 150);
            // The residual at the noise, and the truth predicted as well as
            // a fit of the placements themselves predicts it.
            let residual_ok = o.residual_rms <= 1.1 * o.noise_rms;
            let check_ok = o.lrmcal_mean <= 1.2 * o.independent_mean;
            if !(residual_ok && check_ok) {
                failures.push(format!("chain {seed} ({joints} joints), {option}: {o:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
