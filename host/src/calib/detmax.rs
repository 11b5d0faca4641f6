//! D-optimal pose selection with Mitchell's DETMAX exchange (Technometrics 1974).
//!
//! Each candidate pose contributes a block `A` (its rows of the column-scaled
//! Jacobian: 3 per load it is measured under), and a design of N poses has the
//! information matrix `M = Σ AᵀA`. DETMAX maximises `det M`, i.e. O1, by
//! *excursions*: add the k candidates that raise `det M` most, then drop the k
//! design poses whose loss is least (or drop first, then add), and keep the
//! result when the determinant rose; k grows from 1 to
//! [`DetmaxOptions::max_excursion`] when shorter excursions stop paying.
//!
//! No step refactors J. With `M⁻¹` at hand, the matrix determinant lemma gives
//! every candidate's gain as `det(I ± A M⁻¹ Aᵀ)` (an r×r determinant, r = 3 per
//! load), and the Woodbury identity updates `M⁻¹` by a rank-r correction after
//! each add or drop. `M⁻¹` is rebuilt from scratch only after an accepted
//! excursion, which bounds rounding drift. A tiny ridge (`1e-9 I`) keeps the
//! random start invertible; the reported determinant is recomputed without it.
//! Several seeded random starts run and the best design is kept.
//!
//! The result is a function of the blocks *in their order*: the starts are
//! drawn over candidate indices and a tie goes to the lowest index, the
//! same on every run. `pipeline` passes the candidates in a canonical order
//! (by joint angles, then pose id), so that the poses chosen do not depend on
//! the order of the rows of the file they came from.

use nalgebra::DMatrix;
use rand::seq::index::sample;
use rand::{SeedableRng, rngs::StdRng};

use super::CalibError;
use super::progress::Progress;

/// Settings of the exchange.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetmaxOptions {
    /// Poses to select.
    pub n: usize,
    /// Random starts; the best design is kept.
    pub starts: usize,
    /// Seed of the first start; start `s` uses `seed + s`.
    pub seed: u64,
    /// Longest excursion tried before giving up on a start.
    pub max_excursion: usize,
}

impl Default for DetmaxOptions {
    /// 50 poses (the paper's count), 8 starts, excursions up to 4.
    fn default() -> Self {
        Self {
            n: 50,
            starts: 8,
            seed: 1,
            max_excursion: 4,
        }
    }
}

/// A selected design.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    /// Indices of the chosen candidates, ascending.
    pub chosen: Vec<usize>,
    /// `ln det(Σ AᵀA)` of the chosen blocks (−∞ when singular).
    pub log_det: f64,
    /// Accepted excursions of the winning start.
    pub excursions: usize,
    /// `ln det` reached by every start, in order.
    pub start_log_dets: Vec<f64>,
}

const RIDGE: f64 = 1e-9;

/// `ln det` of the information matrix of `chosen`, without any ridge; −∞ when singular.
pub fn log_det(blocks: &[DMatrix<f64>], chosen: &[usize]) -> f64 {
    let Some(m) = blocks.first().map(|b| b.ncols()) else {
        return f64::NEG_INFINITY;
    };
    let mut info = DMatrix::zeros(m, m);
    for &c in chosen {
        info.gemm_tr(1.0, &blocks[c], &blocks[c], 1.0);
    }
    match info.cholesky() {
        Some(ch) => 2.0 * ch.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>(),
        None => f64::NEG_INFINITY,
    }
}

/// The exchange state of one design: membership, `M⁻¹` and `ln det M` (with ridge).
#[derive(Clone)]
struct State<'a> {
    blocks: &'a [DMatrix<f64>],
    /// All blocks stacked and transposed (`m × r·C`, so each candidate row is a
    /// contiguous column), for the one-product scan of additions.
    stacked_t: &'a DMatrix<f64>,
    member: Vec<bool>,
    minv: DMatrix<f64>,
    log_det: f64,
}

impl<'a> State<'a> {
    fn new(blocks: &'a [DMatrix<f64>], stacked_t: &'a DMatrix<f64>, chosen: &[usize]) -> Self {
        let mut member = vec![false; blocks.len()];
        for &c in chosen {
            member[c] = true;
        }
        let m = blocks[0].ncols();
        let mut s = Self {
            blocks,
            stacked_t,
            member,
            minv: DMatrix::zeros(m, m),
            log_det: 0.0,
        };
        s.refactor();
        s
    }

