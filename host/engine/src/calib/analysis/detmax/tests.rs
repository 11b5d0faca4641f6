//! Tests of `detmax`.

use super::*;
use crate::calib::progress::Silent;

/// `ln det` of the members plus the ridge, from scratch.
fn ridged_log_det(blocks: &[DMatrix<f64>], chosen: &[usize]) -> f64 {
    let m = blocks[0].ncols();
    let mut info = DMatrix::identity(m, m) * RIDGE;
    for &c in chosen {
        info.gemm_tr(1.0, &blocks[c], &blocks[c], 1.0);
    }
    let ch = info.cholesky().unwrap();
    2.0 * ch.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>()
}

/// After adds and drops, the updated `M⁻¹`, `ln det` and dispersions
/// agree with a state built from scratch on the same members, for
/// blocks of one load (3 rows), of two (6 rows) and of 4 rows.
#[test]
fn rank_r_updates_match_rebuilding() {
    for rows in [3, 4, 6] {
        let blocks = random_blocks_of(40, rows, 8, 3);
        let pool = Pool::new(&blocks);
        let mut s = State::new(&pool, &[0, 1, 2, 3, 4]);
        let mut t = s.trial();
        for (c, sign) in [(10, 1.0), (2, -1.0), (20, 1.0), (0, -1.0), (33, 1.0)] {
            t.update(c, sign);
        }
        let changes = t.changes;
        let updated = (changes.minv.clone(), changes.log_det);
        s.accept(changes);
        assert_eq!(s.chosen(), [1, 3, 4, 10, 20, 33]);
        let fresh = State::new(&pool, &s.chosen());
        assert!((updated.1 - fresh.log_det).abs() < 1e-9);
        assert!((&updated.0 - &fresh.minv).amax() < 1e-9 * fresh.minv.amax());
        let worst = s
            .dispersion
            .iter()
            .zip(&fresh.dispersion)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let size = fresh.dispersion.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            worst < 1e-10 * size,
            "{rows} rows: drift {worst:e} of {size:e}"
        );
    }
}

/// Every candidate's gain is the change of `ln det` its addition or
/// removal makes (the determinant lemma), and the best addition and
/// removal are the largest, from a state and from a trial with
/// corrections pending.
#[test]
fn gains_are_the_changes_of_ln_det() {
    let blocks = random_blocks(60, 8, 4);
    let pool = Pool::new(&blocks);
    let chosen = [1, 5, 9, 13, 17, 21];
    let s = State::new(&pool, &chosen);
    let base = ridged_log_det(&blocks, &chosen);
    let mut scratch = [0.0; 9];
    let gain = |design: &[usize], c: usize| {
        let with: Vec<usize> = if design.contains(&c) {
            design.iter().copied().filter(|&x| x != c).collect()
        } else {
            design.iter().copied().chain([c]).collect()
        };
        ridged_log_det(&blocks, &with) - ridged_log_det(&blocks, design)
    };
    for c in 0..blocks.len() {
        let sign = if s.member[c] { -1.0 } else { 1.0 };
        let det = det_shifted(&s.dispersion[9 * c..9 * c + 9], sign, 3, &mut scratch);
        let expected = gain(&chosen, c);
        assert!((det.unwrap().ln() - expected).abs() < 1e-9, "candidate {c}");
    }
    assert!(base.is_finite());
    let best = |design: &[usize], adding: bool| {
        (0..blocks.len())
            .filter(|c| design.contains(c) != adding)
            .max_by(|&a, &b| gain(design, a).total_cmp(&gain(design, b)))
    };
    let mut t = s.trial();
    assert_eq!(t.best(true), best(&chosen, true));
    assert_eq!(t.best(false), best(&chosen, false));
    t.update(30, 1.0);
    t.update(5, -1.0);
    let moved = [1, 9, 13, 17, 21, 30];
    assert_eq!(t.best(true), best(&moved, true));
    assert_eq!(t.best(false), best(&moved, false));
}

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

/// After additions only, the bounded search for the best addition picks
/// what a pass over every candidate picks, ties to the lowest index
/// included (each candidate doubled, so every gain has a twin), on many
/// random pools and designs.
#[test]
fn the_bounded_search_picks_what_the_full_pass_picks() {
    let mut searches = 0;
    for seed in 0..30 {
        let once = random_blocks(150, 12, seed);
        let blocks: Vec<DMatrix<f64>> = once.iter().chain(&once).cloned().collect();
        let pool = Pool::new(&blocks);
        let start = random_design(150, 6, seed);
        let s = State::new(&pool, &start);
        let full = |t: &Trial| {
            let c = &t.changes;
            let products = c.corrections.products(&pool).unwrap();
            let (mut g, mut scratch) = ([0.0; 9], [0.0; 9]);
            first_max((0..pool.len()).filter(|&i| !c.member[i]).map(|i| {
                c.corrections
                    .correct(&s.dispersion[9 * i..9 * i + 9], &products, i, 3, &mut g);
                (i, det_shifted(&g, 1.0, 3, &mut scratch).unwrap())
            }))
        };
        let mut t = s.trial();
        for _ in 0..5 {
            let next = t.best(true).unwrap();
            if !t.changes.corrections.is_empty() {
                assert_eq!(Some(next), full(&t), "seed {seed}");
                let twin_taken = next >= 150 && t.changes.member[next - 150];
                assert!(
                    next < 150 || twin_taken,
                    "the lower of two equal candidates"
                );
                searches += 1;
            }
            t.update(next, 1.0);
        }
    }
    assert_eq!(searches, 30 * 4);
}
