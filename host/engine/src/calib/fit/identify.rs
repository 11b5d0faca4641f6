//! Identification: the error parameters that make the model's measured points
//! match the measurements, by Levenberg–Marquardt (the `levenberg-marquardt`
//! crate, MINPACK's algorithm on nalgebra), in named steps: *fit* (one LM run
//! over the free parameters of a [`ParamVector`]), *active set* (bounds),
//! *reweight* (Huber), *covariance* and *outliers*.
//!
//! **Bounded parameters, by an active set.** Compliances, softenings and
//! play widths have physical ranges (`model::bounds`: worked out from the
//! nominal arm, its rated payload included, the very ranges every reader of
//! the calibration file and the board check), kept inside by
//! `model::bounds::FIT_MARGIN`. The fit runs unconstrained over the free
//! parameters (a value outside is only a number to the model, so the solver
//! never sees a kink). If it ends with some value outside its range, those
//! parameters are fixed at exactly the bound and the fit is repeated from
//! there; a fixed one is released again when the gradient says that moving
//! it off the bound would lower the cost (the KKT multiplier has the wrong
//! sign). This ends with every bounded parameter either free and inside its
//! range or fixed at a bound with a non-negative multiplier: the constrained
//! optimum. Should the round budget run out first, what is still outside is
//! fixed at its bound, so the identified arm is always physical, and no
//! reader refuses the file it goes into. The compliance's ceiling
//! (`model::bounds::MAX_SAG_RAD` over the largest torque) also keeps the
//! deflection's fixed-point iteration well inside where it converges, so
//! the identified arm can be evaluated.
//!
//! **Failed steps.** Parameters the data barely determine let a trial step of
//! LM go far, e.g. to a compliance whose deflection no longer converges.
//! Such a trial point gets a residual [`FAILED_STEP_FACTOR`] times the one the
//! run started from: LM's ratio test rejects it like any step that made
//! things worse and raises the damping; the fit goes on from the last good
//! point. The count is reported (`failed_steps`).
//!
//! **Standard deviations** come from the Jacobian J of the free parameters at
//! the solution and the residual: `cov = s² (JᵀJ)⁻¹` with `s² = RSS / (3n − m)`.
//! Parameters fixed at a bound are reported with no deviation. A free
//! parameter is named **weak** when the data barely determine it: a compliance
//! whose deviation exceeds its value (the data cannot tell it from zero), a
//! length or angle whose deviation moves the tool point, at the arm's reach,
//! by more than [`WEAK_REACH_FRACTION`] of the reach. The fit keeps them (they
//! do not harm the measured points), and says how little they mean.
//!
//! **Leave-one-out error.** How well the fit predicts a pose it did not see
//! is estimated from the fit itself: each measurement's residual in the fit
//! without it is `(I − H_kk)⁻¹ r_k` (`H` the hat matrix of the linearised
//! fit, `r_k` the measurement's residual; exact for a linear fit), and
//! their mean norm is reported (`loo_mean_m`). A model with more parameters
//! than the poses carry fits its own poses better and this worse; the
//! servo curves' knot spacing is chosen by it (`calib::knot_choice`).
//!
//! **Robust fit, the default (Huber, by iteratively reweighted least squares).** Each
//! measurement's weight depends on the norm `e` of its 3D residual relative to
//! a robust scale `s = median(e) / 1.5382` (the median of the norm of a 3D
//! Gaussian with per-axis deviation σ is 1.5382 σ): weight 1 up to
//! [`HUBER_K`]`·s`, `HUBER_K·s / e` beyond. Whether robust or not, measurements
//! whose residual exceeds [`OUTLIER_K`]`·s` are named as outliers (a clean 3D
//! Gaussian residual exceeds 4.5 σ with probability 5e-4).

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn, Vector3};

use model::params::ParamKind;

use crate::calib::analysis::identifiability::check_full_rank;
use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::{ParamKey, ParamVector};
use crate::calib::parameters::servo_knots;
use crate::calib::{CalibError, ModelOption, Rig, Sample};
use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::ErrorStats;

/// Huber threshold on the residual norm, in units of the robust per-axis scale.
pub const HUBER_K: f64 = 3.0;
/// Residual norm (in units of the robust per-axis scale) above which a measurement is named an outlier.
pub const OUTLIER_K: f64 = 4.5;
/// Median of the norm of a 3D standard Gaussian vector.
const CHI3_MEDIAN: f64 = 1.5382;
/// A free length or angle is weak when one standard deviation of it moves the
/// tool point by more than this fraction of the arm's reach (1 %: 4 mm on
/// the bundled arm, 14 mm on a UR10-sized one).
pub const WEAK_REACH_FRACTION: f64 = 1e-2;
/// A trial point whose deflection cannot be solved scores this many times the
/// residual norm its LM run started from: far beyond the tenfold that makes
/// LM count a step as failed.
pub const FAILED_STEP_FACTOR: f64 = 1e6;

