//! What a fit is asked (how to fit) and what it gives: the estimates with
//! their deviations, the outliers named, the solver's diagnostics and each
//! fitted measurement.

use lrmcal_core::io::calibration_file::ErrorStats;
use nalgebra::{DMatrix, Vector3};

use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::prior;
use crate::calib::{ModelOption, Rig};

/// How to fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyOptions {
    /// Down-weight outliers with Huber's function (the default: on clean
    /// data it loses nothing, see docs/METHOD.md).
    pub robust: bool,
    /// Most active-set rounds (each one a full LM fit), over all reweighting rounds.
    pub max_active_set_rounds: usize,
    /// Most rounds of the robust fit (each with Huber's threshold of the
    /// residuals it starts from) or of the prior's noise.
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
    /// Rounds used (1 when neither robust nor under a prior).
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
    /// How it was fitted (under a prior, the servo curves' correlation
    /// length the measurements chose: `calib::fit::grow`).
    pub options: IdentifyOptions,
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
