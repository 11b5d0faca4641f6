//! How far the model's measured points are from the measurements, before and
//! after calibration: mean, median, RMS, 95th percentile and max of the 3D
//! error norm.

use model::Arm;
use serde::{Deserialize, Serialize};

use super::jacobian::tool_points;
use super::{CalibError, Sample};
use crate::dataset::Measurement;

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

/// The error of one measurement before and after calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseError {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// 3D error of the nominal model, m.
    pub before_m: f64,
    /// 3D error of the calibrated model, m.
    pub after_m: f64,
}

/// Before/after comparison on one measurement set.
#[derive(Clone, Debug, PartialEq)]
pub struct Validation {
    /// Errors of the nominal (uncalibrated) model.
    pub before: ErrorStats,
    /// Errors of the calibrated model.
    pub after: ErrorStats,
    /// `100 (1 − mean after / mean before)`, %.
    pub reduction_pct: f64,
    /// Each measurement's error, in the order given.
    pub per_measurement: Vec<PoseError>,
}

/// A validation on the measurements under one load.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadValidation {
    /// The load of the measurements, kg.
    pub load_kg: f64,
    /// Errors before and after on them.
    pub validation: Validation,
}

/// Compares `nominal` and `calibrated` on `measurements`, load by load (ascending).
pub fn validate_per_load(
    nominal: &Arm<f64>,
    calibrated: &Arm<f64>,
    measurements: &[Measurement],
) -> Result<Vec<LoadValidation>, CalibError> {
    crate::dataset::loads_of(measurements)
        .into_iter()
        .map(|load_kg| {
            let set: Vec<Measurement> = measurements
                .iter()
                .filter(|m| m.load_kg == load_kg)
                .copied()
                .collect();
            Ok(LoadValidation {
                load_kg,
                validation: validate(nominal, calibrated, &set)?,
            })
        })
        .collect()
}

/// 3D error norms of `arm`'s predictions against `measurements`, m.
pub fn error_norms(arm: &Arm<f64>, measurements: &[Measurement]) -> Result<Vec<f64>, CalibError> {
    let samples: Vec<Sample> = measurements.iter().map(Sample::from).collect();
    Ok(tool_points(arm, &samples)?
        .iter()
        .zip(measurements)
        .map(|(p, m)| (p - m.position).norm())
        .collect())
}

/// Compares `nominal` and `calibrated` on `measurements`.
pub fn validate(
    nominal: &Arm<f64>,
    calibrated: &Arm<f64>,
    measurements: &[Measurement],
) -> Result<Validation, CalibError> {
    if measurements.is_empty() {
        return Err(CalibError::Empty {
            what: "validate the calibration: no validation measurements".into(),
        });
    }
    let before = error_norms(nominal, measurements)?;
    let after = error_norms(calibrated, measurements)?;
    let (b, a) = (ErrorStats::of(&before), ErrorStats::of(&after));
    Ok(Validation {
        before: b,
        after: a,
        reduction_pct: if b.mean_m > 0.0 {
            100.0 * (1.0 - a.mean_m / b.mean_m)
        } else {
            0.0
        },
        per_measurement: measurements
            .iter()
            .zip(before.iter().zip(&after))
            .map(|(m, (b, a))| PoseError {
                pose: m.pose.id,
                load_kg: m.load_kg,
                before_m: *b,
                after_m: *a,
            })
            .collect(),
    })
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