/// How to fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyOptions {
    /// Down-weight outliers with Huber's function (the default: on clean
    /// data it loses nothing, see docs/METHOD.md).
    pub robust: bool,
    /// Most active-set rounds (each one a full LM fit), over all reweighting rounds.
    pub max_active_set_rounds: usize,
    /// Most reweighting rounds of the robust fit.
    pub max_irls_rounds: usize,
    /// Run the rank analysis again at the estimate and fit what it adds
    /// (`crate::calib::fit::refresh`, which the pipeline calls); false is the paper's reduction.
    pub refresh: bool,
    /// Most residual evaluations of one LM run, in units of the free
    /// parameters + 1 (MINPACK's `maxfev` factor).
    pub patience: usize,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            robust: true,
            max_active_set_rounds: 10,
            max_irls_rounds: 12,
            refresh: true,
            patience: 50,
        }
    }
}

/// One identified parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The parameter.
    pub id: ParamKey,
    /// Identified error (correction added to the nominal value), SI units.
    pub error: f64,
    /// Nominal + error, SI units.
    pub value: f64,
    /// One standard deviation of the error, SI units; `None` when fixed at a bound.
    pub std: Option<f64>,
    /// Whether the data barely determine it (see the module docs).
    pub weak: bool,
}

/// A measurement whose residual is far beyond the others'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outlier {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// Norm of its residual after the fit, m.
    pub residual_m: f64,
    /// Its final weight in the fit (1 when not robust).
    pub weight: f64,
}

/// How the fit went.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostics {
    /// The last LM run's termination reason.
    pub termination: String,
    /// Whether the last LM run reported success.
    pub converged: bool,
    /// Whether an LM run spent its whole evaluation budget
    /// ([`IdentifyOptions::patience`]) before converging.
    pub exhausted: bool,
    /// Residual evaluations over all LM runs.
    pub evaluations: usize,
    /// Active-set rounds used.
    pub active_set_rounds: usize,
    /// Trial steps rejected because the deflection could not be solved there.
    pub failed_steps: usize,
    /// Reweighting rounds used (1 when not robust).
    pub irls_rounds: usize,
    /// Parameters fixed at a bound (zero or the compliance's physical
    /// ceiling) by the constraint, in fit order.
    pub at_bound: Vec<ParamKey>,
    /// RMS of the 3D residual norm before the fit (nominal model), m.
    pub rms_before_m: f64,
    /// RMS of the 3D residual norm after the fit, m.
    pub rms_after_m: f64,
    /// Residual standard deviation per coordinate, `sqrt(RSS / (3n − m))`, m.
    pub sigma_m: f64,
    /// Condition number of the column-scaled Jacobian at the solution.
    pub condition: f64,
    /// Mean 3D error at each fitted measurement of the fit without it
    /// (leave-one-out, from the linearised fit: see the module docs), m;
    /// infinite when a measurement alone decides a parameter.
    pub loo_mean_m: f64,
}

/// The outcome of an identification.
#[derive(Clone, Debug, PartialEq)]
pub struct Identified {
    /// The option fitted.
    pub option: ModelOption,
    /// The nominal arm and targets with the identified errors applied.
    pub rig: Rig,
    /// Every fitted parameter.
    pub estimates: Vec<Estimate>,
    /// Convergence diagnostics.
    pub diagnostics: Diagnostics,
    /// 3D error of the calibrated arm on the measurements it was fitted to (unweighted).
    pub fit_residual: ErrorStats,
    /// [`Identified::fit_residual`] per target, in the rig's target order.
    pub fit_residual_per_target: Vec<ErrorStats>,
    /// Measurements named as outliers, largest residual first.
    pub outliers: Vec<Outlier>,
}

/// The measurements of one fit, as the solver sees them.
struct FitData<'a> {
    nominal: &'a Rig,
    option: ModelOption,
    samples: Vec<Sample>,
    measured: Vec<Vector3<f64>>,
}

impl<'a> FitData<'a> {
    fn new(
        nominal: &'a Rig,
        option: ModelOption,
        measurements: &[Measurement],
    ) -> Result<Self, CalibError> {
        let samples = nominal.samples(measurements)?;
        Ok(Self {
            nominal,
            option,
            samples,
            measured: measurements.iter().map(|m| m.position).collect(),
        })
    }

    /// The smallest and largest value the fit may give `key`'s quantity, if bounded.
    fn bounds(&self, key: ParamKey) -> (Option<f64>, Option<f64>) {
        key.fit_range(&self.nominal.bounds)
    }

    /// Norms of the 3D residuals of `arm` against the measurements, m.
    fn residual_norms(&self, arm: &Rig) -> Result<Vec<f64>, CalibError> {
        Ok(self.residuals(arm)?.iter().map(|r| r.norm()).collect())
    }

    /// The 3D residuals of `arm` against the measurements, m.
    fn residuals(&self, arm: &Rig) -> Result<Vec<Vector3<f64>>, CalibError> {
        Ok(arm
            .tool_points(&self.samples)?
            .iter()
            .zip(&self.measured)
            .map(|(p, m)| p - m)
            .collect())
    }

    /// The stacked residuals of `arm`, each 3D residual times its `sqrt_w`.
    fn weighted_residuals(&self, arm: &Rig, sqrt_w: &[f64]) -> Option<DVector<f64>> {
        let points = arm.tool_points(&self.samples).ok()?;
        let mut r = DVector::zeros(3 * points.len());
        for (k, (p, m)) in points.iter().zip(&self.measured).enumerate() {
            r.fixed_rows_mut::<3>(3 * k)
                .copy_from(&((p - m) * sqrt_w[k]));
        }
        Some(r)
    }

