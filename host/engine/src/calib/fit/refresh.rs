//! Refresh: the rank analysis run again at the estimate, and the parameters
//! it finds independent there fitted too.
//!
//! The paper's reduction analyses the Jacobian once, at the nominal arm, and
//! holds every parameter it removes at its nominal value. Some of them are
//! confounded only at that point: `j3.d` with `j2.d` while joints 2 and 3
//! are exactly parallel (a twist error makes them not), `j1.d` and
//! `j1.theta` with the base's height and yaw while the base is rigid and
//! level (the base's tilt and compliance make it neither), `k1` while
//! gravity has no torque about joint 1. On the true arm these parameters
//! move the measured point in directions the kept ones cannot reproduce, so
//! holding them leaves a structural error (0.19 mm on the bundled arm
//! simulated without noise or unmodelled effects). After the fit, the
//! analysis is repeated at the estimate over the fitted poses, with the
//! kept parameters first; every other candidate whose column is independent
//! of theirs by more than [`REFRESH_TOLERANCE`] joins, and the fit goes on
//! from the estimate with the larger set.
//!
//! Our option's spring softenings are proposed here only
//! (`calib::option::refresh_candidates`): a softening's effect is its
//! spring's compliance times `|tau| tau`, zero on an arm file's rigid
//! springs and gone wherever the fit takes the compliance to zero, so only
//! at the estimate can the poses be seen to determine it.
//!
//! Independent is not the same as determined: away from the nominal point
//! `j1.d` differs from the base's height only by the lever of the base's
//! elastic tilt (about 1 %), so with millimetres of noise and unmodelled
//! error the two would wander off together by centimetres. A joining
//! parameter whose standard deviation in the larger fit exceeds a typical
//! error of its kind (1 mm, 1 mrad, 0.01 rad/Nm on the bundled arm: what
//! the kept parameters are determined to; `TypicalErrors`) is left out again
//! and the larger fit repeated without it; one whose deviation, predicted
//! from the Jacobian at the estimate and the residual the fit left, is a
//! hundred times that stays out of the larger fit from the start (such fits
//! converge slowly: with them the demo and its 20 random sets took 148 s,
//! with this bar 11 s, with no refresh 4 s).
//!
//! That residual still holds the structural error the joining parameters
//! remove, so a parameter can look hopeless beside it and not beside what
//! is left once the others joined. So the refresh is repeated from the
//! larger fit, up to [`MAX_REFRESH_ROUNDS`] times, until no parameter
//! joins: noise-free data of the bundled arm then leave 1e-16 m held out
//! (`lrmcal demo --model-only`; one round left 0.0006 mm, the single
//! reduction 0.19 mm). With noise the residual hardly drops and the second
//! round adds nothing (the default demo's figures and time are unchanged).

use crate::calib::analysis::identifiability::{TypicalErrors, joining};
use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::fit::identify::{Estimate, Identified, IdentifyOptions, identify_about};
use crate::calib::parameters::option::{candidates, refresh_candidates};
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::prior::Prior;
use crate::calib::parameters::servo_knots::{self, KnotSpacing};
use crate::calib::{CalibError, ModelOption, Rig};
use lrmcal_core::dataset::Measurement;

/// Sine of the smallest angle between a removed parameter's column at the
/// estimate and the span of the fitted ones above which it joins the fit:
/// well above the rounding noise of the Jacobian (a column the kept ones
/// reproduce exactly, like `j6.theta` with the tool's offsets, is left
/// with 1e-16), well below what a real dependence on the estimate
/// gives (a twist or tilt of a few mrad gives ~1e-3).
pub const REFRESH_TOLERANCE: f64 = 1e-4;

/// Refreshes at most: each judges the joining parameters with the residual
/// the previous larger fit left.
pub const MAX_REFRESH_ROUNDS: usize = 3;

/// The evaluation budget of a larger fit ([`IdentifyOptions::patience`]):
/// where the poses determine what joins, it converges within a tenth of it.
pub const TRIAL_PATIENCE: usize = 10;

/// A joining parameter whose predicted deviation exceeds this many typical
/// errors of its kind stays out of the larger fit: the residual would have
/// to shrink as many times for it to be determined.
pub const HOPELESS_FACTOR: f64 = 100.0;

