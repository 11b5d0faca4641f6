//! The fit's uncertainty at its solution (step *covariance* of the fit):
//! the standard deviations of the free parameters, the condition of the
//! problem, each measurement's leave-one-out error, and which parameters
//! the data barely determine.

use nalgebra::{DMatrix, Vector3};

use model::params::ParamKind;

use super::WEAK_REACH_FRACTION;
use super::problem::FitData;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::analysis::triangular::triangular_factor;
use crate::calib::{CalibError, ParamKey, Rig};

/// The fit's uncertainty at its solution.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Covariance {
    /// Residual deviation per coordinate, m.
    pub(super) sigma_m: f64,
    /// Condition number of the column-scaled, weighted Jacobian.
    pub(super) condition: f64,
    /// One standard deviation per free parameter, in `free` order, SI units.
    pub(super) std: Vec<f64>,
    /// The covariance of the free parameters, in `free` order, SI units.
    pub(super) matrix: DMatrix<f64>,
    /// Mean leave-one-out error of the measurements, m.
    pub(super) loo_mean_m: f64,
    /// Each measurement's leave-one-out error, in the measurements' order, m.
    pub(super) loo_errors_m: Vec<f64>,
}

/// Each measurement's norm of its leave-one-out residual, and their mean `(I − H_kk)⁻¹ r_k`, m: `r_k` the 3D residual of
/// measurement `k`, `H_kk` its 3×3 block of the hat matrix `U Uᵀ` of the
/// weighted Jacobian (`U` its left singular vectors; a measurement's weight
/// scales its residual and its rows alike, so it cancels). Exact for a
/// linear least-squares fit, the classic PRESS statistic; infinite when
/// `I − H_kk` is singular (the measurement alone decides a direction of the
/// parameters).
pub(super) fn leave_one_out(u: &DMatrix<f64>, residuals: &[Vector3<f64>]) -> (Vec<f64>, f64) {
    let errors: Vec<f64> = residuals
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let rows = u.rows(3 * k, 3);
            let i_minus_h = nalgebra::Matrix3::identity() - rows * rows.transpose();
            i_minus_h
                .lu()
                .solve(r)
                .filter(|e| e.iter().all(|v| v.is_finite()))
                .map_or(f64::INFINITY, |e| e.norm())
        })
        .collect();
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    (errors, mean)
}

/// The residual deviation per coordinate alone, m: [`covariance`]'s
/// `sigma_m`, which each round of a fit under a prior weighs the prior
/// against. With a prior the parameters the measurements determine are
/// `m − tr H_prior`, the hat matrix's trace over the prior's rows, read on
/// the Jacobian's triangular factor `R` as `‖A R⁻¹‖²` (`A` the prior's
/// rows): no singular vectors of the tall Jacobian, which only the
/// leave-one-out errors need. Falls back to [`covariance`] where `R` is
/// singular. Without a prior they are the free parameters, and no
/// Jacobian is needed.
pub(super) fn noise_sigma(
    data: &FitData,
    arm: &Rig,
    free: &[ParamKey],
    weights: &[f64],
    residuals: &[Vector3<f64>],
    prior: Option<&DMatrix<f64>>,
) -> Result<f64, CalibError> {
    let m = free.len();
    let Some(prior_rows) = prior else {
        return Ok(deviation(data, residuals, weights, m as f64));
    };
    let (scaled, _) = scaled_jacobian(data, arm, free, weights, prior)?;
    let r = triangular_factor(&scaled);
    let a = scaled.rows(3 * data.samples.len(), prior_rows.nrows());
    let in_prior = (r.shape() == (m, m))
        .then(|| r.transpose().solve_lower_triangular(&a.transpose()))
        .flatten()
        .map(|w| w.norm_squared())
        .filter(|t| t.is_finite());
    let Some(in_prior) = in_prior else {
        return covariance(data, arm, free, weights, residuals, prior).map(|c| c.sigma_m);
    };
    Ok(deviation(data, residuals, weights, m as f64 - in_prior))
}

/// The weighted Jacobian at `arm` over `free`, the prior's rows (if any)
/// below it, with its columns scaled, and the scale.
fn scaled_jacobian(
    data: &FitData,
    arm: &Rig,
    free: &[ParamKey],
    weights: &[f64],
    prior: Option<&DMatrix<f64>>,
) -> Result<(DMatrix<f64>, ColumnScale), CalibError> {
    let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let j = super::stack(data.weighted_jacobian(arm, free, &sqrt_w)?, prior.cloned());
    let scale = ColumnScale::from_jacobian(&j, data.samples.len());
    Ok((scale.apply(&j), scale))
}