    /// The Jacobian of the weighted residuals with respect to `keys` at `arm`.
    fn weighted_jacobian(
        &self,
        arm: &Rig,
        keys: &[ParamKey],
        sqrt_w: &[f64],
    ) -> Result<DMatrix<f64>, CalibError> {
        let mut j = jacobian(arm, keys, &self.samples)?;
        for (k, w) in sqrt_w.iter().enumerate() {
            j.rows_mut(3 * k, 3).scale_mut(*w);
        }
        Ok(j)
    }

    fn solver_error(&self, reason: String) -> CalibError {
        CalibError::Solver {
            option: self.option.name().into(),
            reason,
        }
    }
}

/// The LM problem over the free parameters; the fixed ones stay where they are.
struct Problem<'a> {
    data: &'a FitData<'a>,
    params: &'a ParamVector,
    free: Vec<ParamKey>,
    sqrt_w: &'a [f64],
    x: DVector<f64>,
    /// The residual of a trial point whose deflection cannot be solved
    /// (each entry), from the norm the run started from.
    failed_entry: f64,
    /// Trial points that could not be evaluated.
    failed: std::cell::Cell<usize>,
}

impl Problem<'_> {
    fn arm(&self) -> Rig {
        self.params
            .apply_with_free(self.data.nominal, self.x.as_slice())
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        match self.data.weighted_residuals(&self.arm(), self.sqrt_w) {
            Some(r) => Some(r),
            None => {
                // A failed step, not the end of the fit (module docs).
                self.failed.set(self.failed.get() + 1);
                let rows = 3 * self.data.samples.len();
                Some(DVector::from_element(rows, self.failed_entry))
            }
        }
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.data
            .weighted_jacobian(&self.arm(), &self.free, self.sqrt_w)
            .ok()
    }
}

