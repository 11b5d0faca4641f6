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
//! **Robust fit, the default (Huber's cost, minimised directly).** A
//! measurement's residual norm `e` counts as `e²` up to a threshold `c` and
//! as `2ce − c²` beyond (it grows linearly, so one gross error cannot pull
//! the fit). The threshold is [`HUBER_K`] robust scales, the scale
//! `s = median(e) / 1.5382` (the median of the norm of a 3D Gaussian with
//! per-axis deviation σ is 1.5382 σ; 1.1774 for a pixel's 2D). LM minimises
//! the cost itself: a block beyond the threshold is shortened to the root of
//! its cost, its Jacobian rows by the slope of that shortening
//! (`robust::Weighting`). Each round fits with the threshold of the
//! residuals it starts from (a fit from the nominal arm starts with its
//! large ones, nearly least squares; a refit from an estimate with the
//! noise), and the rounds end when the threshold moves by less than
//! [`SIGMA_SETTLED`]. At the end each measurement's weight is Huber's,
//! 1 up to the threshold and `c / e` beyond: the weights the covariance and
//! the outliers use, and at which the weighted least-squares gradient
//! vanishes as the cost's does. (Reweighted least squares, one LM run per
//! set of weights, reaches the same point, but its weights settle about
//! 0.7× a round: twelve rounds left a camera fit short of it.) Whether
//! robust or not, measurements whose residual exceeds [`OUTLIER_K`]`·s` are
//! named as outliers (a clean 3D Gaussian residual exceeds 4.5 σ with
//! probability 5e-4).
//!
//! **When a run stops.** LM stops when a step lowers the cost, or moves the
//! parameters, by less than [`LM_TOLERANCE`] of it: within that the cost
//! moves no parameter by a hundredth of its deviation (`ΔC/C = 1e-8` over
//! 5,000 pixel rows is `5e-5 σ²`), and the model's own evaluation wanders by
//! about 1e-9 of the cost near a camera fit's optimum. The crate's default
//! (30 machine epsilons) made the runs crawl along that noise.

use levenberg_marquardt::{LevenbergMarquardt, TerminationReason};
use nalgebra::{DVector, Vector3};

use crate::calib::analysis::identifiability::check_full_rank;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::{ParamKey, ParamVector};
use crate::calib::parameters::prior::Prior;
use crate::calib::parameters::servo_knots;
use crate::calib::{CalibError, ModelOption, Rig};
use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::ErrorStats;

mod active_set;
mod compressed;
mod covariance;
pub(crate) mod problem;
mod result;
mod robust;

use active_set::active_set;
use covariance::{covariance, is_weak, noise_sigma};
use problem::{FitData, Problem, Tally, stack};
pub use result::{Diagnostics, Estimate, FitPoint, Identified, IdentifyOptions, Outlier};
pub use robust::{HUBER_K, OUTLIER_K, outlier_indices};
use robust::{Weighting, huber_threshold, huber_weights, name_outliers};

