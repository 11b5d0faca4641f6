//! The machine-readable report (JSON) and the paper-style table a person reads.
//!
//! The report carries everything a run learnt per option: the rank analysis
//! (kept, removed and what each removed parameter is confounded with), the
//! selection and its observability indices, the fitted parameters with their
//! deviations, the solver diagnostics, named outliers, and the validation and
//! cross-load statistics. Bump [`REPORT_SCHEMA_VERSION`] when a field changes meaning.

use serde::Serialize;

use super::ModelOption;
use super::identifiability::Identifiability;
use super::identify::Identified;
use super::observability::Observability;
use super::pipeline::OptionResult;
use super::validate::{ErrorStats, Validation};
use crate::io::calibration_file::FittedParam;

/// Version of the report schema.
pub const REPORT_SCHEMA_VERSION: u32 = 1;

/// A removed parameter and what explains it.
#[derive(Clone, Debug, Serialize)]
pub struct RemovedReport {
    /// Parameter name.
    pub name: String,
    /// Sine of the angle between its column and the kept columns' span.
    pub residual: f64,
    /// Kept parameters reproducing its column, with coefficients.
    pub confounded_with: Vec<(String, f64)>,
}

/// The rank analysis of one option.
#[derive(Clone, Debug, Serialize)]
pub struct IdentifiabilityReport {
    /// Candidates before the analysis.
    pub candidates: usize,
    /// Kept parameter names.
    pub kept: Vec<String>,
    /// Removed parameters.
    pub removed: Vec<RemovedReport>,
    /// Rank by SVD (must equal the number kept).
    pub svd_rank: usize,
    /// Condition number of the kept unit columns.
    pub kept_condition: f64,
}

impl From<&Identifiability> for IdentifiabilityReport {
    fn from(a: &Identifiability) -> Self {
        Self {
            candidates: a.kept.len() + a.removed.len(),
            kept: a.kept.iter().map(|p| p.name().into()).collect(),
            removed: a
                .removed
                .iter()
                .map(|r| RemovedReport {
                    name: r.id.name().into(),
                    residual: r.residual,
                    confounded_with: r
                        .confounded_with
                        .iter()
                        .map(|(p, c)| (p.name().into(), *c))
                        .collect(),
                })
                .collect(),
            svd_rank: a.svd_rank,
            kept_condition: a.kept_condition,
        }
    }
}

/// Solver diagnostics, in report units.
#[derive(Clone, Debug, Serialize)]
pub struct FitReport {
    /// Last LM termination reason.
    pub termination: String,
    /// Whether LM reported success.
    pub converged: bool,
    /// Residual evaluations.
    pub evaluations: usize,
    /// Active-set rounds.
    pub active_set_rounds: usize,
    /// Reweighting rounds.
    pub irls_rounds: usize,
    /// Compliances held at zero.
    pub at_bound: Vec<String>,
    /// RMS 3D residual of the fit data before, mm.
    pub rms_before_mm: f64,
    /// RMS 3D residual of the fit data after, mm.
    pub rms_after_mm: f64,
    /// Residual deviation per coordinate, mm.
    pub sigma_mm: f64,
    /// Condition number of the scaled Jacobian at the solution.
    pub condition: f64,
    /// Fitted parameters.
    pub parameters: Vec<FittedParam>,
    /// Outliers: (pose, load kg, residual mm, weight).
    pub outliers: Vec<(u32, f64, f64, f64)>,
}

impl From<&Identified> for FitReport {
    fn from(f: &Identified) -> Self {
        let d = &f.diagnostics;
        Self {
            termination: d.termination.clone(),
            converged: d.converged,
            evaluations: d.evaluations,
            active_set_rounds: d.active_set_rounds,
            irls_rounds: d.irls_rounds,
            at_bound: d.at_bound.iter().map(|p| p.name().into()).collect(),
            rms_before_mm: d.rms_before_m * 1e3,
            rms_after_mm: d.rms_after_m * 1e3,
            sigma_mm: d.sigma_m * 1e3,
            condition: d.condition,
            parameters: f.estimates.iter().map(FittedParam::from).collect(),
            outliers: f
                .outliers
                .iter()
                .map(|o| (o.pose, o.load_kg, o.residual_m * 1e3, o.weight))
                .collect(),
        }
    }
}

/// Validation statistics of one measurement set.
#[derive(Clone, Debug, Serialize)]
pub struct ValidationReport {
    /// Payload, kg.
    pub load_kg: f64,
    /// Nominal model, m.
    pub before: ErrorStats,
    /// Calibrated model, m.
    pub after: ErrorStats,
    /// Mean error reduction, %.
    pub reduction_pct: f64,
}

