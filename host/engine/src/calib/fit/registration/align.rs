//! The best rigid motion between two point sets (closed form, by the SVD of
//! their cross-covariance), and its trimmed repetition that leaves gross
//! errors out.

use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, Translation3, Vector3};

use super::{MAX_ROUNDS, TRIM_FACTOR, TRIM_FLOOR_M};

/// A rigid motion `p ↦ r · p + t` as `(r, t)`.
pub(super) type Motion = (Matrix3<f64>, Vector3<f64>);

/// The best rigid motion `T` with `T · p ≈ m` over the pairs whose `keep` is
/// true, by the SVD of the cross-covariance; `proper` chooses a rotation,
/// otherwise the reflection is allowed. `None` when the points are too few or
/// lie on a line (a turn about it would be free).
pub(super) fn align(
    predicted: &[Vector3<f64>],
    measured: &[Vector3<f64>],
    keep: &[bool],
    proper: bool,
) -> Option<Motion> {
    let pairs: Vec<(&Vector3<f64>, &Vector3<f64>)> = predicted
        .iter()
        .zip(measured)
        .zip(keep)
        .filter(|(_, k)| **k)
        .map(|(pair, _)| pair)
        .collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let pc = pairs.iter().map(|(p, _)| **p).sum::<Vector3<f64>>() / n;
    let mc = pairs.iter().map(|(_, m)| **m).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = pairs
        .iter()
        .map(|(p, m)| (**p - pc) * (**m - mc).transpose())
        .sum();
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let s = svd.singular_values;
    // Points on a line leave the turn about it free: the second singular value vanishes.
    let spread = pairs
        .iter()
        .map(|(p, _)| (**p - pc).norm_squared())
        .sum::<f64>();
    if s.max() <= 0.0 || s.iter().filter(|v| **v > 1e-9 * spread.max(1e-300)).count() < 2 {
        return None;
    }
    let mut d = Matrix3::identity();
    if proper && (v_t.transpose() * u.transpose()).determinant() < 0.0 {
        // The third singular value is the smallest (nalgebra sorts them): flip it.
        let (smallest, _) = s.argmin();
        d[(smallest, smallest)] = -1.0;
    }
    let r = v_t.transpose() * d * u.transpose();
    Some((r, mc - r * pc))
}

/// Distances of `predicted` under `(r, t)` from `measured`, m.
pub(super) fn distances(
    (r, t): &Motion,
    predicted: &[Vector3<f64>],
    measured: &[Vector3<f64>],
) -> Vec<f64> {
    predicted
        .iter()
        .zip(measured)
        .map(|(p, m)| (r * p + t - m).norm())
        .collect()
}

pub(super) fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.get(s.len() / 2).copied().unwrap_or(0.0)
}

pub(super) fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

/// The trimmed least-squares alignment of `predicted` onto `measured`:
/// the motion, the kept mask and the distances of every point.
pub(super) fn trimmed_align(
    predicted: &[Vector3<f64>],
    measured: &[Vector3<f64>],
    proper: bool,
) -> Option<(Motion, Vec<bool>, Vec<f64>)> {
    let mut keep = vec![true; predicted.len()];
    let mut motion = align(predicted, measured, &keep, proper)?;
    for _ in 0..MAX_ROUNDS {
        let d = distances(&motion, predicted, measured);
        let limit = (TRIM_FACTOR * median(&d)).max(TRIM_FLOOR_M);
        let next: Vec<bool> = d.iter().map(|e| *e <= limit).collect();
        // Never trim to fewer than half the points: then the "outliers" are the data.
        if next == keep || next.iter().filter(|k| **k).count() * 2 < keep.len() {
            return Some((motion, keep, d));
        }
        keep = next;
        motion = align(predicted, measured, &keep, proper)?;
    }
    let d = distances(&motion, predicted, measured);
    Some((motion, keep, d))
}

pub(super) fn isometry((r, t): &Motion) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(Translation3::from(*t), Rotation3::from_matrix_unchecked(*r))
}
