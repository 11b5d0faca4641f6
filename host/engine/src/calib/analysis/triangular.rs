//! A tall matrix brought down to its triangular factor: `A = Q R` with
//! orthonormal `Q` keeps every inner product of `A`'s columns in `R`'s
//! (`AᵀA = RᵀR`), so the rank, the singular values, the right singular
//! vectors and every least-squares fit between columns can be read on `R`,
//! `n × n`, instead of on the `rows × n` Jacobian of thousands of poses.
//!
//! `R` is built by blocks of rows, each block's factor on one of rayon's
//! threads, then the stacked factors factored once more (a tall-skinny QR).
//! The blocks are fixed by the row count alone, so the result does not
//! depend on the number of threads.

use nalgebra::DMatrix;
use rayon::prelude::*;

/// Rows per block: enough above any parameter count that a block's factor
/// is a small fraction of the block, few enough to give every core work.
const BLOCK_ROWS: usize = 2048;

/// A matrix of at most `a.ncols()` rows whose columns have the same inner
/// products as `a`'s; `a` itself when it has no more rows than that.
pub fn triangular_factor(a: &DMatrix<f64>) -> DMatrix<f64> {
    let (rows, cols) = a.shape();
    if rows <= cols {
        return a.clone();
    }
    if rows <= BLOCK_ROWS {
        return a.clone().qr().r();
    }
    let starts: Vec<usize> = (0..rows).step_by(BLOCK_ROWS).collect();
    let factors: Vec<DMatrix<f64>> = starts
        .par_iter()
        .map(|&start| {
            let n = BLOCK_ROWS.min(rows - start);
            a.rows(start, n).into_owned().qr().r()
        })
        .collect();
    let stacked_rows = factors.iter().map(|f| f.nrows()).sum();
    let mut stacked = DMatrix::zeros(stacked_rows, cols);
    let mut row = 0;
    for f in &factors {
        stacked.rows_mut(row, f.nrows()).copy_from(f);
        row += f.nrows();
    }
    triangular_factor(&stacked)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tall(rows: usize, cols: usize) -> DMatrix<f64> {
        // Deterministic, full rank, with one column a combination of two others.
        let mut a = DMatrix::from_fn(rows, cols, |i, j| {
            ((i * 7 + j * 13) as f64 * 0.37).sin() + if i % cols == j { 0.5 } else { 0.0 }
        });
        let combo = a.column(0) * 2.0 - a.column(1) * 0.5;
        a.set_column(cols - 1, &combo);
        a
    }

    #[test]
    fn keeps_the_inner_products_of_the_columns() {
        for rows in [5, 300, 2048, 5000, 9001] {
            let a = tall(rows, 12);
            let r = triangular_factor(&a);
            assert!(r.nrows() <= rows.min(12));
            let (g, h) = (a.transpose() * &a, r.transpose() * &r);
            let err = (&g - &h).abs().max() / g.abs().max();
            assert!(err < 1e-12, "{rows} rows: relative error {err:e}");
        }
    }

    #[test]
    fn keeps_the_singular_values_and_a_zero_column() {
        let mut a = tall(7000, 9);
        a.set_column(3, &nalgebra::DVector::zeros(7000));
        let r = triangular_factor(&a);
        assert!(
            r.column(3).iter().all(|v| *v == 0.0),
            "a zero column stays exactly zero"
        );
        let (sa, sr) = (
            a.clone().svd(false, false).singular_values,
            r.svd(false, false).singular_values,
        );
        let mut sa: Vec<f64> = sa.iter().copied().collect();
        let mut sr: Vec<f64> = sr.iter().copied().collect();
        sa.sort_by(f64::total_cmp);
        sr.sort_by(f64::total_cmp);
        for (x, y) in sa.iter().zip(&sr) {
            assert!((x - y).abs() <= 1e-10 * sa[sa.len() - 1], "{x} vs {y}");
        }
    }

    #[test]
    fn does_not_depend_on_the_threads() {
        let a = tall(10_000, 10);
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| triangular_factor(&a))
        };
        assert_eq!(on(1), on(2));
    }
}
