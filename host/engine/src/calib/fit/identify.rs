//! Identification: the error parameters that make the model's measured points
//! match the measurements, by Levenberg–Marquardt (the `levenberg-marquardt`
//! crate, MINPACK's algorithm on nalgebra), in named steps: *fit* (one LM run
//! over the free parameters of a [`ParamVector`]), *active set* (bounds),
//! *reweight* (Huber and the prior's noise), *covariance* and *outliers*.
//!
//! **Under a prior** ([`IdentifyOptions::prior`], ours): the fit is the
//! most probable one given the measurements and what the arm's effects
//! typically are before any is measured (`calib::parameters::prior`: one
//! standard deviation per correction, the servo curves smooth). It
//! minimises `Σ w_k |r_k|² + σ² |A (e − e₀)|²`, the measurements' weighted
//! residuals and the prior's rows (`A (e − e₀)`, the corrections `e` from
//! the prior's centre in standard deviations) scaled by the noise `σ` of a
//! coordinate, which weighs the one against the other; the rows join LM's
//! residuals and Jacobian as further measurements would. The noise is not
//! known beforehand: it is estimated from the residual as
//! `σ² = Σ w_k |r_k|² / (3n − γ)`, `γ` the number of parameters the
//! measurements (not the prior) determine (the trace of the hat matrix over
//! their rows), and each reweighting round fits with the last estimate,
//! from the residual the fit starts with (the prior at its strongest) until
//! it changes by less than [`SIGMA_SETTLED`]. Where the poses determine a
//! parameter well its prior weighs nothing beside them and the fit is the
//! least-squares one; where they do not, the prior holds it near its
//! physical size instead of letting it run off with the noise. The keys the
//! prior holds need no rank of their own: only the others must be
//! determined by the poses. [`identify_scored`] also gives the evidence
//! (the probability of the measurements under the prior, Laplace's
//! approximation), by which `calib::grow` chooses how smooth the servo
//! curves are.
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
//! the solution and the residual: `cov = s² (JᵀJ)⁻¹` with `s² = RSS / (3n − m)`;
//! under a prior, the posterior covariance `σ² (JᵀJ + σ² AᵀA)⁻¹` with `γ`
//! for `m` (a parameter the poses do not determine keeps its prior's
//! deviation, never an infinite or a vanishing one).
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
//! servo curves' knot spacing is chosen by it (`calib::knot_choice`). Under
//! a prior `H` is the regularised fit's (exact for it too: a measurement
//! left out, the prior still holds).
//!
//! **Robust fit, the default (Huber, by iteratively reweighted least squares).** Each
//! measurement's weight depends on the norm `e` of its 3D residual relative to
//! a robust scale `s = median(e) / 1.5382` (the median of the norm of a 3D
//! Gaussian with per-axis deviation σ is 1.5382 σ): weight 1 up to
//! [`HUBER_K`]`·s`, `HUBER_K·s / e` beyond. Whether robust or not, measurements
//! whose residual exceeds [`OUTLIER_K`]`·s` are named as outliers (a clean 3D
//! Gaussian residual exceeds 4.5 σ with probability 5e-4).

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::allocator::Reallocator;
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, DefaultAllocator, Dim, Dyn, OMatrix, Vector3};

use crate::calib::analysis::identifiability::check_full_rank;
use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::{ParamKey, ParamVector};
use crate::calib::parameters::prior::{self, Prior};
use crate::calib::parameters::servo_knots;
use crate::calib::{CalibError, ModelOption, Rig, Sample};
use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::ErrorStats;

mod covariance;

