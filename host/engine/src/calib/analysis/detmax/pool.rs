//! The candidate blocks: split from the stacked Jacobian, stacked back, and
//! the pool the exchange reads them from.

use nalgebra::DMatrix;

/// The candidates as the exchange reads them: the blocks, and all of them
/// stacked (`r·C × m`, column-major) and transposed (`m × r·C`: a
/// candidate's rows are `r·m` contiguous numbers), for the passes over
/// every candidate.
pub(super) struct Pool<'a> {
    pub(super) blocks: &'a [DMatrix<f64>],
    /// Rows per block.
    pub(super) r: usize,
    pub(super) stacked: DMatrix<f64>,
    pub(super) stacked_t: DMatrix<f64>,
}

impl<'a> Pool<'a> {
    pub(super) fn new(blocks: &'a [DMatrix<f64>]) -> Self {
        let all: Vec<usize> = (0..blocks.len()).collect();
        let stacked = stack(blocks, &all);
        Self {
            blocks,
            r: blocks.first().map_or(0, |b| b.nrows()),
            stacked_t: stacked.transpose(),
            stacked,
        }
    }

    pub(super) fn len(&self) -> usize {
        self.blocks.len()
    }

    pub(super) fn m(&self) -> usize {
        self.stacked_t.nrows()
    }

    /// Candidate `c`'s rows, one after the other.
    pub(super) fn rows(&self, c: usize) -> &[f64] {
        let n = self.r * self.m();
        &self.stacked_t.as_slice()[n * c..n * (c + 1)]
    }
}

/// Singular values of a block below this fraction of its largest carry
/// nothing the exchange can tell from rounding.
const RANK_TOLERANCE: f64 = 1e-10;

/// The blocks with as few rows as carry their information: `B` with
/// `BᵀB = AᵀA` (so every determinant of the exchange is the same), `Σ Vᵀ`
/// of `A`'s singular value decomposition, its negligible rows dropped and
/// every block padded with zero rows to the largest rank. A camera's view
/// of 48 corners is 144 rows that move with the board's six coordinates
/// alone: six rows do, and the exchange's work grows with the square of
/// the rows. `None` when no block would lose a row.
pub(super) fn compressed(blocks: &[DMatrix<f64>]) -> Option<Vec<DMatrix<f64>>> {
    use rayon::prelude::*;
    let (r, m) = blocks.first().map(|b| b.shape())?;
    if r <= 6 {
        return None;
    }
    let reduced: Vec<DMatrix<f64>> = blocks
        .par_iter()
        .map(|block| {
            let svd = block.clone().svd(false, true);
            let v_t = svd.v_t.expect("asked for");
            let largest = svd.singular_values.max();
            let kept: Vec<usize> = (0..svd.singular_values.len())
                .filter(|&i| svd.singular_values[i] > RANK_TOLERANCE * largest)
                .collect();
            DMatrix::from_fn(kept.len(), m, |row, col| {
                svd.singular_values[kept[row]] * v_t[(kept[row], col)]
            })
        })
        .collect();
    let rank = reduced.iter().map(|b| b.nrows()).max().unwrap_or(0).max(1);
    (rank < r).then(|| {
        reduced
            .into_iter()
            .map(|b| b.resize_vertically(rank, 0.0))
            .collect()
    })
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