/// The refresh described in the module docs, from `first`, the fit of
/// `keys` to `measurements` from `nominal`. The result's estimates are
/// corrections of `nominal`, the added parameters among them.
pub fn refreshed(
    nominal: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    first: Identified,
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    let mut fit = first;
    let typical = TypicalErrors::of_arm(&nominal.arm);
    let mut fitted = keys.to_vec();
    // Joined once and found undetermined: not proposed again.
    let mut undetermined: Vec<ParamKey> = Vec::new();
    for _ in 0..MAX_REFRESH_ROUNDS {
        let prior = options
            .prior
            .then_some((nominal, options.servo_correlation_deg));
        let added: Vec<ParamKey> =
            joining_at(&fit, prior, option, &fitted, measurements, &typical)?
                .into_iter()
                .filter(|k| !undetermined.contains(k))
                .collect();
        if added.is_empty() {
            break;
        }
        let Some(larger) = fit_from(
            nominal,
            &fit,
            option,
            &fitted,
            &added,
            measurements,
            options,
        )?
        else {
            break;
        };
        // Joined but not determined: left out, and the larger fit repeated without them.
        let (determined, not): (Vec<ParamKey>, Vec<ParamKey>) = added.iter().partition(|k| {
            larger
                .estimates
                .iter()
                .find(|e| e.id == **k)
                .and_then(|e| e.std)
                .is_none_or(|s| s <= typical.of(**k))
        });
        undetermined.extend(not);
        if determined.is_empty() {
            break;
        }
        let larger = if determined.len() == added.len() {
            larger
        } else {
            match fit_from(
                nominal,
                &fit,
                option,
                &fitted,
                &determined,
                measurements,
                options,
            )? {
                Some(larger) => larger,
                None => break,
            }
        };
        fit = combine(nominal, &fit, larger);
        fitted.extend(determined);
    }
    Ok(fit)
}

