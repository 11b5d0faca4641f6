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

use nalgebra::DMatrix;
use rand::seq::index::sample;
use rand::{SeedableRng, rngs::StdRng};

use crate::calib::CalibError;
use crate::calib::progress::{Progress, par_map};

mod corrections;
use corrections::Corrections;

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

/// The candidates as the exchange reads them: the blocks, and all of them
/// stacked (`r·C × m`, column-major) and transposed (`m × r·C`: a
/// candidate's rows are `r·m` contiguous numbers), for the passes over
/// every candidate.
struct Pool<'a> {
    blocks: &'a [DMatrix<f64>],
    /// Rows per block.
    r: usize,
    stacked: DMatrix<f64>,
    stacked_t: DMatrix<f64>,
}

impl<'a> Pool<'a> {
    fn new(blocks: &'a [DMatrix<f64>]) -> Self {
        let all: Vec<usize> = (0..blocks.len()).collect();
        let stacked = stack(blocks, &all);
        Self {
            blocks,
            r: blocks.first().map_or(0, |b| b.nrows()),
            stacked_t: stacked.transpose(),
            stacked,
        }
    }

    fn len(&self) -> usize {
        self.blocks.len()
    }

    fn m(&self) -> usize {
        self.stacked_t.nrows()
    }

    /// Candidate `c`'s rows, one after the other.
    fn rows(&self, c: usize) -> &[f64] {
        let n = self.r * self.m();
        &self.stacked_t.as_slice()[n * c..n * (c + 1)]
    }
}

/// `det(I + sign · G)` of an r×r matrix `g` (column-major) that is
/// symmetric, by Cholesky in `scratch`; `None` when `I + sign · G` is not
/// positive definite (a pose the design cannot do without, to drop).
fn det_shifted(g: &[f64], sign: f64, r: usize, scratch: &mut [f64]) -> Option<f64> {
    if r == 3 && sign > 0.0 {
        // I + G with G positive semidefinite is positive definite: the
        // determinant written out (one load, the common case) says it all.
        let a = |i: usize, j: usize| g[i + 3 * j] + if i == j { 1.0 } else { 0.0 };
        let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
            - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
            + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
        return (det > 0.0 && det.is_finite()).then_some(det);
    }
    for (i, (s, v)) in scratch.iter_mut().zip(g).enumerate() {
        *s = sign * v + if i % (r + 1) == 0 { 1.0 } else { 0.0 };
    }
    let mut det = 1.0;
    for j in 0..r {
        let mut d = scratch[j + j * r];
        for k in 0..j {
            d -= scratch[j + k * r] * scratch[j + k * r];
        }
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let l = d.sqrt();
        det *= d;
        scratch[j + j * r] = l;
        for i in j + 1..r {
            let mut v = scratch[i + j * r];
            for k in 0..j {
                v -= scratch[i + k * r] * scratch[j + k * r];
            }
            scratch[i + j * r] = v / l;
        }
    }
    Some(det)
}

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

/// Rebuilds `minv` from the `member` blocks and returns `ln det M`.
fn refactor(pool: &Pool, member: &[bool], minv: &mut DMatrix<f64>) -> f64 {
    let m = minv.nrows();
    let mut info = DMatrix::identity(m, m) * RIDGE;
    for (c, _) in member.iter().enumerate().filter(|(_, in_)| **in_) {
        let b = &pool.blocks[c];
        info.gemm_tr(1.0, b, b, 1.0);
    }
    // The ridge makes `info` positive definite whatever the members.
    match info.cholesky() {
        Some(ch) => {
            *minv = ch.inverse();
            2.0 * ch.l_dirty().diagonal().iter().map(|d| d.ln()).sum::<f64>()
        }
        None => f64::NEG_INFINITY,
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

/// The candidate of the largest gain, the first (lowest index) among equal ones.
fn first_max(gains: impl Iterator<Item = (usize, f64)>) -> Option<usize> {
    gains
        .fold(None, |best: Option<(usize, f64)>, (c, gain)| match best {
            Some((_, g)) if g >= gain => best,
            _ => Some((c, gain)),
        })
        .map(|(c, _)| c)
}

/// One start of the exchange, from the random design its seed draws:
/// the chosen candidates and the accepted excursions.
fn run_start(pool: &Pool, options: &DetmaxOptions, start: usize) -> (Vec<usize>, usize) {
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
    let pool = Pool::new(blocks);
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