    /// Rebuilds `M⁻¹` and `ln det M` from the members.
    fn refactor(&mut self) {
        let m = self.blocks[0].ncols();
        let mut info = DMatrix::identity(m, m) * RIDGE;
        for (c, _) in self.member.iter().enumerate().filter(|(_, in_)| **in_) {
            info.gemm_tr(1.0, &self.blocks[c], &self.blocks[c], 1.0);
        }
        // The ridge makes `info` positive definite whatever the members.
        if let Some(ch) = info.cholesky() {
            self.log_det = 2.0 * ch.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>();
            self.minv = ch.inverse();
        }
    }

    /// `I + sign · A M⁻¹ Aᵀ` and `M⁻¹ Aᵀ` for candidate `c`.
    fn capacitance(&self, c: usize, sign: f64) -> (DMatrix<f64>, DMatrix<f64>) {
        let a = &self.blocks[c];
        let k = &self.minv * a.transpose();
        let r = a.nrows();
        let s = DMatrix::identity(r, r) + (a * &k) * sign;
        (s, k)
    }

    /// Change of `ln det M` if `c` were added (`sign` = 1) or removed (−1).
    fn gain(&self, c: usize, sign: f64) -> f64 {
        let (s, _) = self.capacitance(c, sign);
        let det = s.determinant();
        if det > 0.0 {
            det.ln()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// Adds (`sign` = 1) or removes (−1) candidate `c` with a Woodbury update.
    fn update(&mut self, c: usize, sign: f64) {
        let (s, k) = self.capacitance(c, sign);
        let det = s.determinant();
        match s.try_inverse() {
            Some(sinv) if det > 0.0 => {
                self.minv -= (&k * sinv * k.transpose()) * sign;
                self.log_det += det.ln();
                self.member[c] = sign > 0.0;
            }
            // Removing a pose the design cannot do without: refactor instead.
            _ => {
                self.member[c] = sign > 0.0;
                self.refactor();
            }
        }
    }

    /// The candidate whose addition raises (or whose removal lowers least) `ln det M`.
    fn best(&self, adding: bool) -> Option<usize> {
        if adding {
            return self.best_addition();
        }
        first_max(
            (0..self.blocks.len())
                .filter(|&c| self.member[c])
                .map(|c| (c, self.gain(c, -1.0))),
        )
    }

    /// The best addition, scanning every candidate with one product `M⁻¹ Aᵀ`
    /// over all stacked blocks (one GEMM instead of an allocation per
    /// candidate), then each r×r capacitance `I + A_c (M⁻¹ A_cᵀ)` from
    /// contiguous columns.
    fn best_addition(&self) -> Option<usize> {
        let r = self.blocks.first()?.nrows();
        let pt = &self.minv * self.stacked_t;
        first_max(
            (0..self.blocks.len())
                .filter(|&c| !self.member[c])
                .map(|c| {
                    let s = DMatrix::from_fn(r, r, |i, j| {
                        let dot = pt.column(r * c + i).dot(&self.stacked_t.column(r * c + j));
                        if i == j { 1.0 + dot } else { dot }
                    });
                    let det = s.determinant();
                    let gain = if det > 0.0 {
                        det.ln()
                    } else {
                        f64::NEG_INFINITY
                    };
                    (c, gain)
                }),
        )
    }

    /// One excursion of length `k`, up first (`up`) or down first.
    fn excursion(&self, k: usize, up: bool) -> State<'a> {
        let mut t = self.clone();
        for phase in [up, !up] {
            for _ in 0..k {
                if let Some(c) = t.best(phase) {
                    t.update(c, if phase { 1.0 } else { -1.0 });
                }
            }
        }
        t.refactor();
        t
    }

    fn chosen(&self) -> Vec<usize> {
        (0..self.member.len()).filter(|&c| self.member[c]).collect()
    }
}

/// The candidate of the largest gain, the first (lowest index) among equal ones.
fn first_max(gains: impl Iterator<Item = (usize, f64)>) -> Option<usize> {
    gains
        .fold(None, |best: Option<(usize, f64)>, (c, gain)| match best {
            Some((_, g)) if g >= gain => best,
            _ => Some((c, gain)),
        })
        .map(|(c, _)| c)
}

/// Selects `options.n` of the candidate `blocks` (each `r × m`, column-scaled)
/// maximising `det(Σ AᵀA)`; advances `progress` by one per start.
pub fn detmax(
    blocks: &[DMatrix<f64>],
    options: &DetmaxOptions,
    progress: &dyn Progress,
) -> Result<Design, CalibError> {
    let m = blocks.first().map(|b| b.ncols()).unwrap_or(0);
    let rows_per_pose = blocks.first().map(|b| b.nrows()).unwrap_or(0);
    if options.n > blocks.len() {
        return Err(CalibError::Empty {
            what: format!(
                "select {} poses from {} candidates: not enough candidates",
                options.n,
                blocks.len()
            ),
        });
    }
    if options.n * rows_per_pose < m || m == 0 {
        return Err(CalibError::TooFewPoses {
            poses: options.n,
            rows: options.n * rows_per_pose,
            params: m,
        });
    }
    let all: Vec<usize> = (0..blocks.len()).collect();
    let stacked_t = stack(blocks, &all).transpose();
    let mut best: Option<Design> = None;
    let mut start_log_dets = Vec::new();
    for s in 0..options.starts.max(1) {
        let mut rng = StdRng::seed_from_u64(options.seed.wrapping_add(s as u64));
        let start = sample(&mut rng, blocks.len(), options.n).into_vec();
        let mut state = State::new(blocks, &stacked_t, &start);
        let mut excursions = 0;
        'search: loop {
            for k in 1..=options.max_excursion {
                for up in [true, false] {
                    let t = state.excursion(k, up);
                    if t.log_det > state.log_det + 1e-10 {
                        state = t;
                        excursions += 1;
                        continue 'search;
                    }
                }
            }
            break;
        }
        let chosen = state.chosen();
        let ld = log_det(blocks, &chosen);
        start_log_dets.push(ld);
        if best.as_ref().is_none_or(|b| ld > b.log_det) {
            best = Some(Design {
                chosen,
                log_det: ld,
                excursions,
                start_log_dets: Vec::new(),
            });
        }
        progress.advance(1);
    }
    let mut best = best.ok_or_else(|| CalibError::Empty {
        what: "select poses".into(),
    })?;
    best.start_log_dets = start_log_dets;
    Ok(best)
}