use covariance::{covariance, is_weak};

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
/// The prior's noise scale is settled when a round changes it by less than
/// this fraction.
pub const SIGMA_SETTLED: f64 = 0.01;

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
    /// Fit the most probable corrections under the prior of the keys that
    /// have one (`calib::parameters::prior`) instead of plain least squares
    /// (see the module docs); a fit of keys without one is the same either
    /// way. `calib::grow` keeps it for ours only.
    pub prior: bool,
    /// How far apart, degrees, two angles of a servo curve have errors
    /// correlated by `e^-½` under the prior
    /// (`calib::parameters::prior::SERVO_CORRELATION_DEG`, which
    /// `calib::grow` chooses among).
    pub servo_correlation_deg: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            robust: true,
            max_active_set_rounds: 10,
            max_irls_rounds: 12,
            refresh: true,
            patience: 50,
            prior: true,
            servo_correlation_deg: prior::SERVO_CORRELATION_DEG,
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
    /// Residual standard deviation per coordinate, `sqrt(RSS / (3n − m))`,
    /// m; under a prior `m` counts what the measurements determine (the
    /// noise the prior was weighed against, module docs).
    pub sigma_m: f64,
    /// Condition number of the column-scaled Jacobian at the solution.
    pub condition: f64,
    /// Mean 3D error at each fitted measurement of the fit without it
    /// (leave-one-out, from the linearised fit: see the module docs), m;
    /// infinite when a measurement alone decides a parameter.
    pub loo_mean_m: f64,
    /// Each fitted measurement's leave-one-out error, in the measurements'
    /// order, m: what [`Diagnostics::loo_mean_m`] is the mean of, for
    /// comparing two fits of the same measurements pair by pair.
    pub loo_errors_m: Vec<f64>,
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
    /// Each fitted measurement, in the measurements' order (the order of
    /// [`Diagnostics::loo_errors_m`]): where it was measured and how far the
    /// arm was from it before and after the fit.
    pub per_measurement: Vec<FitPoint>,
    /// The covariance of the free parameters' errors at the solution, SI
    /// units: the estimates with a deviation, in the estimates' order, in
    /// the frame the fit ran in. The deviations are the roots of its diagonal.
    pub covariance: DMatrix<f64>,
}

/// One fitted measurement and the arm's distance from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitPoint {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// Index of the measured target in the rig's targets.
    pub target: usize,
    /// The measured point, in the frame the fit ran in, m.
    pub measured_m: Vector3<f64>,
    /// 3D error of the arm the fit started from (the nominal arm, placed), m.
    pub before_m: f64,
    /// 3D error of the fitted arm, m.
    pub after_m: f64,
}

