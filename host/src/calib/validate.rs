//! How far the model's measured points are from the measurements, before and
//! after calibration: mean, median, RMS, 95th percentile and max of the 3D
//! error norm.

use model::Arm;
use serde::Serialize;

use super::jacobian::tool_points;
use super::{CalibError, Sample};
use crate::dataset::Measurement;

/// The statistics of a set of 3D error norms, as the file formats hold them.
pub use crate::io::calibration_file::ErrorStats;

/// Before/after comparison on one measurement set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Validation {
    /// Errors of the nominal (uncalibrated) model.
    pub before: ErrorStats,
    /// Errors of the calibrated model.
    pub after: ErrorStats,
    /// `100 (1 − mean after / mean before)`, %.
    pub reduction_pct: f64,
    /// Per measurement: (pose id, load kg, error before m, error after m).
    pub per_measurement: Vec<(u32, f64, f64, f64)>,
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
            .map(|(m, (b, a))| (m.pose.id, m.load_kg, *b, *a))
            .collect(),
    })
}