/// The fit of `keys` and `added` from `first`'s estimate (its rig is the
/// nominal of this fit; a prior stays centred at `nominal`, the arm the
/// calibration started from); `None` when the poses do not determine them all
/// together, and the first fit stands. A larger fit that has not converged
/// within [`TRIAL_PATIENCE`] does not determine them either: such fits crawl
/// along a direction the poses barely see (from 40 poses the bundled arm's
/// spent 4,650 evaluations, 4 s, and was judged undetermined after all).
fn fit_from(
    nominal: &Rig,
    first: &Identified,
    option: ModelOption,
    keys: &[ParamKey],
    added: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Option<Identified>, CalibError> {
    let all: Vec<ParamKey> = keys.iter().chain(added).copied().collect();
    let trial = IdentifyOptions {
        patience: TRIAL_PATIENCE.min(options.patience),
        ..*options
    };
    match identify_about(&first.rig, nominal, option, &all, measurements, &trial) {
        Ok(second) if second.diagnostics.exhausted => Ok(None),
        Ok(second) => Ok(Some(second)),
        Err(CalibError::RankDeficient { .. } | CalibError::TooFewPoses { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// The candidates of `option` outside `keys` whose columns at `first`'s
/// estimate over `measurements` are independent of the columns of `keys`
/// (in preference order) and not hopeless there: their standard deviation
/// in the larger fit, predicted from the same Jacobian and the first fit's
/// residual, within [`HOPELESS_FACTOR`] typical errors of their kind (the
/// first residual still holds the error they may remove, so the bar is
/// loose; the larger fit's own deviations decide). One Jacobian serves both
/// questions, and a parameter no fit could determine never slows one.
///
/// A fit under a prior centred at `prior`'s arm, servo errors correlated
/// over its degrees (`calib::parameters::prior`),
/// determines the keys the prior holds whatever the poses: a candidate is
/// judged against the columns of the others only, and its deviation
/// predicted with the prior's rows (the posterior's).
fn joining_at(
    first: &Identified,
    prior: Option<(&Rig, f64)>,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    typical: &TypicalErrors,
) -> Result<Vec<ParamKey>, CalibError> {
    let samples = first.rig.samples(measurements)?;
    let ordered: Vec<ParamKey> = keys
        .iter()
        .copied()
        .chain(
            candidates(
                option,
                &first.rig.arm,
                servo_knots::spacing_of(keys).unwrap_or(KnotSpacing::FINEST),
            )
            .into_iter()
            .chain(refresh_candidates(option, &first.rig.arm))
            .filter(|k| !keys.contains(k)),
        )
        .collect();
    let j = jacobian(&first.rig, &ordered, &samples)?;
    let sigma = first.diagnostics.sigma_m;
    let prior_of = |keys: &[ParamKey]| {
        prior.and_then(|(origin, correlation_deg)| {
            Prior::new(
                &servo_knots::fit_start(&first.rig, keys),
                &servo_knots::fit_start(origin, keys),
                keys,
                correlation_deg,
            )
        })
    };
    let held = prior_of(keys);
    let judged: Vec<usize> = (0..ordered.len())
        .filter(|&c| c >= keys.len() || !held.as_ref().is_some_and(|p| p.holds(c)))
        .collect();
    let against = judged.iter().filter(|&&c| c < keys.len()).count();
    let judged_keys: Vec<ParamKey> = judged.iter().map(|&c| ordered[c]).collect();
    let joining = joining(
        &judged_keys[..against],
        &judged_keys[against..],
        &j.select_columns(&judged),
        typical,
        REFRESH_TOLERANCE,
    );
    if joining.is_empty() {
        return Ok(joining);
    }
    let all: Vec<ParamKey> = keys.iter().chain(&joining).copied().collect();
    let columns: Vec<usize> = all
        .iter()
        .filter_map(|k| ordered.iter().position(|o| o == k))
        .collect();
    let a = j.select_columns(&columns);
    let a = match prior_of(&all) {
        Some(p) => {
            let rows = p.columns(&(0..all.len()).collect::<Vec<_>>()) * sigma;
            let n = a.nrows();
            let mut stacked = a.resize_vertically(n + rows.nrows(), 0.0);
            stacked.rows_mut(n, rows.nrows()).copy_from(&rows);
            stacked
        }
        None => a,
    };
    // The columns scaled as everywhere else keep the normal matrix well conditioned.
    let scale = ColumnScale::from_jacobian(&a, samples.len());
    let Some(inverse) = ({
        let scaled = scale.apply(&a);
        scaled.transpose() * &scaled
    })
    .try_inverse() else {
        return Ok(Vec::new());
    };
    Ok(joining
        .iter()
        .enumerate()
        .filter(|(i, k)| {
            let c = keys.len() + i;
            let std = sigma * inverse[(c, c)].max(0.0).sqrt() * scale.factors[c];
            std.is_finite() && std <= HOPELESS_FACTOR * typical.of(**k)
        })
        .map(|(_, k)| *k)
        .collect())
}

/// The second fit's result as corrections of `nominal`: each estimate adds
/// the first fit's correction of its key; the diagnostics count both fits.
fn combine(nominal: &Rig, first: &Identified, second: Identified) -> Identified {
    let keys: Vec<ParamKey> = second.estimates.iter().map(|e| e.id).collect();
    let nominal = &servo_knots::fit_start(nominal, &keys);
    let before = |key: ParamKey| {
        first
            .estimates
            .iter()
            .find(|e| e.id == key)
            .map_or(0.0, |e| e.error)
    };
    let estimates = second
        .estimates
        .iter()
        .map(|e| Estimate {
            error: before(e.id) + e.error,
            value: e.id.value(&second.rig),
            ..*e
        })
        .collect();
    let mut diagnostics = second.diagnostics;
    diagnostics.rms_before_m = first.diagnostics.rms_before_m;
    diagnostics.evaluations += first.diagnostics.evaluations;
    diagnostics.active_set_rounds += first.diagnostics.active_set_rounds;
    debug_assert!(
        second
            .estimates
            .iter()
            .all(
                |e| (e.id.value(nominal) + before(e.id) + e.error - e.id.value(&second.rig)).abs()
                    < 1e-9 * (1.0 + e.id.value(&second.rig).abs())
            ),
        "the combined corrections apply to the nominal arm"
    );
    // Each measurement's "before" is the nominal arm's, as the first fit saw it.
    let mut per_measurement = second.per_measurement.clone();
    if per_measurement.len() == first.per_measurement.len() {
        for (p, f) in per_measurement.iter_mut().zip(&first.per_measurement) {
            p.before_m = f.before_m;
        }
    }
    Identified {
        estimates,
        diagnostics,
        per_measurement,
        ..second
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::fit::grow::fit_refreshed;
    use crate::calib::testing::{key, measure, rigid_nominal, small_samples};

    /// Joints 2 and 3 of the nominal arm are parallel, so `j3.d` is removed
    /// there; on a true arm with a twist error at joint 2 it moves the point
    /// its own way. Without refresh the fit keeps a residual; with it the
    /// data are matched exactly and the estimates are corrections of the
    /// nominal arm.
    #[test]
    fn a_parameter_confounded_only_at_the_nominal_point_joins_the_fit() {
        let arm = rigid_nominal();
        let nominal = Rig::from(arm);
        let mut truth = arm;
        truth.joints[1].alpha += 0.05;
        truth.joints[2].d += 0.004;
        truth.joints[1].d -= 0.002;
        let meas = measure(&truth, &small_samples(30));
        let samples = small_samples(30);
        let keys = crate::calib::analysis::identifiability::analyse(
            &arm,
            ModelOption::PaperKinematic,
            crate::calib::parameters::servo_knots::KnotSpacing::FINEST,
            &samples,
        )
        .unwrap()
        .kept;
        assert!(!keys.contains(&key("j3.d")), "{keys:?}");
        let plain = IdentifyOptions {
            refresh: false,
            ..Default::default()
        };
        let first =
            fit_refreshed(&nominal, ModelOption::PaperKinematic, &keys, &meas, &plain).unwrap();
        assert!(
            first.diagnostics.rms_after_m > 1e-6,
            "{:?}",
            first.diagnostics
        );
        let fit = fit_refreshed(
            &nominal,
            ModelOption::PaperKinematic,
            &keys,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        assert!(
            fit.diagnostics.rms_after_m < 1e-9,
            "{:?} {:?}",
            fit.diagnostics,
            fit.estimates
        );
        let j3d = fit.estimates.iter().find(|e| e.id == key("j3.d"));
        assert!(j3d.is_some(), "{:?}", fit.estimates);
        for e in &fit.estimates {
            assert!(
                (e.id.value(&nominal) + e.error - e.value).abs() < 1e-12,
                "{}",
                e.id
            );
        }
        assert_eq!(fit.diagnostics.rms_before_m, first.diagnostics.rms_before_m);
    }
}