/// The measurements of one fit, as the solver sees them.
struct FitData<'a> {
    nominal: &'a Rig,
    option: ModelOption,
    samples: Vec<Sample>,
    measured: Vec<Vector3<f64>>,
    /// The prior on the corrections of the keys, if the fit has one.
    prior: Option<Prior>,
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
            prior: None,
        })
    }

    /// The prior's rows at the corrections of `params` with the free ones
    /// taken from `free`, each times `sigma` (the measurements' noise, the
    /// scale of the weighted residuals); `None` without a prior.
    fn prior_residuals(
        &self,
        params: &ParamVector,
        free: &[f64],
        sigma: f64,
    ) -> Option<DVector<f64>> {
        let prior = self.prior.as_ref()?;
        let mut trial = free.iter();
        let errors: Vec<f64> = params
            .iter()
            .map(|p| match p.fixed {
                true => p.error,
                false => trial.next().copied().unwrap_or(p.error),
            })
            .collect();
        Some(prior.residuals(&errors) * sigma)
    }

    /// The Jacobian of [`FitData::prior_residuals`] with respect to the
    /// `fixed` or the free parameters of `params`; `None` without a prior.
    fn prior_jacobian(
        &self,
        params: &ParamVector,
        fixed: bool,
        sigma: f64,
    ) -> Option<DMatrix<f64>> {
        let prior = self.prior.as_ref()?;
        let columns: Vec<usize> = params
            .iter()
            .enumerate()
            .filter(|(_, p)| p.fixed == fixed)
            .map(|(c, _)| c)
            .collect();
        Some(prior.columns(&columns) * sigma)
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
    /// The noise the prior's rows are scaled by, m.
    sigma: f64,
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
        let prior = self
            .data
            .prior_residuals(self.params, self.x.as_slice(), self.sigma);
        match self.data.weighted_residuals(&self.arm(), self.sqrt_w) {
            Some(r) => Some(stack(r, prior)),
            None => {
                // A failed step, not the end of the fit (module docs).
                self.failed.set(self.failed.get() + 1);
                let rows = 3 * self.data.samples.len() + prior.map_or(0, |p| p.len());
                Some(DVector::from_element(rows, self.failed_entry))
            }
        }
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let j = self
            .data
            .weighted_jacobian(&self.arm(), &self.free, self.sqrt_w)
            .ok()?;
        Some(stack(
            j,
            self.data.prior_jacobian(self.params, false, self.sigma),
        ))
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

/// `top` (the measurements' residuals, or their Jacobian) with the prior's
/// rows below it, if any.
fn stack<C: Dim>(
    top: OMatrix<f64, Dyn, C>,
    prior: Option<OMatrix<f64, Dyn, C>>,
) -> OMatrix<f64, Dyn, C>
where
    DefaultAllocator: Reallocator<f64, Dyn, C, Dyn, C>,
{
    match prior {
        Some(p) => {
            let rows = top.nrows();
            let mut out = top.resize_vertically(rows + p.nrows(), 0.0);
            out.rows_mut(rows, p.nrows()).copy_from(&p);
            out
        }
        None => top,
    }
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
    sigma: f64,
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
        sigma,
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
    sigma: f64,
) -> Option<ParamKey> {
    let fixed: Vec<ParamKey> = params.fixed().collect();
    if fixed.is_empty() {
        return None;
    }
    // The prior's rows count in the cost like the measurements'.
    let r = stack(
        data.weighted_residuals(arm, sqrt_w)?,
        data.prior_residuals(params, &params.free_errors(), sigma),
    );
    let jf = stack(
        data.weighted_jacobian(arm, &fixed, sqrt_w).ok()?,
        data.prior_jacobian(params, true, sigma),
    );
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
    sigma: f64,
    options: &IdentifyOptions,
    tally: &mut Tally,
) -> Result<(), CalibError> {
    loop {
        tally.active_set_rounds += 1;
        fit(data, params, sqrt_w, sigma, options.patience, tally)?;
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
        match release_candidate(data, params, &arm, sqrt_w, sigma) {
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
    identify_about(nominal, nominal, option, keys, measurements, options)
}

/// [`identify`] from `nominal` with the prior (when `options.prior`)
/// centred at `origin`: a refit from an estimate (`calib::refresh`) starts
/// there and keeps the prior of the arm the calibration started from.
pub fn identify_about(
    nominal: &Rig,
    origin: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    identify_scored(nominal, origin, option, keys, measurements, options).map(|(fit, _)| fit)
}

/// [`identify_about`], and with a prior the log of the evidence the
/// measurements give its model (module docs): how probable they are under
/// the prior, the parameters integrated out (Laplace's approximation at
/// the solution, the noise at its estimate). It compares priors of one set
/// of keys; the parameters without a prior contribute a constant only
/// when that set is the same.
pub fn identify_scored(
    nominal: &Rig,
    origin: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<(Identified, Option<f64>), CalibError> {
    // Servo knots move the curves on their grid (the same map); the
    // measurements stay commanded through the nominal curves.
    let start = servo_knots::fit_start(nominal, keys);
    let nominal = &start;
    let mut data = FitData::new(nominal, option, measurements)?;
    if options.prior {
        data.prior = Prior::new(
            nominal,
            &servo_knots::fit_start(origin, keys),
            keys,
            options.servo_correlation_deg,
        );
    }
    let n = data.samples.len();
    // What the prior holds is determined whatever the poses; the rest must
    // be determined by them.
    let unheld: Vec<ParamKey> = keys
        .iter()
        .enumerate()
        .filter(|(c, _)| !data.prior.as_ref().is_some_and(|p| p.holds(*c)))
        .map(|(_, k)| *k)
        .collect();
    if 3 * n < unheld.len() || n == 0 {
        return Err(CalibError::TooFewPoses {
            poses: n,
            rows: 3 * n,
            params: unheld.len(),
        });
    }
    if !unheld.is_empty() {
        check_full_rank(nominal, option, &unheld, &data.samples)?;
    }
    let before_m = data.residual_norms(nominal)?;
    let rms_before_m = rms(&before_m);

    let mut params = ParamVector::new(keys.iter().copied())?;
    let mut weights: Vec<f64> = vec![1.0; n];
    let mut tally = Tally::default();
    // The prior weighs against the noise, which the residual tells: from
    // the residual the fit starts with (the prior at its strongest), each
    // round fits with the last estimate (module docs).
    let mut sigma = rms_before_m / 3f64.sqrt();
    let rounds = if options.robust || data.prior.is_some() {
        options.max_irls_rounds.max(1)
    } else {
        1
    };
    for _ in 0..rounds {
        tally.irls_rounds += 1;
        let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
        active_set(&data, &mut params, &sqrt_w, sigma, options, &mut tally)?;
        if tally.exhausted {
            break;
        }
        let arm = params.apply(nominal);
        let mut settled = true;
        if data.prior.is_some() {
            let residuals = data.residuals(&arm)?;
            let free: Vec<ParamKey> = params.free().collect();
            let prior = data.prior_jacobian(&params, false, sigma);
            let new = covariance(&data, &arm, &free, &weights, &residuals, prior.as_ref())?.sigma_m;
            settled &= (new - sigma).abs() <= SIGMA_SETTLED * sigma;
            sigma = new;
        }
        if options.robust {
            let new = huber_weights(&data.residual_norms(&arm)?);
            let change = new
                .iter()
                .zip(&weights)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            weights = new;
            settled &= change < 1e-3;
        }
        if settled {
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
    let prior = data.prior_jacobian(&params, false, sigma);
    let cov = covariance(&data, &rig, &free, &weights, &residuals, prior.as_ref())?;
    let evidence = match &data.prior {
        Some(p) => Some(log_evidence(
            &data,
            &rig,
            &params,
            p,
            &weights,
            &residuals,
            cov.sigma_m,
        )?),
        None => None,
    };
    let mut std = cov.std.iter().copied();
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
    let fit = Identified {
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
            loo_errors_m: cov.loo_errors_m,
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
        per_measurement: data
            .samples
            .iter()
            .zip(&data.measured)
            .zip(before_m.iter().zip(&norms))
            .map(|((s, m), (b, a))| FitPoint {
                pose: s.id,
                load_kg: s.load_kg,
                target: s.target,
                measured_m: *m,
                before_m: *b,
                after_m: *a,
            })
            .collect(),
        covariance: cov.matrix,
    };
    Ok((fit, evidence))
}

/// The log evidence of a fit under `prior` (Laplace's approximation): the
/// log likelihood of the measurements at the solution `params` (residuals
/// `residuals`, weights `weights`, noise `sigma`), the log prior density
/// there, and half the log determinant of the posterior covariance of every
/// key, those held at a bound included (as if free: their curvature says
/// how much of the prior's volume the measurements leave), up to terms in
/// `2π` that depend on the keys only.
fn log_evidence(
    data: &FitData,
    rig: &Rig,
    params: &ParamVector,
    prior: &Prior,
    weights: &[f64],
    residuals: &[Vector3<f64>],
    sigma: f64,
) -> Result<f64, CalibError> {
    let sigma = sigma.max(f64::MIN_POSITIVE);
    let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let keys: Vec<ParamKey> = params.iter().map(|p| p.key).collect();
    let all: Vec<usize> = (0..keys.len()).collect();
    let j = stack(
        data.weighted_jacobian(rig, &keys, &sqrt_w)?,
        Some(prior.columns(&all) * sigma),
    );
    // log det(JᵀJ + σ² AᵀA) from the column-scaled singular values.
    let scale = ColumnScale::from_jacobian(&j, data.samples.len());
    let log_det_normal = 2.0
        * scale
            .apply(&j)
            .singular_values()
            .iter()
            .map(|s| s.ln())
            .sum::<f64>()
        - 2.0 * scale.factors.iter().map(|f| f.ln()).sum::<f64>();
    let rows = 3.0 * data.samples.len() as f64;
    let rss: f64 = residuals
        .iter()
        .zip(weights)
        .map(|(e, w)| w * e.norm_squared())
        .sum();
    let errors: Vec<f64> = params.iter().map(|p| p.error).collect();
    let log_weights: f64 = weights.iter().map(|w| 3.0 * w.ln()).sum();
    let likelihood = -0.5 * rss / (sigma * sigma) - rows * sigma.ln() + 0.5 * log_weights;
    let log_prior = -prior.cost(&errors) + prior.log_det();
    // The posterior precision is (JᵀJ + σ² AᵀA) / σ².
    let log_det_posterior_precision = log_det_normal - 2.0 * keys.len() as f64 * sigma.ln();
    Ok(likelihood + log_prior - 0.5 * log_det_posterior_precision)
}

#[cfg(test)]
mod tests;
