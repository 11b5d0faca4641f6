//! One option's fit, its parameter set grown stage by stage, each stage
//! handing the next a larger set and none calling another:
//!
//! ```text
//! kept (the candidates' analysis, structure checked)
//!   → model (model_choice: the placement, then the option's effects, on each rung)
//!   → knot spacing (knot_choice: the servo curves' knots on each spacing tried)
//!     → play widths (backlash: the joints the measurements show arriving both ways)
//!       → the fit (identify)
//!         → refresh (the rank analysis again at the estimate, and what it adds)
//! ```
//!
//! The model and spacing stages compare the fits they end in and keep the
//! one that predicts best; the stages after each run once per rung or
//! spacing.
//!
//! Ours is fitted, on every rung, under the prior of its effects
//! (`calib::parameters::prior`): the most probable corrections given the
//! measurements and the effects' physical sizes. The paper's options and
//! the options of one effect are fitted by least squares, as the paper
//! fitted them.

use crate::calib::fit::choice::{ChosenFit, Rung};
use crate::calib::fit::guard;
use crate::calib::fit::identify::{Identified, IdentifyOptions, identify, identify_scored};
use crate::calib::fit::knot_choice;
use crate::calib::fit::model_choice::{self, Ladder};
use crate::calib::fit::refresh::refreshed;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::prior::SERVO_CORRELATIONS_DEG;
use crate::calib::parameters::{backlash, option};
use crate::calib::{CalibError, ModelOption, Rig};
use lrmcal_core::dataset::Measurement;

/// Fits `option`'s `kept` parameters to `measurements` from `nominal`
/// through every stage, and the nominal arm placed beside it.
pub fn grow(
    nominal: &Rig,
    option: ModelOption,
    kept: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Ladder, CalibError> {
    let options = &IdentifyOptions {
        prior: options.prior && option == ModelOption::ElastoKinematicServo,
        ..*options
    };
    model_choice::choose(
        option,
        kept,
        |rung, kept| match rung {
            // The base and tool points only: no refresh may add the arm's own.
            Rung::Placement => Ok(ChosenFit {
                identified: identify(nominal, option, kept, measurements, options)?,
                knots: None,
                model: None,
            }),
            Rung::Model(model) => knot_choice::choose(kept, options.prior, |keys| {
                let mut keys =
                    backlash::with_widths(nominal, model, keys, measurements, options.prior)?;
                if options.prior {
                    keys.extend(option::softenings_of(model, &keys));
                }
                fit_refreshed(nominal, model, &keys, measurements, options)
            }),
        },
        |fit| guard::beyond_size(&nominal.arm, &fit.identified),
    )
}

/// The last two stages for `keys`: the fit, then, when `options.refresh`,
/// the refresh at its estimate. Under a prior with servo curves, the fit
/// is the most probable of [`smoothest_probable`]'s.
pub fn fit_refreshed(
    nominal: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    let knots = keys.iter().any(|k| matches!(k, ParamKey::ServoKnot { .. }));
    let fit = match options.prior && knots {
        true => smoothest_probable(nominal, option, keys, measurements, options)?,
        false => identify(nominal, option, keys, measurements, options)?,
    };
    if !options.refresh {
        return Ok(fit);
    }
    let options = fit.options;
    refreshed(nominal, option, keys, fit, measurements, &options)
}

/// How smooth the servo curves are: the fit of `keys` under the prior with
/// each of [`SERVO_CORRELATIONS_DEG`] (the correlation lengths of a curve's
/// error), the one whose measurements are the most probable (the largest
/// evidence, `identify::identify_scored`; its [`Identified::options`] say
/// which). The middle one and the roughest are fitted side by side, the
/// smoothest only when the middle one beat the roughest.
pub fn smoothest_probable(
    nominal: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    let fit = |correlation_deg: f64| {
        let options = IdentifyOptions {
            servo_correlation_deg: correlation_deg,
            ..*options
        };
        identify_scored(nominal, nominal, option, keys, measurements, &options)
            .map(|(fit, evidence)| (fit, evidence.unwrap_or(f64::NEG_INFINITY)))
    };
    let [rough, middle, smooth] = SERVO_CORRELATIONS_DEG;
    let (a, b) = rayon::join(|| fit(rough), || fit(middle));
    let mut fits = vec![a, b];
    let middle_won = match (&fits[0], &fits[1]) {
        (Ok(r), Ok(m)) => m.1 > r.1,
        (Err(_), Ok(_)) => true,
        _ => false,
    };
    if middle_won {
        fits.push(fit(smooth));
    }
    let best = fits
        .iter()
        .enumerate()
        .filter_map(|(i, f)| f.as_ref().ok().map(|f| (i, f.1)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    // Every one failed: the middle one's reason.
    fits.swap_remove(best.unwrap_or(1)).map(|(fit, _)| fit)
}