/// The residual deviation per coordinate, m: the root of the weighted
/// residual sum of squares `Σ w_k ‖r_k‖²` over the coordinates measured (a
/// camera's blocks have two: their third row is zero) less the
/// `determined` parameters, that difference at least 1.
fn deviation(data: &FitData, residuals: &[Vector3<f64>], weights: &[f64], determined: f64) -> f64 {
    let rss: f64 = residuals
        .iter()
        .zip(weights)
        .map(|(e, w)| w * e.norm_squared())
        .sum();
    let measured = data.nominal.measured_axes() * data.samples.len();
    (rss / (measured as f64 - determined).max(1.0)).sqrt()
}

/// Step *covariance*: `cov = s² (JᵀJ)⁻¹` over the `free` parameters at `arm`,
/// with `s² = RSS / (3n − m)` of the weighted residual norms, and the
/// leave-one-out error of the measurements ([`leave_one_out`]).
///
/// With a prior, `prior` is its rows' Jacobian with respect to `free`,
/// scaled by the noise the fit weighed it against, `σ A`: `J` has these rows
/// below its own, which makes `cov` the posterior covariance
/// `σ² (JᵀJ + σ² AᵀA)⁻¹`, the hat matrix that of the regularised fit (the
/// leave-one-out errors its), and `m` the parameters the measurements
/// determine, `tr H` over the measurements' rows (each parameter counts
/// as far as the measurements, not the prior, decide it).
pub(super) fn covariance(
    data: &FitData,
    arm: &Rig,
    free: &[ParamKey],
    weights: &[f64],
    residuals: &[Vector3<f64>],
    prior: Option<&DMatrix<f64>>,
) -> Result<Covariance, CalibError> {
    let (scaled, scale) = scaled_jacobian(data, arm, free, weights, prior)?;
    let svd = scaled.svd(true, true);
    let condition = svd.singular_values.max() / svd.singular_values.min();
    let rows = 3 * data.samples.len();
    let determined = match (prior, svd.u.as_ref()) {
        (Some(_), Some(u)) => u.rows(0, rows).iter().map(|v| v * v).sum(),
        _ => free.len() as f64,
    };
    let sigma_m = deviation(data, residuals, weights, determined);
    let (loo_errors_m, loo_mean_m) = svd
        .u
        .as_ref()
        .map_or((Vec::new(), f64::NAN), |u| leave_one_out(u, residuals));
    // cov of scaled params = s² (JsᵀJs)⁻¹ = s² V Σ⁻² Vᵀ; unscale by the factors.
    let m = free.len();
    let matrix = match svd.v_t.as_ref() {
        Some(vt) => {
            // Vᵀ's rows divided by their singular values: cov = s² Wᵀ W.
            let mut w = vt.clone();
            for (i, s) in svd.singular_values.iter().enumerate() {
                w.row_mut(i).unscale_mut(*s);
            }
            let mut cov = w.transpose() * w * (sigma_m * sigma_m);
            for r in 0..m {
                for c in 0..m {
                    cov[(r, c)] *= scale.factors[r] * scale.factors[c];
                }
            }
            cov
        }
        None => DMatrix::from_element(m, m, f64::NAN),
    };
    // The deviations: the roots of the diagonal, each summed over the singular values.
    let vt = svd.v_t.as_ref();
    let std = (0..m)
        .map(|c| {
            let var: f64 = vt
                .map(|vt| {
                    svd.singular_values
                        .iter()
                        .enumerate()
                        .map(|(i, s)| (vt[(i, c)] / s).powi(2))
                        .sum()
                })
                .unwrap_or(f64::NAN);
            sigma_m * var.sqrt() * scale.factors[c]
        })
        .collect();
    Ok(Covariance {
        sigma_m,
        condition,
        std,
        matrix,
        loo_mean_m,
        loo_errors_m,
    })
}

/// Whether a free parameter with value `value` and deviation `std` is weak
/// on an arm of reach `reach_m` (module docs); a deviation that is not a
/// number (a direction the data do not see at all) is weak too.
pub(super) fn is_weak(key: ParamKey, value: f64, std: f64, reach_m: f64) -> bool {
    let (moves, limit) = match key.kind() {
        ParamKind::Compliance => (std, value.abs()),
        ParamKind::Length => (std, WEAK_REACH_FRACTION * reach_m),
        ParamKind::Angle => (std * reach_m, WEAK_REACH_FRACTION * reach_m),
    };
    moves.is_nan() || moves > limit
}
