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

use crate::calib::fit::identify::{Identified, IdentifyOptions, identify};
use crate::calib::fit::knot_choice::{self, ChosenFit};
use crate::calib::fit::model_choice::{self, Ladder, Rung};
use crate::calib::fit::refresh::refreshed;
use crate::calib::parameters::backlash;
use crate::calib::parameters::params::ParamKey;
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
    model_choice::choose(option, kept, |rung, kept| match rung {
        // The base and tool points only: no refresh may add the arm's own.
        Rung::Placement => Ok(ChosenFit {
            identified: identify(nominal, option, kept, measurements, options)?,
            knots: None,
            model: None,
        }),
        Rung::Model(model) => knot_choice::choose(kept, |keys| {
            let keys = backlash::with_widths(nominal, model, keys, measurements)?;
            fit_refreshed(nominal, model, &keys, measurements, options)
        }),
    })
}

/// The last two stages for `keys`: the fit, then, when `options.refresh`,
/// the refresh at its estimate.
pub fn fit_refreshed(
    nominal: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    let fit = identify(nominal, option, keys, measurements, options)?;
    if !options.refresh {
        return Ok(fit);
    }
    refreshed(nominal, option, keys, fit, measurements, options)
}
