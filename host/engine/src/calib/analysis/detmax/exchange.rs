//! One start of the exchange: the state of a design (its members, `M⁻¹`,
//! every candidate's dispersion), the excursions tried from it by rank-r
//! updates, and the search for the best addition or removal.

use nalgebra::DMatrix;
use rand::seq::index::sample;
use rand::{SeedableRng, rngs::StdRng};

use super::corrections::Corrections;
use super::criterion::{det_shifted, first_max, refactor};
use super::{DetmaxOptions, Pool};

/// Rank-r updates of the dispersions between two rebuilds from scratch. Each
/// adds rounding of about `eps · |G|`; a few dozen leave the gains good to
/// 1e-13, far finer than the differences between candidates.
pub const REBUILD_AFTER: usize = 64;

/// Candidates of the highest earlier gains corrected first, to set the
/// floor of a bounded search for the best addition.
const BOUND_PROBES: usize = 16;

/// Relative margin on the earlier gains of that search: far above the
/// rounding of a 3×3 determinant, far below the gaps between candidates.
const BOUND_MARGIN: f64 = 1e-9;

/// The exchange state of one design: membership, `M⁻¹`, `ln det M` (with
/// ridge), every candidate's dispersion and the best addition.
#[derive(Clone)]
struct State<'a> {
    pool: &'a Pool<'a>,
    member: Vec<bool>,
    minv: DMatrix<f64>,
    log_det: f64,
    /// `A_c M⁻¹ A_cᵀ` of candidate `c` at `r²·c..`, column-major.
    dispersion: Vec<f64>,
    /// Corrections written into the dispersions since they were last rebuilt.
    corrections: usize,
    /// The candidate whose addition raises `ln det M` most.
    best_addition: Option<usize>,
    /// `det(I + G_c)` of every candidate outside the design, from the
    /// dispersions as they stand (−∞ for the members).
    addition_gains: Vec<f64>,
}

impl<'a> State<'a> {
    fn new(pool: &'a Pool<'a>, chosen: &[usize]) -> Self {
        let mut member = vec![false; pool.len()];
        for &c in chosen {
            member[c] = true;
        }
        let m = pool.m();
        let mut s = Self {
            pool,
            member,
            minv: DMatrix::zeros(m, m),
            log_det: 0.0,
            dispersion: Vec::new(),
            corrections: 0,
            best_addition: None,
            addition_gains: Vec::new(),
        };
        s.log_det = refactor(pool, &s.member, &mut s.minv);
        s.dispersion = dispersion(pool, &s.minv);
        s.write(&Corrections::default());
        s
    }

    fn chosen(&self) -> Vec<usize> {
        (0..self.member.len()).filter(|&c| self.member[c]).collect()
    }

    /// An excursion from this state that has not moved yet.
    fn trial(&self) -> Trial<'_, 'a> {
        Trial {
            state: self,
            changes: Changes {
                member: self.member.clone(),
                minv: self.minv.clone(),
                log_det: self.log_det,
                own: None,
                corrections: Corrections::default(),
            },
        }
    }

    /// One excursion of length `k`, up first (`up`) or down first: what
    /// it changes, `M⁻¹` and `ln det` rebuilt from its members.
    fn excursion(&self, k: usize, up: bool) -> Changes {
        let mut t = self.trial();
        for phase in [up, !up] {
            for _ in 0..k {
                if let Some(c) = t.best(phase) {
                    t.update(c, if phase { 1.0 } else { -1.0 });
                }
            }
        }
        let mut changes = t.changes;
        changes.log_det = refactor(self.pool, &changes.member, &mut changes.minv);
        changes
    }

    /// Makes the outcome of an excursion from this state the state: its
    /// corrections written into the dispersions, or the dispersions
    /// rebuilt from scratch when enough have piled up.
    fn accept(&mut self, changes: Changes) {
        let Changes {
            member,
            minv,
            log_det,
            own,
            corrections,
        } = changes;
        self.member = member;
        self.minv = minv;
        self.log_det = log_det;
        if let Some(own) = own {
            self.dispersion = own;
            self.corrections = 0;
        }
        self.corrections += corrections.len() / self.pool.r.max(1);
        if self.corrections >= REBUILD_AFTER {
            self.dispersion = dispersion(self.pool, &self.minv);
            self.corrections = 0;
            self.write(&Corrections::default());
        } else {
            self.write(&corrections);
        }
    }