/// What the LM runs of a fit add up to.
#[derive(Debug, Default)]
struct Tally {
    evaluations: usize,
    exhausted: bool,
    active_set_rounds: usize,
    irls_rounds: usize,
    failed_steps: usize,
    termination: String,
    converged: bool,
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// The robust per-axis scale of a set of residual norms.
fn robust_scale(norms: &[f64]) -> f64 {
    let mut v = norms.to_vec();
    v.sort_by(f64::total_cmp);
    let median = if v.is_empty() { 0.0 } else { v[v.len() / 2] };
    median / CHI3_MEDIAN
}

/// Step *fit*: one Levenberg–Marquardt run over the free parameters of
/// `params`, residuals weighted by `sqrt_w`; leaves the solution in `params`.
fn fit(
    data: &FitData,
    params: &mut ParamVector,
    sqrt_w: &[f64],
    patience: usize,
    tally: &mut Tally,
) -> Result<(), CalibError> {
    let start = data
        .weighted_residuals(&params.apply(data.nominal), sqrt_w)
        .ok_or_else(|| {
            data.solver_error("the model cannot be evaluated where the fit starts".into())
        })?;
    let rows = start.len().max(1) as f64;
    let problem = Problem {
        data,
        params,
        free: params.free().collect(),
        sqrt_w,
        x: DVector::from_vec(params.free_errors()),
        failed_entry: FAILED_STEP_FACTOR * start.norm().max(f64::MIN_POSITIVE) / rows.sqrt(),
        failed: std::cell::Cell::new(0),
    };
    let (problem, report) = LevenbergMarquardt::new()
        .with_patience(patience.max(1))
        .minimize(problem);
    tally.evaluations += report.number_of_evaluations;
    tally.exhausted |= report.termination == TerminationReason::LostPatience;
    tally.failed_steps += problem.failed.get();
    tally.converged = report.termination.was_successful();
    tally.termination = format!("{:?}", report.termination);
    if !problem.x.iter().all(|v| v.is_finite()) {
        return Err(data.solver_error(tally.termination.clone()));
    }
    let x = problem.x;
    params.set_free(x.as_slice());
    Ok(())
}

/// The free parameters whose value in `arm` lies outside their bounds, with
/// the bound they crossed.
fn outside_bounds(data: &FitData, params: &ParamVector, arm: &Rig) -> Vec<(ParamKey, f64)> {
    params
        .free()
        .filter_map(|k| {
            let v = k.value(arm);
            match data.bounds(k) {
                (Some(lo), _) if v < lo => Some((k, lo)),
                (_, Some(hi)) if v > hi => Some((k, hi)),
                _ => None,
            }
        })
        .collect()
}

/// Fixes each key at its bound: the correction that takes its nominal value there.
fn fix_at_bound(
    params: &mut ParamVector,
    nominal: &Rig,
    bounds: &[(ParamKey, f64)],
) -> Result<(), CalibError> {
    for &(key, bound) in bounds {
        params.fix(key, -(key.value(nominal) - bound))?;
    }
    Ok(())
}

/// Step *release*: of the parameters fixed at a bound, the one whose cost
/// gradient at `arm` points most steeply back inside (down at a lower bound,
/// up at an upper one), i.e. whose KKT multiplier has the wrong sign (moving
/// it off the bound would lower the cost); none when every fixed parameter
/// belongs there.
fn release_candidate(
    data: &FitData,
    params: &ParamVector,
    arm: &Rig,
    sqrt_w: &[f64],
) -> Option<ParamKey> {
    let fixed: Vec<ParamKey> = params.fixed().collect();
    if fixed.is_empty() {
        return None;
    }
    let r = data.weighted_residuals(arm, sqrt_w)?;
    let jf = data.weighted_jacobian(arm, &fixed, sqrt_w).ok()?;
    // d(cost)/d(correction) for each fixed parameter at the solution.
    let g = jf.transpose() * r;
    let scale = jf
        .column_iter()
        .map(|c| c.norm())
        .fold(0.0, f64::max)
        .max(1e-300);
    // +1 at a lower bound (inside is up), −1 at an upper one.
    let inward = |k: ParamKey| match data.bounds(k) {
        (Some(lo), _) if k.value(arm) <= lo => 1.0,
        _ => -1.0,
    };
    fixed
        .iter()
        .zip(g.iter())
        .map(|(k, v)| (*k, inward(*k) * v))
        .filter(|(_, v)| *v < -1e-9 * scale)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// Step *active set*: fit the free parameters, fix those that end outside their
/// bounds at the bound and fit again, release a fixed one whose multiplier has
/// the wrong sign; until neither happens, the round budget of
/// `options.max_active_set_rounds` (counted over the whole identification)
/// is spent or an LM run spent its evaluation budget, in which case what is
/// still outside its bounds is fixed there, so the result is always a
/// physical arm.
fn active_set(
    data: &FitData,
    params: &mut ParamVector,
    sqrt_w: &[f64],
    options: &IdentifyOptions,
    tally: &mut Tally,
) -> Result<(), CalibError> {
    loop {
        tally.active_set_rounds += 1;
        fit(data, params, sqrt_w, options.patience, tally)?;
        let arm = params.apply(data.nominal);
        let outside = outside_bounds(data, params, &arm);
        // A run that spent its budget would spend it again from about there.
        if tally.active_set_rounds >= options.max_active_set_rounds || tally.exhausted {
            return fix_at_bound(params, data.nominal, &outside);
        }
        if !outside.is_empty() {
            fix_at_bound(params, data.nominal, &outside)?;
            continue;
        }
        match release_candidate(data, params, &arm, sqrt_w) {
            Some(key) => params.release(key)?,
            None => return Ok(()),
        }
    }
}

/// Step *reweight*: Huber weights of the measurements from their residual norms.
fn huber_weights(norms: &[f64]) -> Vec<f64> {
    let c = HUBER_K * robust_scale(norms);
    if c == 0.0 {
        // Most residuals vanish (exact data): nothing to measure a gross one against.
        return vec![1.0; norms.len()];
    }
    norms
        .iter()
        .map(|&e| if e <= c || e == 0.0 { 1.0 } else { c / e })
        .collect()
}

/// The fit's uncertainty at its solution.
#[derive(Clone, Debug, PartialEq)]
struct Covariance {
    /// Residual deviation per coordinate, m.
    sigma_m: f64,
    /// Condition number of the column-scaled, weighted Jacobian.
    condition: f64,
    /// One standard deviation per free parameter, in `free` order, SI units.
    std: Vec<f64>,
    /// Mean leave-one-out error of the measurements, m.
    loo_mean_m: f64,
}

/// Mean over the measurements of the norm of their leave-one-out residual
/// `(I − H_kk)⁻¹ r_k`, m: `r_k` the 3D residual of measurement `k`, `H_kk`
/// its 3×3 block of the hat matrix `U Uᵀ` of the weighted Jacobian (`U` its
/// left singular vectors; a measurement's weight scales its residual and
/// its rows alike, so it cancels). Exact for a linear least-squares fit,
/// the classic PRESS statistic; infinite when `I − H_kk` is singular (the
/// measurement alone decides a direction of the parameters).
fn leave_one_out_mean(u: &DMatrix<f64>, residuals: &[Vector3<f64>]) -> f64 {
    let total: f64 = residuals
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
        .sum();
    total / residuals.len().max(1) as f64
}

/// Step *covariance*: `cov = s² (JᵀJ)⁻¹` over the `free` parameters at `arm`,
/// with `s² = RSS / (3n − m)` of the weighted residual norms, and the
/// leave-one-out error of the measurements ([`leave_one_out_mean`]).
fn covariance(
    data: &FitData,
    arm: &Rig,
    free: &[ParamKey],
    weights: &[f64],
    residuals: &[Vector3<f64>],
) -> Result<Covariance, CalibError> {
    let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let j = data.weighted_jacobian(arm, free, &sqrt_w)?;
    let rss: f64 = residuals
        .iter()
        .zip(weights)
        .map(|(e, w)| w * e.norm_squared())
        .sum();
    let dof = (3 * data.samples.len()).saturating_sub(free.len()).max(1);
    let sigma_m = (rss / dof as f64).sqrt();
    let scale = ColumnScale::from_jacobian(&j, data.samples.len());
    let svd = scale.apply(&j).svd(true, true);
    let condition = svd.singular_values.max() / svd.singular_values.min();
    let loo_mean_m = svd
        .u
        .as_ref()
        .map_or(f64::NAN, |u| leave_one_out_mean(u, residuals));
    // cov of scaled params = s² (JsᵀJs)⁻¹ = s² V Σ⁻² Vᵀ; unscale by the factors.
    let vt = svd.v_t.as_ref();
    let std = (0..free.len())
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
        loo_mean_m,
    })
}

