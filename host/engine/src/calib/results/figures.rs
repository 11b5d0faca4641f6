//! The experiments' figures as the report holds them: O1 and the error
//! against the number of poses, and DETMAX against random selections. The
//! types live apart from the experiments that compute them
//! (`calib::results::experiments`), which run calibrations, so the report
//! reads them without reaching back into the run.

use serde::{Deserialize, Serialize};

use crate::calib::ModelOption;
use crate::calib::fit::validate::ErrorStats;
use crate::calib::parameters::servo_knots::KnotSpacing;

/// DETMAX against random selections of the same size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RandomBaseline {
    /// Option compared.
    pub option: ModelOption,
    /// Random sets drawn.
    pub sets: usize,
    /// Poses in each set (as many as DETMAX selected).
    pub poses: usize,
    /// O1 of the DETMAX selection.
    pub detmax_o1: f64,
    /// Median O1 of the random sets.
    pub random_o1_median: f64,
    /// Mean validation error of the DETMAX selection, m.
    pub detmax_mean_m: f64,
    /// Median over the random sets of the mean validation error, m.
    pub random_mean_median_m: f64,
}

/// O1 of a DETMAX selection of `poses` poses for `option`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct O1Point {
    /// The option.
    pub option: ModelOption,
    /// Poses selected.
    pub poses: usize,
    /// O1 of the selection.
    pub o1: f64,
}

/// How well a calibration of one option from a DETMAX selection of some
/// number of poses does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorPoint {
    /// The option.
    pub option: ModelOption,
    /// Poses selected and fitted.
    pub poses: usize,
    /// The servo curves' knot spacing the fit chose, for an option with servo curves.
    pub knots: Option<KnotSpacing>,
    /// On the held-out candidates of the grid and on the off-grid poses;
    /// `None` when the poses cannot determine the option's parameters or
    /// the fit failed.
    pub errors: Option<GridErrors>,
    /// Why there are no errors, if there are none.
    pub failure: Option<String>,
}

/// A calibration's error on held-out grid poses and on poses off the grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridErrors {
    /// The option.
    pub option: ModelOption,
    /// On the candidates of the grid (ids below the grid's size) not selected.
    pub grid: ErrorStats,
    /// On `off_grid`, poses none of the candidates'.
    pub off_grid: ErrorStats,
}
