//! Cost of one inverse-kinematics solve of the tool point (`lrmcal move
//! --xyz`, the demo's positioning figure): the bundled arm, targets the tool
//! point of random in-limit poses clear of collisions, random start poses,
//! the default search (start pose and 16 restarts, collisions checked).
//!
//! Run: `cargo bench -p lrmcal-engine --bench ik`.

#![allow(
    missing_docs,
    reason = "the criterion macros generate an undocumented public function"
)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use lrmcal_engine::ik::{IkOptions, solve_position};
use lrmcal_engine::plan::PlanConfig;
use model::testing::TEST_ARM_JOINTS as JOINTS;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Targets and start poses solved in turn, one per iteration.
const CASES: usize = 50;

fn solve(c: &mut Criterion) {
    let arm = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("the bundled arm parses")
        .arm;
    let chain = arm.chain();
    let config = PlanConfig::default();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut pose = || -> [f64; JOINTS] {
        std::array::from_fn(|i| {
            let [lo, hi] = arm.joints[i].limits;
            rng.random_range(lo..hi)
        })
    };
    let mut cases: Vec<(Vector3<f64>, [f64; JOINTS])> = Vec::new();
    while cases.len() < CASES {
        let q = pose();
        if config.contact(&chain.frames(&q, 0.0)).is_none() {
            cases.push((chain.rigid_tool_point(&q), pose()));
        }
    }
    let options = IkOptions::default();
    let mut k = 0;
    c.bench_function("inverse kinematics of the tool point, 17 starts", |b| {
        b.iter(|| {
            let (target, start) = &cases[k % CASES];
            k += 1;
            solve_position(&arm, black_box(target), black_box(start), &options).expect("solves")
        })
    });
}

criterion_group!(benches, solve);
criterion_main!(benches);