/// A free length or angle is weak when one standard deviation of it moves the
/// tool point by more than this fraction of the arm's reach (1 %: 4 mm on
/// the bundled arm, 14 mm on a UR10-sized one).
pub const WEAK_REACH_FRACTION: f64 = 1e-2;
/// A trial point whose deflection cannot be solved scores this many times the
/// residual norm its LM run started from: far beyond the tenfold that makes
/// LM count a step as failed.
pub const FAILED_STEP_FACTOR: f64 = 1e6;
/// Relative tolerance of LM's tests on the cost and the step (module docs).
pub const LM_TOLERANCE: f64 = 1e-8;
/// The prior's noise scale and Huber's threshold are settled when a round
/// changes them by less than this fraction.
pub const SIGMA_SETTLED: f64 = 0.01;

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Step *fit*: one Levenberg–Marquardt run over the free parameters of
/// `params`, residuals weighted as `weighting` says; leaves the solution in `params`.
fn fit(
    data: &FitData,
    params: &mut ParamVector,
    weighting: Weighting,
    sigma: f64,
    patience: usize,
    tally: &mut Tally,
) -> Result<(), CalibError> {
    let start = data
        .weighted_residuals(&params.apply(data.nominal), weighting)
        .ok_or_else(|| {
            data.solver_error("the model cannot be evaluated where the fit starts".into())
        })?;
    let rows = start.len().max(1) as f64;
    let problem = Problem {
        data,
        params,
        free: params.free().collect(),
        weighting,
        sigma,
        x: DVector::from_vec(params.free_errors()),
        failed_entry: FAILED_STEP_FACTOR * start.norm().max(f64::MIN_POSITIVE) / rows.sqrt(),
        failed: std::cell::Cell::new(0),
    };
    let (problem, report) = LevenbergMarquardt::new()
        .with_ftol(LM_TOLERANCE)
        .with_xtol(LM_TOLERANCE)
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
    let coordinates = data.nominal.measured_axes() * n;
    if coordinates < unheld.len() || n == 0 {
        return Err(CalibError::TooFewPoses {
            poses: n,
            rows: coordinates,
            params: unheld.len(),
        });
    }
    if !unheld.is_empty() {
        check_full_rank(nominal, option, &unheld, &data.samples)?;
    }
    let before_m = data.residual_norms(nominal)?;
    let rms_before_m = rms(&before_m);

    let mut params = ParamVector::new(keys.iter().copied())?;
    let ones: Vec<f64> = vec![1.0; n];
    let mut weights = ones.clone();
    // Huber's threshold, from the residuals the round starts from.
    let axes = data.nominal.measured_axes();
    let mut threshold = options
        .robust
        .then(|| huber_threshold(&before_m, axes))
        .flatten();
    let mut tally = Tally::default();
    // The prior weighs against the noise, which the residual tells: from
    // the residual the fit starts with (the prior at its strongest), each
    // round fits with the last estimate (module docs).
    let mut sigma = rms_before_m / (axes as f64).sqrt();
    let rounds = if options.robust || data.prior.is_some() {
        options.max_irls_rounds.max(1)
    } else {
        1
    };
    for _ in 0..rounds {
        tally.irls_rounds += 1;
        let weighting = match threshold {
            Some(c) => Weighting::Huber(c),
            None => Weighting::Scaled(&ones),
        };
        active_set(&data, &mut params, weighting, sigma, options, &mut tally)?;
        if tally.exhausted {
            break;
        }
        let arm = params.apply(nominal);
        let mut settled = true;
        if data.prior.is_some() {
            let residuals = data.residuals(&arm)?;
            let free: Vec<ParamKey> = params.free().collect();
            let prior = data.prior_jacobian(&params, false, sigma);
            let new = noise_sigma(&data, &arm, &free, &weights, &residuals, prior.as_ref())?;
            settled &= (new - sigma).abs() <= SIGMA_SETTLED * sigma;
            sigma = new;
        }
        if options.robust {
            let norms = data.residual_norms(&arm)?;
            let new = huber_threshold(&norms, axes);
            settled &= match (threshold, new) {
                (Some(old), Some(new)) => (new - old).abs() <= SIGMA_SETTLED * old,
                (None, None) => true,
                _ => false,
            };
            threshold = new;
            weights = huber_weights(&norms, axes);
        }
        if settled {
            break;
        }
    }

    let mut rig = params.apply(nominal);
    // The arm the files get holds the gravity its fit was evaluated with.
    rig.arm = rig.placed_arm();
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
        options: *options,
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
        outliers: name_outliers(
            &data.samples,
            &norms,
            &weights,
            data.nominal.measured_axes(),
        ),
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
    let axes = data.nominal.measured_axes() as f64;
    let rows = axes * data.samples.len() as f64;
    let rss: f64 = residuals
        .iter()
        .zip(weights)
        .map(|(e, w)| w * e.norm_squared())
        .sum();
    let errors: Vec<f64> = params.iter().map(|p| p.error).collect();
    let log_weights: f64 = weights.iter().map(|w| axes * w.ln()).sum();
    let likelihood = -0.5 * rss / (sigma * sigma) - rows * sigma.ln() + 0.5 * log_weights;
    let log_prior = -prior.cost(&errors) + prior.log_det();
    // The posterior precision is (JᵀJ + σ² AᵀA) / σ².
    let log_det_posterior_precision = log_det_normal - 2.0 * keys.len() as f64 * sigma.ln();
    Ok(likelihood + log_prior - 0.5 * log_det_posterior_precision)
}

#[cfg(test)]
mod tests;
