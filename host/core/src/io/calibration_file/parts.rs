//! The records a calibration file is made of besides its arms: each fitted
//! parameter, error statistics, the registration, the measured targets and
//! the validation, as the file writes them.

use model::Frame;
use serde::{Deserialize, Serialize};

use crate::param_key::ParamKey;

/// One fitted parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedParam {
    /// The parameter, written by its stable name (`j2.theta`, `k0`, …).
    pub name: ParamKey,
    /// Identified correction, SI units (m, rad, rad/Nm).
    pub error: f64,
    /// Nominal + correction, SI units.
    pub value: f64,
    /// One standard deviation of the correction; null when held at a bound.
    pub std: Option<f64>,
}

/// Statistics of a set of 3D error norms, m.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorStats {
    /// Number of measurements.
    pub count: usize,
    /// Mean, m.
    pub mean_m: f64,
    /// Median, m.
    pub median_m: f64,
    /// Root mean square, m.
    pub rms_m: f64,
    /// 95th percentile (linear interpolation between order statistics), m.
    pub p95_m: f64,
    /// Largest, m.
    pub max_m: f64,
}

impl ErrorStats {
    /// Statistics of `norms` (m); all zero for an empty set.
    pub fn of(norms: &[f64]) -> Self {
        let mut v = norms.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let quantile = |p: f64| {
            if n == 0 {
                return 0.0;
            }
            let x = p * (n - 1) as f64;
            let (lo, hi) = (x.floor() as usize, x.ceil() as usize);
            v[lo] + (v[hi] - v[lo]) * (x - lo as f64)
        };
        let mean = if n == 0 {
            0.0
        } else {
            v.iter().sum::<f64>() / n as f64
        };
        let rms = if n == 0 {
            0.0
        } else {
            (v.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt()
        };
        Self {
            count: n,
            mean_m: mean,
            median_m: quantile(0.5),
            rms_m: rms,
            p95_m: quantile(0.95),
            max_m: v.last().copied().unwrap_or(0.0),
        }
    }
}

/// The arm's place in the measurement frame, as `lrmcal identify` found it.
///
/// A registered file's `nominal` and `arm` are both in the measurement
/// frame already (the nominal's base is the registered base, gravity is the
/// measurement frame's), so `predict`, `validate` and the board work there
/// with no conversion; this record only documents where the base was found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegistrationRecord {
    /// Whether the base was registered (false: `--no-register`, the arm file's base kept).
    pub registered: bool,
    /// The arm file's world frame in the measurement frame (m, rad): the
    /// rigid motion registration found.
    pub frame: Frame<f64>,
    /// The nominal arm's frame 0 in the measurement frame (m, rad), as
    /// registration placed it (the calibrated `arm` refines it).
    pub base: Frame<f64>,
    /// Gravity in the measurement frame, m/s².
    pub gravity: [f64; 3],
    /// RMS distance of the nominal arm from the measurements as the arm file placed it, m.
    pub before_rms_m: f64,
    /// The same after registration, over the points it kept, m.
    pub after_rms_m: f64,
    /// Poses left out of the registration as far off.
    pub trimmed: Vec<u32>,
    /// The tool point registration found with the base (frame 6, m), which
    /// replaced the arm file's in `nominal`; absent when the file's was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_m: Option<[f64; 3]>,
}

/// One measured target of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetTool {
    /// The name the measurement file gave it.
    pub name: String,
    /// Its tool point in frame 6 (the tool frame's parent) of the corrected arm, m.
    pub tool_m: [f64; 3],
    /// Residual of the fit on its own measurements (3D error norm), m.
    pub fit_residual: ErrorStats,
    /// The corrected arm's error on its held-out measurements, when there were any, m.
    pub validation_after: Option<ErrorStats>,
}

/// Before/after statistics on held-out measurements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationSummary {
    /// Payload of the validation measurements, kg.
    pub load_kg: f64,
    /// Nominal model.
    pub before: ErrorStats,
    /// Calibrated model.
    pub after: ErrorStats,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_a_known_set() {
        let s = ErrorStats::of(&[4.0, 1.0, 3.0, 2.0, 5.0]);
        assert_eq!(s.count, 5);
        assert!((s.mean_m - 3.0).abs() < 1e-12);
        assert!((s.median_m - 3.0).abs() < 1e-12);
        assert!((s.rms_m - 11f64.sqrt()).abs() < 1e-12);
        assert!((s.p95_m - 4.8).abs() < 1e-12);
        assert_eq!(s.max_m, 5.0);
        assert_eq!(ErrorStats::of(&[]).count, 0);
    }
}
