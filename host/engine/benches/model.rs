//! Cost of the model calls the tools and the firmware make most: one forward
//! evaluation with elastic deflection (f64, host), and one compensation solve
//! in f64 and f32, on the bundled arm.
//!
//! Run: `cargo bench -p lrmcal-engine --bench model`.

#![allow(
    missing_docs,
    reason = "the criterion macros generate an undocumented public function"
)]

use model::testing::TEST_ARM_JOINTS as JOINTS;
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use model::{Arm, CompensationOptions, SolverOptions};

/// A pose away from singularities, with every joint loaded.
const Q: [f64; JOINTS] = [0.3, 0.9, -0.6, 0.4, -0.8, 0.2];
/// The paper's payload, kg.
const LOAD_KG: f64 = 0.0663;

/// The bundled arm with the compliances a calibration typically finds, so the
/// deflection solve iterates as it does on a real arm (the nominal arm is rigid).
fn bench_arm() -> Arm<f64> {
    let mut arm = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("the bundled arm parses")
        .arm;
    for joint in &mut arm.joints {
        joint.compliance = 0.05;
    }
    arm.base_compliance = 0.02;
    arm
}

fn forward(c: &mut Criterion) {
    let chain = bench_arm().chain();
    let opts = SolverOptions::default();
    c.bench_function("forward with deflection (f64)", |b| {
        b.iter(|| {
            chain
                .tool_point(black_box(&Q), black_box(LOAD_KG), &opts)
                .expect("converges")
        })
    });
    c.bench_function("rigid forward kinematics (f64)", |b| {
        b.iter(|| chain.rigid_tool_point(black_box(&Q)))
    });
}

fn compensation(c: &mut Criterion) {
    let nominal = bench_arm();
    let mut calibrated = nominal;
    calibrated.joints[1].a += 0.002;
    calibrated.joints[2].theta += 0.01;

    let (nominal64, calibrated64) = (nominal.chain(), calibrated.chain());
    let opts64 = CompensationOptions::default();
    let target64 = nominal64
        .tool_point(&Q, LOAD_KG, &SolverOptions::default())
        .expect("converges");
    // Time only solves that reach the target, not early give-ups.
    let check = calibrated64
        .compensate(&Q, &target64, LOAD_KG, None, &opts64)
        .expect("solves");
    assert!(check.converged, "f64 compensation did not converge");
    c.bench_function("compensation, cold start (f64)", |b| {
        b.iter(|| {
            calibrated64
                .compensate(black_box(&Q), &target64, LOAD_KG, None, &opts64)
                .expect("solves")
        })
    });

    let (nominal32, calibrated32) = (
        nominal.map(|x| x as f32).chain(),
        calibrated.map(|x| x as f32).chain(),
    );
    let q32 = Q.map(|x| x as f32);
    let load32 = LOAD_KG as f32;
    let opts32 = CompensationOptions::default();
    let target32 = nominal32
        .tool_point(&q32, load32, &SolverOptions::default())
        .expect("converges");
    c.bench_function("compensation, cold start (f32)", |b| {
        b.iter(|| {
            calibrated32
                .compensate(black_box(&q32), &target32, load32, None, &opts32)
                .expect("solves")
        })
    });
    // The firmware starts each servo frame from the previous frame's solution:
    // here the solution for a command 0.3 deg away on every joint.
    let q_previous = q32.map(|x| x - 0.005);
    let target_previous = nominal32
        .tool_point(&q_previous, load32, &SolverOptions::default())
        .expect("converges");
    let warm = calibrated32
        .compensate(&q_previous, &target_previous, load32, None, &opts32)
        .expect("solves");
    let check = calibrated32
        .compensate(&q32, &target32, load32, Some(&warm), &opts32)
        .expect("solves");
    assert!(check.converged, "f32 warm compensation did not converge");
    c.bench_function("compensation, warm start (f32)", |b| {
        b.iter(|| {
            calibrated32
                .compensate(black_box(&q32), &target32, load32, Some(&warm), &opts32)
                .expect("solves")
        })
    });
}

criterion_group!(benches, forward, compensation);
criterion_main!(benches);
