//! How far the model's measured points are from the measurements, before and
//! after calibration: mean, median, RMS, 95th percentile and max of the 3D
//! error norm, and the measurements whose error is far beyond the others'
//! (named by the fit's outlier rule, [`crate::calib::fit::identify::outlier_indices`]).

use crate::calib::fit::identify::outlier_indices;
use crate::calib::fit::identify::problem::measured_block;
use crate::calib::{CalibError, Rig};
use lrmcal_core::dataset::Measurement;

/// The statistics of a set of 3D error norms, as the file formats hold them.
pub use lrmcal_core::io::calibration_file::ErrorStats;

/// The error of one measurement before and after calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseError {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// Index of the measured target in the calibration's targets.
    pub target: usize,
    /// 3D error of the nominal model, m.
    pub before_m: f64,
    /// 3D error of the calibrated model, m.
    pub after_m: f64,
    /// The measured point, in the frame of the rigs compared, m.
    pub measured_m: nalgebra::Vector3<f64>,
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
    /// The measurements whose calibrated error is far beyond the others'
    /// (a measurement gone wrong, or a pose the model does not describe),
    /// largest first.
    pub outliers: Vec<PoseError>,
    /// A camera's: the reprojection errors before and after, px (the
    /// statistics' `_m` fields hold pixels here).
    pub pixels: Option<[ErrorStats; 2]>,
}

/// A validation on the measurements under one load.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadValidation {
    /// The load of the measurements, kg.
    pub load_kg: f64,
    /// Errors before and after on them.
    pub validation: Validation,
}

/// Outliers `largest_first` grouped by the pose and load `at` says each
/// was measured at: each pose's first, its worst, and how many of its
/// measurements are outliers (a camera's view is dozens of corners, a
/// tracker's several targets), worst pose first.
pub fn worst_per_pose<T>(largest_first: &[T], at: impl Fn(&T) -> (u32, f64)) -> Vec<(&T, usize)> {
    let mut poses: Vec<(&T, usize)> = Vec::new();
    for o in largest_first {
        match poses.iter_mut().find(|(p, _)| at(p) == at(o)) {
            Some((_, count)) => *count += 1,
            None => poses.push((o, 1)),
        }
    }
    poses
}

/// Compares `nominal` and `calibrated` on `measurements`, load by load (ascending).
pub fn validate_per_load(
    nominal: &Rig,
    calibrated: &Rig,
    measurements: &[Measurement],
) -> Result<Vec<LoadValidation>, CalibError> {
    lrmcal_core::dataset::loads_of(measurements)
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

/// Each pixel's reprojection error at `rig` (a camera's), px, in the
/// measurements' order; measurements without a pixel (a tracker's) have none.
pub fn reprojection_errors_px(
    rig: &Rig,
    measurements: &[Measurement],
) -> Result<Vec<f64>, CalibError> {
    Ok(errors_at(rig, measurements)?.1)
}

/// `rig`'s errors at `measurements` (each of one of its targets), from one
/// evaluation of its observations: each error's norm, m (a tracker's 3D
/// distance, a camera's reprojection error carried to the target's
/// distance, `calib::parameters::camera`), and each pixel's reprojection
/// error, px (none for a tracker's measurements).
fn errors_at(rig: &Rig, measurements: &[Measurement]) -> Result<(Vec<f64>, Vec<f64>), CalibError> {
    let seen = rig.observations(&rig.samples(measurements)?)?;
    let norms = seen
        .iter()
        .zip(measurements)
        .map(|(o, m)| o.residual(&measured_block(m)).norm())
        .collect();
    let pixels = seen
        .iter()
        .zip(measurements)
        .filter_map(|(o, m)| m.pixel.map(|px| (o.value.x - px.x).hypot(o.value.y - px.y)))
        .collect();
    Ok((norms, pixels))
}

/// Compares `nominal` and `calibrated` (the same targets) on `measurements`.
pub fn validate(
    nominal: &Rig,
    calibrated: &Rig,
    measurements: &[Measurement],
) -> Result<Validation, CalibError> {
    if measurements.is_empty() {
        return Err(CalibError::Empty {
            what: "validate the calibration: no validation measurements".into(),
        });
    }
    let (before, before_px) = errors_at(nominal, measurements)?;
    let (after, after_px) = errors_at(calibrated, measurements)?;
    let (b, a) = (ErrorStats::of(&before), ErrorStats::of(&after));
    let per_measurement: Vec<PoseError> = measurements
        .iter()
        .zip(before.iter().zip(&after))
        .map(|(m, (b, a))| PoseError {
            pose: m.pose.id,
            load_kg: m.load_kg,
            target: calibrated.targets.index(m.target).unwrap_or(0),
            before_m: *b,
            after_m: *a,
            measured_m: m.position,
        })
        .collect();
    let mut outliers: Vec<PoseError> = outlier_indices(&after, calibrated.measured_axes())
        .into_iter()
        .map(|k| per_measurement[k])
        .collect();
    outliers.sort_by(|x, y| y.after_m.total_cmp(&x.after_m));
    let pixels = calibrated
        .camera
        .is_some()
        .then(|| [ErrorStats::of(&before_px), ErrorStats::of(&after_px)]);
    Ok(Validation {
        before: b,
        after: a,
        reduction_pct: if b.mean_m > 0.0 {
            100.0 * (1.0 - a.mean_m / b.mean_m)
        } else {
            0.0
        },
        per_measurement,
        outliers,
        pixels,
    })
}

impl Validation {
    /// The outliers grouped by pose and load: each pose's worst, and how
    /// many of its measurements are outliers (a camera's view is dozens of
    /// corners, a tracker's several targets), worst pose first.
    pub fn outlying_poses(&self) -> Vec<(PoseError, usize)> {
        worst_per_pose(&self.outliers, |o| (o.pose, o.load_kg))
            .into_iter()
            .map(|(o, count)| (*o, count))
            .collect()
    }

    /// The calibrated model's error statistics per target, in target order
    /// (`targets` of them; a target with no measurement here has count 0).
    pub fn after_per_target(&self, targets: usize) -> Vec<ErrorStats> {
        (0..targets)
            .map(|t| {
                let norms: Vec<f64> = self
                    .per_measurement
                    .iter()
                    .filter(|e| e.target == t)
                    .map(|e| e.after_m)
                    .collect();
                ErrorStats::of(&norms)
            })
            .collect()
    }
}