impl ValidationReport {
    /// Summarises a validation under `load_kg`.
    pub fn new(load_kg: f64, v: &Validation) -> Self {
        Self {
            load_kg,
            before: v.before,
            after: v.after,
            reduction_pct: v.reduction_pct,
        }
    }
}

/// Everything about one option.
#[derive(Clone, Debug, Serialize)]
pub struct OptionReport {
    /// The option.
    pub option: ModelOption,
    /// Rank analysis.
    pub identifiability: IdentifiabilityReport,
    /// Selected pose ids.
    pub selected_poses: Vec<u32>,
    /// ln det of the selection's scaled information matrix.
    pub log_det: f64,
    /// ln det reached by each DETMAX start.
    pub start_log_dets: Vec<f64>,
    /// Observability indices of the selection.
    pub observability: Observability,
    /// The fit.
    pub fit: FitReport,
    /// Validation on held-out poses under the identification load, if any were held out.
    pub validation: Option<ValidationReport>,
    /// Validation under the other load.
    pub cross_load: Option<ValidationReport>,
}

impl OptionReport {
    /// Builds the report of one option's run, identified under `load_kg`.
    pub fn new(r: &OptionResult, load_kg: f64) -> Self {
        Self {
            option: r.selection.option,
            identifiability: (&r.selection.candidates.identifiability).into(),
            selected_poses: r.selection.poses.iter().map(|p| p.id).collect(),
            log_det: r.selection.design.log_det,
            start_log_dets: r.selection.design.start_log_dets.clone(),
            observability: r.selection.observability,
            fit: (&r.identified).into(),
            validation: r
                .validation
                .as_ref()
                .map(|v| ValidationReport::new(load_kg, v)),
            cross_load: r
                .cross_load
                .as_ref()
                .map(|(l, v)| ValidationReport::new(*l, v)),
        }
    }
}

/// DETMAX against random selections of the same size.
#[derive(Clone, Debug, Serialize)]
pub struct RandomBaseline {
    /// Option compared.
    pub option: ModelOption,
    /// Random sets drawn.
    pub sets: usize,
    /// O1 of the DETMAX selection.
    pub detmax_o1: f64,
    /// Median O1 of the random sets.
    pub random_o1_median: f64,
    /// Mean validation error of the DETMAX selection, m.
    pub detmax_mean_m: f64,
    /// Median over the random sets of the mean validation error, m.
    pub random_mean_median_m: f64,
}

/// The whole report of a run.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Always `lrmcal-report`.
    pub schema: &'static str,
    /// [`REPORT_SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Where the nominal arm came from.
    pub arm: String,
    /// Candidate poses.
    pub candidates: usize,
    /// Load the identification used, kg.
    pub identify_load_kg: f64,
    /// How the measurements were made (simulator settings for the demo).
    pub measurements: serde_json::Value,
    /// Per option, in table order.
    pub options: Vec<OptionReport>,
    /// DETMAX versus random selection, when computed.
    pub random_baseline: Option<RandomBaseline>,
    /// O1 of the DETMAX selection per number of poses (option, N, O1).
    pub o1_vs_poses: Vec<(ModelOption, usize, f64)>,
}

impl Report {
    /// The report as pretty JSON.
    pub fn to_json(&self) -> String {
        // Numbers, strings and vectors only: serialisation cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

/// The paper-style table: option, parameters, mean error before → after, reduction,
/// and the cross-load reduction when there is one.
pub fn table(options: &[OptionReport]) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "{:<18} {:>6} {:>26} {:>10} {:>11}\n",
        "model", "params", "mean error before -> after", "reduction", "cross-load"
    ));
    for o in options {
        let cross = o
            .cross_load
            .as_ref()
            .map(|c| format!("{:.1} %", c.reduction_pct))
            .unwrap_or("-".into());
        let (before, after, reduction) = match &o.validation {
            Some(v) => (
                format!("{:.2}", v.before.mean_m * 1e3),
                format!("{:.2}", v.after.mean_m * 1e3),
                format!("{:.1} %", v.reduction_pct),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        s.push_str(&format!(
            "{:<18} {:>6} {:>12} -> {:>6} mm {:>10} {:>11}\n",
            o.option.name(),
            o.identifiability.kept.len(),
            before,
            after,
            reduction,
            cross
        ));
    }
    s
}
