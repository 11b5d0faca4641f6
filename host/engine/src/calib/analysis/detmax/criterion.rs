//! DETMAX's criterion, `ln det M` of a design's information matrix, and the
//! gains `det(I ± G_c)` of adding or dropping one candidate, with the choice
//! of the best.

use nalgebra::DMatrix;

use super::Pool;

/// The ridge `RIDGE · I` added to `M` so that a random start is invertible.
pub(super) const RIDGE: f64 = 1e-9;

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

/// Rebuilds `minv` from the `member` blocks and returns `ln det M`.
pub(super) fn refactor(pool: &Pool, member: &[bool], minv: &mut DMatrix<f64>) -> f64 {
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

/// `det(I + sign · G)` of an r×r matrix `g` (column-major) that is
/// symmetric, by Cholesky in `scratch`; `None` when `I + sign · G` is not
/// positive definite (a pose the design cannot do without, to drop).
pub(super) fn det_shifted(g: &[f64], sign: f64, r: usize, scratch: &mut [f64]) -> Option<f64> {
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

/// The candidate of the largest gain, the first (lowest index) among equal ones.
pub(super) fn first_max(gains: impl Iterator<Item = (usize, f64)>) -> Option<usize> {
    gains
        .fold(None, |best: Option<(usize, f64)>, (c, gain)| match best {
            Some((_, g)) if g >= gain => best,
            _ => Some((c, gain)),
        })
        .map(|(c, _)| c)
}
