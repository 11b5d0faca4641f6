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