/// Whether a free parameter with value `value` and deviation `std` is weak
/// on an arm of reach `reach_m` (module docs); a deviation that is not a
/// number (a direction the data do not see at all) is weak too.
fn is_weak(key: ParamKey, value: f64, std: f64, reach_m: f64) -> bool {
    let (moves, limit) = match key.kind() {
        ParamKind::Compliance => (std, value.abs()),
        ParamKind::Length => (std, WEAK_REACH_FRACTION * reach_m),
        ParamKind::Angle => (std * reach_m, WEAK_REACH_FRACTION * reach_m),
    };
    moves.is_nan() || moves > limit
}

/// The indices of the error norms beyond [`OUTLIER_K`] robust scales of
/// them: the one rule for naming outliers, in a fit and in a validation.
pub fn outlier_indices(norms: &[f64]) -> Vec<usize> {
    let s = robust_scale(norms);
    (0..norms.len())
        .filter(|&k| s > 0.0 && norms[k] > OUTLIER_K * s)
        .collect()
}

/// Step *outliers*: the measurements whose residual norm exceeds
/// [`OUTLIER_K`] robust scales, largest first.
fn name_outliers(samples: &[Sample], norms: &[f64], weights: &[f64]) -> Vec<Outlier> {
    let mut outliers: Vec<Outlier> = outlier_indices(norms)
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

/// Fits the errors `keys` of `nominal` to `measurements` (each of one of
/// `nominal`'s targets): the active-set fit,
/// inside Huber reweighting when `options.robust`, then the covariance and
/// the outliers at the solution.
pub fn identify(
    nominal: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    // Servo knots move the curves on their grid (the same map); the
    // measurements stay commanded through the nominal curves.
    let start = servo_knots::fit_start(nominal, keys);
    let nominal = &start;
    let data = FitData::new(nominal, option, measurements)?;
    let n = data.samples.len();
    if 3 * n < keys.len() || n == 0 {
        return Err(CalibError::TooFewPoses {
            poses: n,
            rows: 3 * n,
            params: keys.len(),
        });
    }
    check_full_rank(nominal, option, keys, &data.samples)?;
    let rms_before_m = rms(&data.residual_norms(nominal)?);

    let mut params = ParamVector::new(keys.iter().copied())?;
    let mut weights: Vec<f64> = vec![1.0; n];
    let mut tally = Tally::default();
    let rounds = if options.robust {
        options.max_irls_rounds.max(1)
    } else {
        1
    };
    for _ in 0..rounds {
        tally.irls_rounds += 1;
        let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
        active_set(&data, &mut params, &sqrt_w, options, &mut tally)?;
        if !options.robust || tally.exhausted {
            break;
        }
        let new = huber_weights(&data.residual_norms(&params.apply(nominal))?);
        let change = new
            .iter()
            .zip(&weights)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        weights = new;
        if change < 1e-3 {
            break;
        }
    }

    let rig = params.apply(nominal);
    servo_knots::check_curves(&nominal.arm, &rig.arm)?;
    // Every point LM accepted could be evaluated, and the ceiling keeps the
    // deflection converging: failing here is not a question of more poses.
    let residuals = data.residuals(&rig).map_err(|e| {
        data.solver_error(format!(
            "the fitted arm's deflection cannot be evaluated ({e})"
        ))
    })?;
    let norms: Vec<f64> = residuals.iter().map(|r| r.norm()).collect();
    let free: Vec<ParamKey> = params.free().collect();
    let cov = covariance(&data, &rig, &free, &weights, &residuals)?;
    let mut std = cov.std.into_iter();
    let reach = crate::ik::reach_m(&nominal.arm);
    let estimates = params
        .iter()
        .map(|p| {
            let value = p.key.value(&rig);
            let std = if p.fixed { None } else { std.next() };
            Estimate {
                id: p.key,
                error: p.error,
                value,
                std,
                weak: std.is_some_and(|s| is_weak(p.key, value, s, reach)),
            }
        })
        .collect();
    Ok(Identified {
        option,
        rig,
        estimates,
        diagnostics: Diagnostics {
            termination: tally.termination,
            converged: tally.converged,
            exhausted: tally.exhausted,
            evaluations: tally.evaluations,
            active_set_rounds: tally.active_set_rounds,
            failed_steps: tally.failed_steps,
            irls_rounds: tally.irls_rounds,
            at_bound: params.fixed().collect(),
            rms_before_m,
            rms_after_m: rms(&norms),
            sigma_m: cov.sigma_m,
            condition: cov.condition,
            loo_mean_m: cov.loo_mean_m,
        },
        fit_residual: ErrorStats::of(&norms),
        fit_residual_per_target: (0..data.nominal.targets.len())
            .map(|t| {
                let of_t: Vec<f64> = norms
                    .iter()
                    .zip(&data.samples)
                    .filter(|(_, s)| s.target == t)
                    .map(|(e, _)| *e)
                    .collect();
                ErrorStats::of(&of_t)
            })
            .collect(),
        outliers: name_outliers(&data.samples, &norms, &weights),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{key, measure, rigid_nominal, small_samples, true_errors};
    use model::ParamId;

    fn elastic_keys() -> Vec<ParamKey> {
        ["k2", "k3", "k4", "k5", "k0"].map(key).to_vec()
    }

    /// `nominal` with `errors` added to `keys`.
    fn with_errors(nominal: &Rig, keys: &[ParamKey], errors: &[f64]) -> Rig {
        let mut v = ParamVector::new(keys.iter().copied()).unwrap();
        for (k, e) in keys.iter().zip(errors) {
            v.set(*k, *e).unwrap();
        }
        v.apply(nominal)
    }

    fn fit_data<'a>(nominal: &'a Rig, meas: &[Measurement]) -> FitData<'a> {
        FitData::new(nominal, ModelOption::Elastic, meas).unwrap()
    }

    /// Measurements of an arm that sags *upwards* at joint 3: only a negative k3 would fit.
    fn upward_sag(nominal: &Rig) -> Vec<Measurement> {
        let mut true_arm = with_errors(nominal, &elastic_keys(), &[0.1, 0.0, 0.08, 0.03, 0.02]).arm;
        true_arm.joints[2].compliance = -0.05;
        measure(&true_arm, &small_samples(16))
    }

    /// Noise-free data of a true arm that differs only in compliances: the fit
    /// recovers them exactly and the residual vanishes.
    #[test]
    fn recovers_compliances_exactly() {
        let nominal = Rig::from(rigid_nominal());
        let keys = elastic_keys();
        let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
        let meas = measure(
            &with_errors(&nominal, &keys, &truth).arm,
            &small_samples(16),
        );
        let fit = identify(
            &nominal,
            ModelOption::Elastic,
            &keys,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        for (e, t) in fit.estimates.iter().zip(truth) {
            assert!((e.error - t).abs() < 1e-8, "{}: {} vs {t}", e.id, e.error);
        }
        assert!(fit.diagnostics.rms_after_m < 1e-9);
        assert!(fit.fit_residual.max_m < 1e-9);
        assert_eq!(fit.fit_residual.count, meas.len());
        assert!(fit.diagnostics.converged, "{}", fit.diagnostics.termination);
    }

    /// A true compliance of zero with data pulling it below zero stays at the
    /// bound, and the bound is reported.
    #[test]
    fn compliances_never_go_negative() {
        let nominal = Rig::from(rigid_nominal());
        let meas = upward_sag(&nominal);
        let fit = identify(
            &nominal,
            ModelOption::Elastic,
            &elastic_keys(),
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        assert!(
            fit.rig.arm.joints.iter().all(|j| j.compliance >= 0.0)
                && fit.rig.arm.base_compliance >= 0.0
        );
        assert!(
            fit.diagnostics.at_bound.contains(&key("k3")),
            "{:?}",
            fit.estimates
        );
        // KKT: raising any compliance held at zero makes the fit worse.
        let data = fit_data(&nominal, &meas);
        let cost = |arm: &Rig| rms(&data.residual_norms(arm).unwrap());
        for &p in &fit.diagnostics.at_bound {
            let raised = with_errors(&fit.rig, &[p], &[1e-4]);
            assert!(cost(&raised) > cost(&fit.rig), "{p} should stay at zero");
        }
        assert!(fit.estimates[1].std.is_none());
    }

    /// With the round budget spent before the bound is met, the compliance is
    /// fixed at its bound anyway: the estimate and the arm agree, and the arm
    /// is physical.
    #[test]
    fn a_spent_round_budget_still_ends_inside_the_bounds() {
        let nominal = Rig::from(rigid_nominal());
        let one_round = IdentifyOptions {
            robust: false,
            max_active_set_rounds: 1,
            ..Default::default()
        };
        let fit = identify(
            &nominal,
            ModelOption::Elastic,
            &elastic_keys(),
            &upward_sag(&nominal),
            &one_round,
        )
        .unwrap();
        assert_eq!(fit.diagnostics.active_set_rounds, 1);
        assert_eq!(fit.diagnostics.at_bound, [key("k3")]);
        let k3 = fit.estimates[1];
        assert_eq!((k3.id, k3.value, k3.std), (key("k3"), 0.0, None));
        assert_eq!(fit.rig.arm.joints[2].compliance, 0.0);
        for e in &fit.estimates {
            assert_eq!(e.value, e.id.value(&nominal) + e.error, "{}", e.id);
        }
    }

    /// A compliance held at zero while the data want it positive is the one
    /// the active set releases; one that belongs at zero is not.
    #[test]
    fn release_names_the_compliance_whose_multiplier_has_the_wrong_sign() {
        let nominal = Rig::from(rigid_nominal());
        let keys = elastic_keys();
        let meas = measure(
            &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
            &small_samples(16),
        );
        let data = fit_data(&nominal, &meas);
        let sqrt_w = vec![1.0; meas.len()];
        let mut params = ParamVector::new(keys.iter().copied()).unwrap();
        params.fix(key("k4"), 0.0).unwrap();
        let arm = params.apply(&nominal);
        assert_eq!(
            release_candidate(&data, &params, &arm, &sqrt_w),
            Some(key("k4"))
        );
        let sagging_up = upward_sag(&nominal);
        let data = fit_data(&nominal, &sagging_up);
        let mut params = ParamVector::new(keys.iter().copied()).unwrap();
        for (k, e) in keys.iter().zip([0.1, 0.0, 0.08, 0.03, 0.02]) {
            params.set(*k, e).unwrap();
        }
        params.fix(key("k3"), 0.0).unwrap();
        assert_eq!(
            release_candidate(&data, &params, &params.apply(&nominal), &sqrt_w),
            None
        );
    }

    /// The covariance from the scaled SVD equals `s² (JᵀJ)⁻¹` computed directly.
    #[test]
    fn covariance_matches_the_normal_equations() {
        let nominal = Rig::from(rigid_nominal());
        let keys = elastic_keys();
        let mut meas = measure(
            &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
            &small_samples(16),
        );
        for (k, m) in meas.iter_mut().enumerate() {
            m.position.y += 2e-4 * ((k * 5 % 7) as f64 - 3.0);
        }
        let data = fit_data(&nominal, &meas);
        let arm = nominal.clone();
        let residuals = data.residuals(&arm).unwrap();
        let norms: Vec<f64> = residuals.iter().map(|r| r.norm()).collect();
        let weights: Vec<f64> = (0..meas.len()).map(|k| 0.5 + (k % 3) as f64).collect();
        let cov = covariance(&data, &arm, &keys, &weights, &residuals).unwrap();
        let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
        let j = data.weighted_jacobian(&arm, &keys, &sqrt_w).unwrap();
        let rss: f64 = norms.iter().zip(&weights).map(|(e, w)| w * e * e).sum();
        let s2 = rss / (3 * meas.len() - keys.len()) as f64;
        let direct = (j.transpose() * &j).try_inverse().unwrap() * s2;
        assert!((cov.sigma_m - s2.sqrt()).abs() < 1e-15);
        for (c, std) in cov.std.iter().enumerate() {
            let expected = direct[(c, c)].sqrt();
            assert!(
                (std - expected).abs() < 1e-8 * expected,
                "{}: {std} vs {expected}",
                keys[c]
            );
        }
    }

    /// The leave-one-out errors from the hat matrix equal those of refitting a
    /// linear problem without each measurement in turn; a measurement that
    /// alone decides a parameter cannot be predicted.
    #[test]
    fn leave_one_out_equals_refitting_without_each_measurement() {
        let (n, m) = (8, 5);
        let j = DMatrix::from_fn(3 * n, m, |r, c| {
            ((r * 7 + c * 13) % 11) as f64 - 5.0 + 0.1 * c as f64
        });
        let y = DVector::from_fn(3 * n, |r, _| ((r * 5) % 9) as f64 * 0.3 - 1.0);
        let fit = |rows: &[usize]| {
            let a = j.select_rows(rows);
            let b = y.select_rows(rows);
            (a.transpose() * &a).try_inverse().unwrap() * a.transpose() * b
        };
        let all: Vec<usize> = (0..3 * n).collect();
        let beta = fit(&all);
        let r = &y - &j * &beta;
        let residuals: Vec<Vector3<f64>> = (0..n)
            .map(|k| Vector3::new(r[3 * k], r[3 * k + 1], r[3 * k + 2]))
            .collect();
        let u = j.clone().svd(true, false).u.unwrap();
        let refitted: f64 = (0..n)
            .map(|k| {
                let rest: Vec<usize> = all.iter().copied().filter(|i| i / 3 != k).collect();
                let beta_k = fit(&rest);
                (y.rows(3 * k, 3) - j.rows(3 * k, 3) * beta_k).norm()
            })
            .sum::<f64>()
            / n as f64;
        let loo = leave_one_out_mean(&u, &residuals);
        assert!(
            (loo - refitted).abs() < 1e-9 * refitted,
            "{loo} vs {refitted}"
        );
        assert!(loo > residuals.iter().map(|r| r.norm()).sum::<f64>() / n as f64);
        // Five parameters from two measurements (six rows): the first
        // measurement's rows are all the data have for some direction.
        let two = j.rows(0, 6).clone_owned();
        let u = two.svd(true, false).u.unwrap();
        let loo = leave_one_out_mean(&u, &residuals[..2]);
        assert!(loo.is_infinite() || loo > 1e6, "{loo}");
    }

    /// The fit's range of each bounded parameter is the arm's physical one
    /// (`model::bounds`), just inside; a value above it is outside.
    #[test]
    fn fit_ranges_are_the_arms_bounds_just_inside() {
        let nominal = Rig::from(rigid_nominal());
        let meas = measure(&nominal.arm, &small_samples(12));
        let data = fit_data(&nominal, &meas);
        let bounds = nominal.bounds;
        assert_eq!(bounds, model::bounds::Bounds::of(&nominal.arm));
        let k3 = key("k3");
        let (lo, hi) = data.bounds(k3);
        assert_eq!(lo, Some(0.0));
        let ceiling = model::bounds::MAX_SAG_RAD / bounds.torque_nm(3);
        assert!(hi.unwrap() < ceiling && hi.unwrap() > ceiling * (1.0 - 1e-4));
        let (s_lo, s_hi) = data.bounds(ParamKey::Softening { spring: 2 });
        assert!(s_lo.unwrap() > -0.5 / bounds.torque_nm(2) && s_lo.unwrap() < 0.0);
        assert!(s_hi.unwrap() < 1.0 / bounds.torque_nm(2));
        assert_eq!(data.bounds(key("j2.d")), (None, None));
        let mut params = ParamVector::new(elastic_keys()).unwrap();
        params.set(k3, 2.0 * hi.unwrap()).unwrap();
        let arm = params.apply(&nominal);
        assert_eq!(outside_bounds(&data, &params, &arm), [(k3, hi.unwrap())]);
    }

    /// A trial point whose deflection diverges is a failed step with a huge
    /// residual, counted, not the end of the fit.
    #[test]
    fn an_unsolvable_trial_point_is_a_failed_step() {
        let nominal = Rig::from(rigid_nominal());
        let keys = elastic_keys();
        let meas = measure(
            &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
            &small_samples(8),
        );
        let data = fit_data(&nominal, &meas);
        let params = ParamVector::new(keys.iter().copied()).unwrap();
        let sqrt_w = vec![1.0; meas.len()];
        let mut problem = Problem {
            data: &data,
            params: &params,
            free: keys.clone(),
            sqrt_w: &sqrt_w,
            x: DVector::zeros(keys.len()),
            failed_entry: 7.0,
            failed: std::cell::Cell::new(0),
        };
        assert!(problem.residuals().unwrap().iter().all(|r| *r != 7.0));
        problem.set_params(&DVector::from_element(keys.len(), 500.0));
        assert!(data.residual_norms(&problem.arm()).is_err());
        let r = problem.residuals().unwrap();
        assert!(r.len() == 3 * meas.len() && r.iter().all(|v| *v == 7.0));
        assert_eq!(problem.failed.get(), 1);
    }

    #[test]
    fn huber_weights_down_weight_only_beyond_the_threshold() {
        // Median 1.5382 makes the robust scale 1, so the threshold is HUBER_K.
        let norms = [0.0, 1.0, 1.2, 1.5382, 2.9, 6.0, 30.0];
        let w = huber_weights(&norms);
        assert_eq!(w[..5], [1.0; 5]);
        assert!((w[5] - HUBER_K / 6.0).abs() < 1e-12);
        assert!((w[6] - HUBER_K / 30.0).abs() < 1e-12);
    }

    #[test]
    fn outliers_are_named_largest_first() {
        let samples = small_samples(7);
        let norms = [1.0, 1.5382, 9.0, 2.0, 0.5, 4.4, 7.0];
        let weights = [1.0, 1.0, 0.3, 1.0, 1.0, 1.0, 0.4];
        let o = name_outliers(&samples, &norms, &weights);
        let named: Vec<(u32, f64)> = o.iter().map(|o| (o.pose, o.weight)).collect();
        assert_eq!(named, [(2, 0.3), (6, 0.4)]);
        assert_eq!(o[0].load_kg, samples[2].load_kg);
        assert!(name_outliers(&samples, &[0.0; 7], &weights).is_empty());
    }

    /// One corrupted measurement is named, and the robust fit is not pulled by it.
    #[test]
    fn robust_fit_names_and_ignores_an_outlier() {
        let nominal = Rig::from(rigid_nominal());
        let keys = elastic_keys();
        let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
        let samples = small_samples(24);
        let mut meas = measure(&with_errors(&nominal, &keys, &truth).arm, &samples);
        // Small noise so the robust scale is not zero, then one gross error.
        for (k, m) in meas.iter_mut().enumerate() {
            m.position.x += 1e-4 * ((k * 7 % 5) as f64 - 2.0);
        }
        meas[5].position.z += 0.02;
        // Robust is the default.
        let fit = identify(
            &nominal,
            ModelOption::Elastic,
            &keys,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        assert_eq!(fit.outliers.first().map(|o| o.pose), Some(meas[5].pose.id));
        assert!(fit.outliers[0].weight < 0.1);
        let squared = IdentifyOptions {
            robust: false,
            ..Default::default()
        };
        let plain = identify(&nominal, ModelOption::Elastic, &keys, &meas, &squared).unwrap();
        assert_eq!(plain.outliers[0].weight, 1.0);
        let err = |f: &Identified| {
            f.estimates
                .iter()
                .zip(truth)
                .map(|(e, t)| (e.error - t).abs())
                .fold(0.0, f64::max)
        };
        assert!(
            err(&fit) < 0.5 * err(&plain),
            "robust {} plain {}",
            err(&fit),
            err(&plain)
        );
    }

    #[test]
    fn too_few_and_rank_deficient_sets_are_refused() {
        let nominal = Rig::from(rigid_nominal());
        let all: Vec<ParamKey> = ParamId::all().map(ParamKey::Arm).collect();
        let meas = measure(
            &with_errors(&nominal, &all, &true_errors(1)).arm,
            &small_samples(20),
        );
        let opts = IdentifyOptions::default();
        assert!(matches!(
            identify(
                &nominal,
                ModelOption::ElastoKinematic,
                &all,
                &meas[..5],
                &opts
            ),
            Err(CalibError::TooFewPoses { params: 43, .. })
        ));
        // All 43 include the tool rotation, which no position can reveal.
        let err = identify(&nominal, ModelOption::ElastoKinematic, &all, &meas, &opts).unwrap_err();
        assert!(matches!(err, CalibError::RankDeficient { .. }), "{err}");
    }
}
