//! Robust weighting: Huber's cost as the solver minimises it, the weights
//! it gives the measurements and the rule that names outliers, all in
//! units of the residuals' robust scale.

use nalgebra::{Matrix3, Vector3};

use super::result::Outlier;
use crate::calib::Sample;

/// Huber threshold on the residual norm, in units of the robust per-axis scale.
pub const HUBER_K: f64 = 3.0;
/// Residual norm (in units of the robust per-axis scale) above which a measurement is named an outlier.
pub const OUTLIER_K: f64 = 4.5;
/// Median of the norm of a 3D standard Gaussian vector (a tracker's point).
const CHI3_MEDIAN: f64 = 1.5382;
/// Median of the norm of a 2D standard Gaussian vector (a camera's pixel).
const CHI2_MEDIAN: f64 = 1.1774;

/// The robust per-axis scale of a set of residual norms, each over `axes`
/// axes (3 for a tracker's points, 2 for a camera's pixels).
pub(super) fn robust_scale(norms: &[f64], axes: usize) -> f64 {
    let mut v = norms.to_vec();
    v.sort_by(f64::total_cmp);
    let median = if v.is_empty() { 0.0 } else { v[v.len() / 2] };
    median
        / match axes {
            2 => CHI2_MEDIAN,
            _ => CHI3_MEDIAN,
        }
}

/// Huber's threshold on the residual norms `norms` (each over `axes`
/// axes): [`HUBER_K`] robust scales; `None` when most residuals vanish
/// (exact data: nothing to measure a gross one against).
pub(super) fn huber_threshold(norms: &[f64], axes: usize) -> Option<f64> {
    Some(HUBER_K * robust_scale(norms, axes)).filter(|c| *c > 0.0)
}

/// How a Levenberg–Marquardt run weighs the measurements' residual blocks.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Weighting<'w> {
    /// Least squares, each block times the square root of its weight.
    Scaled(&'w [f64]),
    /// Huber's cost of each block's norm `e` with this threshold `c`:
    /// `e²` up to it, `2ce − c²` beyond, minimised directly. A block beyond
    /// is shortened to the norm `√(2ce − c²)`, so the solver's sum of
    /// squares is the cost, and its Jacobian rows follow (the chain rule
    /// through the shortening).
    Huber(f64),
}

impl Weighting<'_> {
    /// The `k`-th block `r` as the solver sees it, and the map from the
    /// block's Jacobian rows to those of what the solver sees.
    pub(crate) fn block(&self, k: usize, r: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        match *self {
            Weighting::Scaled(sqrt_w) => (r * sqrt_w[k], Matrix3::identity() * sqrt_w[k]),
            Weighting::Huber(c) => {
                let e = r.norm();
                if e <= c {
                    return (*r, Matrix3::identity());
                }
                let f = (2.0 * c * e - c * c).sqrt();
                let u = r / e;
                let along = u * u.transpose();
                let map = along * (c / f) + (Matrix3::identity() - along) * (f / e);
                (u * f, map)
            }
        }
    }
}

/// Step *reweight*: Huber weights of the measurements from their residual
/// norms, each over `axes` axes.
pub(super) fn huber_weights(norms: &[f64], axes: usize) -> Vec<f64> {
    let Some(c) = huber_threshold(norms, axes) else {
        return vec![1.0; norms.len()];
    };
    norms
        .iter()
        .map(|&e| if e <= c || e == 0.0 { 1.0 } else { c / e })
        .collect()
}

/// The indices of the error norms (each over `axes` axes) beyond
/// [`OUTLIER_K`] robust scales of them: the one rule for naming outliers,
/// in a fit and in a validation.
pub fn outlier_indices(norms: &[f64], axes: usize) -> Vec<usize> {
    let s = robust_scale(norms, axes);
    (0..norms.len())
        .filter(|&k| s > 0.0 && norms[k] > OUTLIER_K * s)
        .collect()
}

/// Step *outliers*: the measurements whose residual norm exceeds
/// [`OUTLIER_K`] robust scales, largest first.
pub(super) fn name_outliers(
    samples: &[Sample],
    norms: &[f64],
    weights: &[f64],
    axes: usize,
) -> Vec<Outlier> {
    let mut outliers: Vec<Outlier> = outlier_indices(norms, axes)
        .into_iter()
        .map(|k| (k, norms[k]))
        .map(|(k, e)| Outlier {
            pose: samples[k].id,
            load_kg: samples[k].load_kg,
            residual_m: e,
            weight: weights[k],
        })
        .collect();
    outliers.sort_by(|a, b| b.residual_m.total_cmp(&a.residual_m));
    outliers
}
