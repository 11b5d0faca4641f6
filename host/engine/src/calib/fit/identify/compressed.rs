//! A tall least-squares problem as the solver sees it: `n + 1` rows for
//! `n` parameters instead of one per measured coordinate.
//!
//! Levenberg–Marquardt uses the residuals `r` and the Jacobian `J` only
//! through the cost `|r|²`, the gradient `Jᵀr` and the Gauss–Newton matrix
//! `JᵀJ` (its QR of `J` is a way of factoring `JᵀJ`). The solver is handed
//! `r' = (|r|, 0, …, 0)` and
//!
//! ```text
//! J' = ⎡ uᵀJ ⎤    u = r / |r|,   R the triangle with RᵀR = (PJ)ᵀ(PJ),
//!      ⎣  R  ⎦    P = I − uuᵀ (J with its part along r taken out),
//! ```
//!
//! for which `|r'| = |r|`, `J'ᵀr' = Jᵀr` and `J'ᵀJ' = JᵀJ`: every step,
//! damping and convergence test comes out as on the whole problem. The
//! residuals at a trial point are only their norm, and the solver's QR is
//! of `(n + 1) × n` instead of `rows × n` (a camera fit: 5,152 rows, 100
//! parameters). `R` comes from the Cholesky factor of the Gram matrix,
//! which one matrix product forms; its columns scaled to unit length
//! first, and a ridge of [`RIDGE`] on that unit diagonal, where `PJ` has
//! lost a direction (at a fit's start, `r` nearly in the span of `J`); the
//! row `uᵀJ` carries that direction exactly.

use nalgebra::{DMatrix, DVector};

/// Ridge added to the unit diagonal of the scaled Gram matrix of `PJ`
/// before its Cholesky factorisation: far below what a step can feel
/// (LM damps by more than this), far above the rounding of the product.
pub const RIDGE: f64 = 1e-12;

/// The residuals the solver sees for a problem of `params` parameters
/// whose residuals have the norm `norm`.
pub(super) fn residuals(norm: f64, params: usize) -> DVector<f64> {
    let mut r = DVector::zeros(params + 1);
    r[0] = norm;
    r
}

/// The Jacobian the solver sees for the residuals `r` and their Jacobian
/// `j` (module docs).
pub(super) fn jacobian(r: &DVector<f64>, mut j: DMatrix<f64>) -> DMatrix<f64> {
    let n = j.ncols();
    let mut out = DMatrix::zeros(n + 1, n);
    let norm = r.norm();
    if norm > 0.0 {
        let u = r / norm;
        let along = j.tr_mul(&u);
        out.row_mut(0).copy_from(&along.transpose());
        // PJ = J − u (uᵀJ)
        j.ger(-1.0, &u, &along, 1.0);
    }
    out.rows_mut(1, n).copy_from(&triangle(&j));
    out
}

/// An upper triangle `R` with `RᵀR = jᵀj`.
fn triangle(j: &DMatrix<f64>) -> DMatrix<f64> {
    let gram = j.transpose() * j;
    let n = gram.ncols();
    let scale: Vec<f64> = (0..n)
        .map(|c| gram[(c, c)].sqrt())
        .map(|s| if s > 0.0 { s } else { 1.0 })
        .collect();
    let scaled = DMatrix::from_fn(n, n, |a, b| {
        gram[(a, b)] / (scale[a] * scale[b]) + if a == b { RIDGE } else { 0.0 }
    });
    match scaled.cholesky() {
        Some(c) => {
            let l = c.l();
            DMatrix::from_fn(n, n, |a, b| l[(b, a)] * scale[b])
        }
        // Not positive definite even with the ridge (a column of NaN, an
        // overflow): the QR's triangle, slower and always there.
        None => j.clone().qr().r(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tall() -> (DVector<f64>, DMatrix<f64>) {
        let rows = 40;
        let j = DMatrix::from_fn(rows, 5, |a, b| {
            ((a * 7 + b * 13) % 11) as f64 - 5.0 + 1e-3 * (a * b) as f64
        });
        let r = DVector::from_fn(rows, |a, _| ((a * 5) % 9) as f64 - 4.0);
        (r, j)
    }

    fn close(a: &DMatrix<f64>, b: &DMatrix<f64>) {
        let scale = b.norm();
        assert!((a - b).norm() <= 1e-11 * scale, "{a} vs {b}");
    }

    /// The solver's cost, gradient and Gauss–Newton matrix are the tall
    /// problem's.
    #[test]
    fn the_compressed_problem_keeps_cost_gradient_and_gauss_newton_matrix() {
        let (r, j) = tall();
        let rc = residuals(r.norm(), j.ncols());
        let jc = jacobian(&r, j.clone());
        assert_eq!(jc.shape(), (6, 5));
        assert!((rc.norm() - r.norm()).abs() < 1e-12 * r.norm());
        close(
            &DMatrix::from_column_slice(5, 1, (jc.transpose() * &rc).as_slice()),
            &DMatrix::from_column_slice(5, 1, (j.transpose() * &r).as_slice()),
        );
        close(&(jc.transpose() * &jc), &(j.transpose() * &j));
    }

    /// Residuals in the span of the Jacobian (a fit's start, a problem
    /// the parameters solve exactly) and none at all are compressed as well.
    #[test]
    fn residuals_the_parameters_explain_and_none_are_compressed_too() {
        let (_, j) = tall();
        let x = DVector::from_vec(vec![0.3, -1.0, 2.0, 0.5, 0.1]);
        for r in [&j * &x, DVector::zeros(j.nrows())] {
            let jc = jacobian(&r, j.clone());
            let rc = residuals(r.norm(), j.ncols());
            close(&(jc.transpose() * &jc), &(j.transpose() * &j));
            let g = jc.transpose() * &rc;
            let expected = j.transpose() * &r;
            assert!((g - &expected).norm() <= 1e-12 * expected.norm().max(1.0));
        }
    }
}
