//! What the fit's choices are: the knot spacing ([`KnotChoice`], chosen in
//! `calib::fit::knot_choice`), the model ([`ModelChoice`], chosen in
//! `calib::fit::model_choice`) and the fit that carries both
//! ([`ChosenFit`]). The types live apart from the stages that choose them,
//! which read each other's.

use serde::{Deserialize, Serialize};

use crate::calib::ModelOption;
use crate::calib::fit::identify::Identified;
use crate::calib::parameters::servo_knots::KnotSpacing;

/// One knot spacing tried.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KnotTrial {
    /// The spacing.
    pub spacing: KnotSpacing,
    /// Mean leave-one-out error of its fit, mm; `None` when it failed.
    pub loo_mean_mm: Option<f64>,
    /// Why its fit failed, if it did.
    pub failure: Option<String>,
}

/// The spacing chosen and the ones tried.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KnotChoice {
    /// The spacing of the calibration's curves.
    pub chosen: KnotSpacing,
    /// Every spacing fitted, finest first.
    pub trials: Vec<KnotTrial>,
}

/// A fit of an option's parameters, with the knot spacing chosen when the
/// option fits servo curves and the model when it fits several effects
/// (`calib::model_choice`).
#[derive(Clone, Debug)]
pub struct ChosenFit {
    /// The identification.
    pub identified: Identified,
    /// How the knot spacing was chosen; `None` without knots.
    pub knots: Option<KnotChoice>,
    /// How the model was chosen; `None` for an option fitted as it is.
    pub model: Option<ModelChoice>,
}
/// A rung of the ladder: a model of the arm, by what it fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rung {
    /// The nominal arm placed: its base and tool points only.
    Placement,
    /// The effects of a model option.
    #[serde(untagged)]
    Model(#[serde(with = "lrmcal_core::io::model_option")] ModelOption),
}

impl std::fmt::Display for Rung {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Rung::Placement => f.write_str("placement"),
            Rung::Model(option) => write!(f, "{option}"),
        }
    }
}

/// One rung of the ladder as fitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelTrial {
    /// The rung.
    pub model: Rung,
    /// Parameters the rung's fit ended with; 0 when it failed.
    pub parameters: usize,
    /// Mean leave-one-out error of its fit, mm; `None` when it failed.
    pub loo_mean_mm: Option<f64>,
    /// Standard error of the mean difference of its leave-one-out errors
    /// from the best rung's, the measurements paired, mm (0 for the best).
    pub loo_se_mm: Option<f64>,
    /// Why its fit failed, if it did.
    pub failure: Option<String>,
}

/// The rung kept and every rung fitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelChoice {
    /// The model the calibration holds.
    pub chosen: Rung,
    /// Every rung, simplest first.
    pub trials: Vec<ModelTrial>,
}
