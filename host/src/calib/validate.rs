//! How far the model's measured points are from the measurements, before and
//! after calibration: mean, median, RMS, 95th percentile and max of the 3D
//! error norm.

use model::Arm;

use super::jacobian::measured_points;
use super::{CalibError, Sample};
use crate::dataset::Measurement;

/// The statistics of a set of 3D error norms, as the file formats hold them.
pub use crate::io::calibration_file::ErrorStats;

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

/// 3D error norms of `arm`'s predictions against `measurements`, which were
/// commanded through `commanding`'s servo curves, m.
pub fn error_norms(
    commanding: &Arm<f64>,
    arm: &Arm<f64>,
    measurements: &[Measurement],
) -> Result<Vec<f64>, CalibError> {
    let samples: Vec<Sample> = measurements.iter().map(Sample::from).collect();
    Ok(measured_points(commanding, arm, &samples)?
        .iter()
        .zip(measurements)
        .map(|(p, m)| (p - m.position).norm())
        .collect())
}

/// Compares `nominal` and `calibrated` on `measurements`, taken with `nominal`
/// (commanded through its servo curves).
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
    let before = error_norms(nominal, nominal, measurements)?;
    let after = error_norms(nominal, calibrated, measurements)?;
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