    /// One pass over every candidate: `corrections` written into its
    /// dispersion, and the best addition found on the way.
    fn write(&mut self, corrections: &Corrections) {
        let (pool, r) = (self.pool, self.pool.r);
        let products = corrections.products(pool);
        let mut out = vec![0.0; r * r];
        let mut scratch = vec![0.0; r * r];
        let mut dets = Vec::with_capacity(pool.len());
        for (c, g) in self.dispersion.chunks_exact_mut(r * r).enumerate() {
            if let Some(p) = &products {
                corrections.correct(g, p, c, r, &mut out);
                g.copy_from_slice(&out);
            }
            if !self.member[c] {
                dets.push((c, det_shifted(g, 1.0, r, &mut scratch)));
            }
        }
        self.addition_gains = vec![f64::NEG_INFINITY; pool.len()];
        for (c, d) in dets {
            self.addition_gains[c] = d.unwrap_or(f64::NEG_INFINITY);
        }
        self.best_addition = first_max(self.addition_gains.iter().copied().enumerate());
    }
}

/// Every candidate's dispersion `A_c M⁻¹ A_cᵀ`, from scratch.
fn dispersion(pool: &Pool, minv: &DMatrix<f64>) -> Vec<f64> {
    let r = pool.r;
    let pt = minv * &pool.stacked_t;
    let at = &pool.stacked_t;
    let mut out = vec![0.0; r * r * pool.len()];
    for (c, g) in out.chunks_exact_mut(r * r).enumerate() {
        for j in 0..r {
            for i in 0..r {
                g[i + j * r] = pt.column(r * c + i).dot(&at.column(r * c + j));
            }
        }
    }
    out
}

/// What an excursion changes: its design and `M⁻¹`, and the corrections
/// its steps made to the dispersions of the state it started from.
struct Changes {
    member: Vec<bool>,
    minv: DMatrix<f64>,
    log_det: f64,
    /// Dispersions rebuilt from scratch after a step that could not be a
    /// correction, in place of the state's.
    own: Option<Vec<f64>>,
    corrections: Corrections,
}

/// An excursion under way from `state`.
struct Trial<'s, 'a> {
    state: &'s State<'a>,
    changes: Changes,
}

impl Trial<'_, '_> {
    /// The candidate whose addition raises (or whose removal lowers least)
    /// `ln det M` most, the first (lowest index) among equals.
    fn best(&self, adding: bool) -> Option<usize> {
        let c = &self.changes;
        if adding && c.corrections.is_empty() && c.own.is_none() {
            return self.state.best_addition;
        }
        if adding && c.own.is_none() && c.corrections.only_additions() {
            return self.best_bounded_addition();
        }
        let pool = self.state.pool;
        let r = pool.r;
        let base = c.own.as_deref().unwrap_or(&self.state.dispersion);
        let sign = if adding { 1.0 } else { -1.0 };
        let (mut p, mut g, mut scratch) = (Vec::new(), vec![0.0; r * r], vec![0.0; r * r]);
        // Additions scan every candidate: one product for all; removals
        // scan the design's few poses, each its own.
        let products = if adding {
            c.corrections.products(pool)
        } else {
            None
        };
        // det(I ± G_c) is monotonic in the gain ln det(I ± G_c).
        first_max((0..pool.len()).filter(|&i| c.member[i] != adding).map(|i| {
            let gi = &base[r * r * i..r * r * (i + 1)];
            match &products {
                Some(all) => c.corrections.correct(gi, all, i, r, &mut g),
                None => c.corrections.apply(gi, pool.rows(i), r, &mut p, &mut g),
            }
            let det = det_shifted(&g, sign, r, &mut scratch);
            (i, det.unwrap_or(f64::NEG_INFINITY))
        }))
    }

