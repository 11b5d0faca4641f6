//! Robust weighting: the Huber weights of the measurements and the rule that
//! names outliers, both in units of the residuals' robust scale.

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

/// Step *reweight*: Huber weights of the measurements from their residual
/// norms, each over `axes` axes.
pub(super) fn huber_weights(norms: &[f64], axes: usize) -> Vec<f64> {
    let c = HUBER_K * robust_scale(norms, axes);
    if c == 0.0 {
        // Most residuals vanish (exact data): nothing to measure a gross one against.
        return vec![1.0; norms.len()];
    }
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
