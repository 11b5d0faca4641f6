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
//! No step refactors J, and no step multiplies by `M⁻¹` over every
//! candidate. The state keeps, for every candidate `c`, its *dispersion*
//! `G_c = A M⁻¹ Aᵀ` (r×r, r = 3 per load): by the matrix determinant lemma
//! its gain is `det(I + G_c)` to add it and `det(I − G_c)` to drop it, an
//! r×r determinant each. Adding or dropping a pose `u` changes `M⁻¹` by the
//! rank-r Woodbury correction `∓ K̃ K̃ᵀ` (`K̃ = M⁻¹ A_uᵀ L⁻ᵀ`, `L Lᵀ = S =
//! I ± A_u M⁻¹ A_uᵀ`), so every dispersion changes by `∓ (A_c K̃)(A_c K̃)ᵀ`.
//! An excursion only collects its corrections: the design's own ~N poses
//! are corrected one by one, and a scan for the best addition reads every
//! candidate once with all of them applied (one product of the stacked
//! candidates with the corrections' columns, 3·m multiplications per
//! candidate and correction, where `A M⁻¹ Aᵀ` from scratch takes 3·m² + 9·m).
//! Most excursions are rejected and then cost no pass at all; an accepted
//! one writes its corrections into the dispersions in one pass. `M⁻¹` and
//! `ln det M` are rebuilt from the members after every excursion, so
//! whether an excursion is kept is decided on exact figures; the
//! dispersions are rebuilt from scratch after [`REBUILD_AFTER`] corrections,
//! which bounds their rounding drift. A tiny ridge (`1e-9 I`) keeps the
//! random start invertible; the reported determinant is recomputed without it.
//!
//! Several seeded random starts run, on every core, and the best design is
//! kept (the first among equals). The result is a function of the blocks
//! *in their order*: the starts are drawn over candidate indices, a tie
//! goes to the lowest index, and no start depends on another or on the
//! thread it runs on. `pipeline` passes the candidates in a canonical order
//! (by joint angles, then pose id), so that the poses chosen do not depend
//! on the order of the rows of the file they came from.
//!
//! This file holds the options, the result and the runs of the starts; the
//! candidate blocks (`pool`), the criterion and the gains (`criterion`), one
//! start's exchange (`exchange`) and the corrections it collects
//! (`corrections`) have files of their own.

use nalgebra::DMatrix;
use rand::seq::index::sample;
use rand::{SeedableRng, rngs::StdRng};

use crate::calib::CalibError;
use crate::calib::progress::{Progress, par_map};

mod corrections;
mod criterion;
mod exchange;
mod pool;

pub use criterion::log_det;
pub use exchange::REBUILD_AFTER;
use exchange::run_start;
use pool::Pool;
pub use pool::{split_blocks, stack};

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
    let compressed = pool::compressed(blocks);
    let pool = Pool::new(compressed.as_deref().unwrap_or(blocks));
    // The starts run on every core; each reports as it ends.
    let starts: Vec<usize> = (0..options.starts.max(1)).collect();
    let runs = par_map(&starts, |&s| run_start(&pool, options, s), progress).ok_or_else(|| {
        CalibError::Empty {
            what: "select poses: a DETMAX start failed".into(),
        }
    })?;
    let mut best: Option<Design> = None;
    let mut start_log_dets = Vec::with_capacity(runs.len());
    for (chosen, excursions) in runs {
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

/// Random candidate blocks of 3 rows for the tests.
#[cfg(test)]
fn random_blocks(count: usize, m: usize, seed: u64) -> Vec<DMatrix<f64>> {
    random_blocks_of(count, 3, m, seed)
}

/// Random candidate blocks of `rows` rows for the tests.
#[cfg(test)]
fn random_blocks_of(count: usize, rows: usize, m: usize, seed: u64) -> Vec<DMatrix<f64>> {
    use rand::Rng;
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count)
        .map(|_| DMatrix::from_fn(rows, m, |_, _| rng.random_range(-1.0..1.0)))
        .collect()
}

#[cfg(test)]
mod tests;