/// `n` candidates drawn uniformly without replacement (the baseline DETMAX must beat).
pub fn random_design(candidates: usize, n: usize, seed: u64) -> Vec<usize> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut v = sample(&mut rng, candidates, n.min(candidates)).into_vec();
    v.sort_unstable();
    v
}

/// Splits a stacked `3·L·P × m` matrix into `P` blocks of `3·L` rows.
pub fn split_blocks(j: &DMatrix<f64>, rows_per_block: usize) -> Vec<DMatrix<f64>> {
    (0..j.nrows() / rows_per_block)
        .map(|b| j.rows(b * rows_per_block, rows_per_block).into_owned())
        .collect()
}

/// Stacks the chosen blocks into one matrix.
pub fn stack(blocks: &[DMatrix<f64>], chosen: &[usize]) -> DMatrix<f64> {
    let m = blocks.first().map(|b| b.ncols()).unwrap_or(0);
    let r = blocks.first().map(|b| b.nrows()).unwrap_or(0);
    let mut out = DMatrix::zeros(r * chosen.len(), m);
    for (i, &c) in chosen.iter().enumerate() {
        out.rows_mut(i * r, r).copy_from(&blocks[c]);
    }
    out
}

/// Random candidate blocks for the tests.
#[cfg(test)]
fn random_blocks(count: usize, m: usize, seed: u64) -> Vec<DMatrix<f64>> {
    use rand::Rng;
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count)
        .map(|_| DMatrix::from_fn(3, m, |_, _| rng.random_range(-1.0..1.0)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::progress::Silent;

    /// The Woodbury-updated state agrees with a state rebuilt from scratch.
    #[test]
    fn rank_three_updates_match_refactoring() {
        let blocks = random_blocks(40, 8, 3);
        let all: Vec<usize> = (0..blocks.len()).collect();
        let stacked_t = stack(&blocks, &all).transpose();
        let mut s = State::new(&blocks, &stacked_t, &[0, 1, 2, 3, 4]);
        s.update(10, 1.0);
        s.update(2, -1.0);
        s.update(20, 1.0);
        let mut fresh = s.clone();
        fresh.refactor();
        assert!((s.log_det - fresh.log_det).abs() < 1e-9);
        assert!((&s.minv - &fresh.minv).amax() < 1e-9 * fresh.minv.amax());
    }

    /// The one-product scan of additions picks what the per-candidate lemma picks.
    #[test]
    fn stacked_scan_agrees_with_the_determinant_lemma() {
        let blocks = random_blocks(60, 8, 4);
        let all: Vec<usize> = (0..blocks.len()).collect();
        let stacked_t = stack(&blocks, &all).transpose();
        let s = State::new(&blocks, &stacked_t, &[1, 5, 9, 13, 17]);
        let by_lemma = (0..blocks.len())
            .filter(|&c| !s.member[c])
            .max_by(|&a, &b| s.gain(a, 1.0).total_cmp(&s.gain(b, 1.0)));
        assert_eq!(s.best_addition(), by_lemma);
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
}
