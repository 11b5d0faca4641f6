//! Tests of `detmax`.

use super::*;
use crate::calib::progress::Silent;

/// The design does not depend on how many threads run the starts.
#[test]
fn threads_do_not_change_the_design() {
    let blocks = random_blocks(150, 10, 6);
    let opts = DetmaxOptions {
        n: 15,
        starts: 5,
        ..Default::default()
    };
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| detmax(&blocks, &opts, &Silent).unwrap())
    };
    let one = on(1);
    assert_eq!(one, on(3));
    assert_eq!(one.start_log_dets.len(), 5);
}

/// On a small problem, DETMAX finds the exhaustive optimum.
#[test]
fn finds_the_exhaustive_optimum_of_a_small_problem() {
    let blocks = random_blocks(12, 4, 5);
    let opts = DetmaxOptions {
        n: 3,
        starts: 4,
        seed: 9,
        max_excursion: 2,
    };
    let d = detmax(&blocks, &opts, &Silent).unwrap();
    let mut best = f64::NEG_INFINITY;
    for a in 0..12 {
        for b in a + 1..12 {
            for c in b + 1..12 {
                best = best.max(log_det(&blocks, &[a, b, c]));
            }
        }
    }
    assert!(
        (d.log_det - best).abs() < 1e-9,
        "detmax {} vs exhaustive {best}",
        d.log_det
    );
}

#[test]
fn beats_random_designs() {
    let blocks = random_blocks(200, 10, 8);
    let opts = DetmaxOptions {
        n: 20,
        ..Default::default()
    };
    let d = detmax(&blocks, &opts, &Silent).unwrap();
    for seed in 0..20 {
        assert!(d.log_det > log_det(&blocks, &random_design(200, 20, seed)));
    }
}

#[test]
fn refuses_too_few_poses() {
    let blocks = random_blocks(30, 10, 1);
    let opts = DetmaxOptions {
        n: 3,
        ..Default::default()
    };
    assert!(matches!(
        detmax(&blocks, &opts, &Silent),
        Err(CalibError::TooFewPoses { params: 10, .. })
    ));
}

/// Tall blocks that move with few coordinates (a camera's 48 corners with
/// the board's six) select as their information does: blocks `Q A` with
/// `QᵀQ = I` give the design and the determinant of the blocks `A`.
#[test]
fn tall_blocks_select_as_their_information_does() {
    let small = random_blocks_of(80, 6, 10, 4);
    let turns = random_blocks_of(80, 40, 6, 5);
    let tall: Vec<DMatrix<f64>> = small
        .iter()
        .zip(&turns)
        .map(|(a, t)| t.clone().qr().q() * a)
        .collect();
    assert_eq!(tall[0].shape(), (40, 10));
    let opts = DetmaxOptions {
        n: 12,
        starts: 3,
        ..Default::default()
    };
    let of_small = detmax(&small, &opts, &Silent).unwrap();
    let of_tall = detmax(&tall, &opts, &Silent).unwrap();
    assert_eq!(of_tall.chosen, of_small.chosen);
    assert!((of_tall.log_det - of_small.log_det).abs() < 1e-9);
}
