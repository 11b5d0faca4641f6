//! Step *active set*: the bounded parameters fixed at the bound they cross
//! and released when the gradient would move them back inside (module docs
//! of `identify`).

use super::fit;
use super::problem::{FitData, Tally, stack};
use super::result::IdentifyOptions;
use super::robust::Weighting;
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::{ParamKey, ParamVector};
use crate::calib::{CalibError, Rig};

/// The free parameters whose value in `arm` lies outside their bounds, with
/// the bound they crossed.
pub(super) fn outside_bounds(
    data: &FitData,
    params: &ParamVector,
    arm: &Rig,
) -> Vec<(ParamKey, f64)> {
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
pub(super) fn fix_at_bound(
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
pub(super) fn release_candidate(
    data: &FitData,
    params: &ParamVector,
    arm: &Rig,
    weighting: Weighting,
    sigma: f64,
) -> Option<ParamKey> {
    let fixed: Vec<ParamKey> = params.fixed().collect();
    if fixed.is_empty() {
        return None;
    }
    // The prior's rows count in the cost like the measurements'.
    let (r, jf) = data.weighted_with_jacobian(arm, &fixed, weighting).ok()?;
    let r = stack(
        r,
        data.prior_residuals(params, &params.free_errors(), sigma),
    );
    let jf = stack(jf, data.prior_jacobian(params, true, sigma));
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
pub(super) fn active_set(
    data: &FitData,
    params: &mut ParamVector,
    weighting: Weighting,
    sigma: f64,
    options: &IdentifyOptions,
    tally: &mut Tally,
) -> Result<(), CalibError> {
    loop {
        tally.active_set_rounds += 1;
        fit(data, params, weighting, sigma, options.patience, tally)?;
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
        match release_candidate(data, params, &arm, weighting, sigma) {
            Some(key) => params.release(key)?,
            None => return Ok(()),
        }
    }
}