    /// [`Trial::best`] addition after additions only: no candidate's gain
    /// can exceed its gain before them, so the candidates whose earlier
    /// gain lies below the best of the [`BOUND_PROBES`] earlier leaders,
    /// as corrected now, cannot win, and only the rest are corrected; the
    /// same numbers as a pass over all, so the same choice.
    fn best_bounded_addition(&self) -> Option<usize> {
        let (c, pool) = (&self.changes, self.state.pool);
        let r = pool.r;
        let earlier = &self.state.addition_gains;
        let outside = |i: &usize| !c.member[*i];
        let gains_of = |some: &[usize]| -> Vec<(usize, f64)> {
            let products = c.corrections.products_of(pool, some);
            let (mut g, mut scratch) = (vec![0.0; r * r], vec![0.0; r * r]);
            let base = &self.state.dispersion;
            some.iter()
                .enumerate()
                .map(|(s, &i)| {
                    c.corrections.correct(
                        &base[r * r * i..r * r * (i + 1)],
                        &products,
                        s,
                        r,
                        &mut g,
                    );
                    let det = det_shifted(&g, 1.0, r, &mut scratch);
                    (i, det.unwrap_or(f64::NEG_INFINITY))
                })
                .collect()
        };
        let mut leaders: Vec<usize> = (0..pool.len()).filter(outside).collect();
        if leaders.len() > BOUND_PROBES {
            leaders
                .select_nth_unstable_by(BOUND_PROBES, |a, b| earlier[*b].total_cmp(&earlier[*a]));
            leaders.truncate(BOUND_PROBES);
        }
        let floor = gains_of(&leaders)
            .into_iter()
            .map(|(_, g)| g)
            .fold(f64::NEG_INFINITY, f64::max);
        // Rounding may lift a corrected gain a few ulps above its earlier
        // one; the margin keeps every candidate that could tie.
        let contenders: Vec<usize> = (0..pool.len())
            .filter(outside)
            .filter(|&i| earlier[i] * (1.0 + BOUND_MARGIN) >= floor)
            .collect();
        first_max(gains_of(&contenders).into_iter())
    }

    /// Adds (`sign` = 1) or removes (−1) candidate `c`: a Woodbury update
    /// of `M⁻¹` and one more correction of the dispersions.
    fn update(&mut self, c: usize, sign: f64) {
        let pool = self.state.pool;
        let ch = &mut self.changes;
        let a = &pool.blocks[c];
        let k = &ch.minv * a.transpose();
        let r = a.nrows();
        let s = DMatrix::identity(r, r) + (a * &k) * sign;
        ch.member[c] = sign > 0.0;
        // K̃ = K L⁻ᵀ, so that K S⁻¹ Kᵀ = K̃ K̃ᵀ.
        let factor = s.cholesky().and_then(|l| {
            let kt = l.l().solve_lower_triangular(&k.transpose())?.transpose();
            Some((l, kt))
        });
        let Some((l, kt)) = factor else {
            // Removing a pose the design cannot do without: start afresh.
            ch.log_det = refactor(pool, &ch.member, &mut ch.minv);
            ch.own = Some(dispersion(pool, &ch.minv));
            ch.corrections = Corrections::default();
            return;
        };
        ch.minv -= (&kt * kt.transpose()) * sign;
        ch.log_det += 2.0 * l.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        ch.corrections.push(&kt, sign);
    }
}

/// One start of the exchange, from the random design its seed draws:
/// the chosen candidates and the accepted excursions.
pub(super) fn run_start(pool: &Pool, options: &DetmaxOptions, start: usize) -> (Vec<usize>, usize) {
    let mut rng = StdRng::seed_from_u64(options.seed.wrapping_add(start as u64));
    let first = sample(&mut rng, pool.len(), options.n).into_vec();
    let mut state = State::new(pool, &first);
    let mut excursions = 0;
    'search: loop {
        for k in 1..=options.max_excursion {
            for up in [true, false] {
                let changes = state.excursion(k, up);
                if changes.log_det > state.log_det + 1e-10 {
                    state.accept(changes);
                    excursions += 1;
                    continue 'search;
                }
            }
        }
        break;
    }
    (state.chosen(), excursions)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::analysis::detmax::criterion::RIDGE;
    use crate::calib::analysis::detmax::{random_blocks, random_blocks_of, random_design};

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
}
