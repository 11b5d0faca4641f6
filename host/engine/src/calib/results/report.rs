//! The machine-readable report (JSON): what a run learnt, per option, in one
//! document with its schema header.
//!
//! The report carries the rank analysis (kept, removed and what each removed
//! parameter is confounded with), the selection and its observability
//! indices, the fitted parameters with their deviations, the solver
//! diagnostics, named outliers, the validation and cross-load statistics,
//! and the demo's experiments. Every list entry is an object with named
//! fields. Bump [`REPORT_SCHEMA_VERSION`] when a field changes meaning or shape.
//!
//! [`Report::parse`] reads the report back (`lrmcal report` builds its page
//! from it): fields added since the oldest version it reads are optional,
//! and numbers written as `null` (not finite) read back as NaN.

use serde::{Deserialize, Serialize};

use crate::calib::ModelOption;
use crate::calib::analysis::identifiability::Identifiability;
use crate::calib::analysis::observability::Observability;
use crate::calib::fit::choice::{KnotChoice, ModelChoice};
use crate::calib::fit::identify::{Identified, Outlier};
use crate::calib::fit::pipeline::OptionResult;
use crate::calib::fit::registration::{MIN_TOOL_TURN, Registration, frame_of};
use crate::calib::fit::validate::{ErrorStats, Validation};
use crate::calib::results::figures::{ErrorPoint, O1Point, RandomBaseline};
use crate::calib::results::servo_curves::{ServoCurveReport, servo_curves};
use lrmcal_core::camera::static_transform::StaticTransform;
use lrmcal_core::camera::{Intrinsics, Mount};
use lrmcal_core::error::InputError;
use lrmcal_core::io::calibration_file::FittedParam;
use lrmcal_core::io::json;
use lrmcal_core::param_key::ParamKey;

/// Name of the report schema.
pub const REPORT_SCHEMA: &str = "lrmcal-report";
/// Version of the report schema (2: named list entries; 3: the fit's
/// leave-one-out error, the knot spacing chosen, the error against the
/// number of poses; 4: each validation measurement's error, the registration;
/// 5: each fitted measurement's errors, where each measurement was, the
/// servo curves identified; 6: a camera's pose, lens and reprojection
/// errors, validation outliers one per pose).
pub const REPORT_SCHEMA_VERSION: u32 = 6;

/// The oldest version [`Report::parse`] reads (its fields are all still there).
pub const REPORT_OLDEST_READ: u32 = 3;

/// A kept parameter that reproduces a removed one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Confounder {
    /// Kept parameter.
    pub name: ParamKey,
    /// Its coefficient in the combination of unit columns.
    pub coefficient: f64,
}

/// A removed parameter and what explains it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RemovedReport {
    /// The parameter.
    pub name: ParamKey,
    /// Sine of the angle between its column and the kept columns' span.
    pub residual: f64,
    /// Kept parameters reproducing its column, largest coefficient first.
    pub confounded_with: Vec<Confounder>,
}

impl RemovedReport {
    /// One line: what the parameter is confounded with, or that it has no effect.
    pub fn explain(&self) -> String {
        if self.confounded_with.is_empty() {
            format!(
                "{}: no effect on the measured point (zero column)",
                self.name
            )
        } else {
            let with: Vec<String> = self
                .confounded_with
                .iter()
                .map(|c| format!("{:+.3}·{}", c.coefficient, c.name))
                .collect();
            format!("{}: confounded with {}", self.name, with.join(" "))
        }
    }
}

/// The rank analysis of one option.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IdentifiabilityReport {
    /// Candidates before the analysis.
    pub candidates: usize,
    /// Kept parameters.
    pub kept: Vec<ParamKey>,
    /// Removed parameters.
    pub removed: Vec<RemovedReport>,
    /// Rank by SVD (must equal the number kept).
    pub svd_rank: usize,
    /// Condition number of the kept unit columns.
    #[serde(deserialize_with = "json::nan_if_null")]
    pub kept_condition: f64,
}

impl From<&Identifiability> for IdentifiabilityReport {
    fn from(a: &Identifiability) -> Self {
        Self {
            candidates: a.kept.len() + a.removed.len(),
            kept: a.kept.clone(),
            removed: a
                .removed
                .iter()
                .map(|r| RemovedReport {
                    name: r.id,
                    residual: r.residual,
                    confounded_with: r
                        .confounded_with
                        .iter()
                        .map(|(p, c)| Confounder {
                            name: *p,
                            coefficient: *c,
                        })
                        .collect(),
                })
                .collect(),
            svd_rank: a.svd_rank,
            kept_condition: a.kept_condition,
        }
    }
}

/// A measurement named as an outlier, in report units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutlierReport {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// Norm of its residual after the fit, mm.
    pub residual_mm: f64,
    /// Its final weight in the fit.
    pub weight: f64,
}

impl From<&Outlier> for OutlierReport {
    fn from(o: &Outlier) -> Self {
        Self {
            pose: o.pose,
            load_kg: o.load_kg,
            residual_mm: o.residual_m * 1e3,
            weight: o.weight,
        }
    }
}

/// Solver diagnostics, in report units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Last LM termination reason.
    pub termination: String,
    /// Whether LM reported success.
    pub converged: bool,
    /// Residual evaluations.
    pub evaluations: usize,
    /// Active-set rounds.
    pub active_set_rounds: usize,
    /// Trial steps rejected because the deflection could not be solved there.
    pub failed_steps: usize,
    /// Reweighting rounds.
    pub irls_rounds: usize,
    /// Compliances held at a bound (zero or their physical ceiling).
    pub at_bound: Vec<ParamKey>,
    /// Free parameters the data barely determine (see `calib::identify`).
    pub weak: Vec<ParamKey>,
    /// RMS 3D residual of the fit data before, mm.
    pub rms_before_mm: f64,
    /// RMS 3D residual of the fit data after, mm.
    pub rms_after_mm: f64,
    /// Residual deviation per coordinate, mm.
    pub sigma_mm: f64,
    /// Condition number of the scaled Jacobian at the solution.
    #[serde(deserialize_with = "json::nan_if_null")]
    pub condition: f64,
    /// Mean error at each fitted measurement of the fit without it
    /// (leave-one-out, `calib::identify`), mm; `null` when a measurement
    /// alone decides a parameter.
    #[serde(deserialize_with = "json::nan_if_null")]
    pub loo_mean_mm: f64,
    /// Fitted parameters.
    pub parameters: Vec<FittedParam>,
    /// Measurements named as outliers, largest residual first.
    pub outliers: Vec<OutlierReport>,
    /// Each fitted measurement, in the order fitted (since version 5;
    /// empty when read from an older report).
    #[serde(default)]
    pub per_pose: Vec<FitPoseReport>,
    /// How far apart, degrees, two angles of a servo curve have errors
    /// correlated by `e^-½` under the prior: the length the measurements
    /// chose (`calib::fit::grow`), for a fit of servo curves under the
    /// prior; `None` otherwise (and when read from an older report).
    #[serde(default)]
    pub servo_correlation_deg: Option<f64>,
}

/// One fitted measurement: where it was and the arm's error there, in report units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitPoseReport {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// Index of the measured target in the calibration's targets.
    pub target: usize,
    /// The measured point in the arm's frame (the arm file's world, where
    /// the fit runs: registration carried the measurements there), mm.
    pub xyz_mm: [f64; 3],
    /// 3D error of the nominal arm, placed, mm.
    pub before_mm: f64,
    /// 3D residual of the fit, mm.
    pub after_mm: f64,
    /// 3D error of the fit without this measurement (leave-one-out), mm;
    /// `null` when it alone decides a parameter.
    #[serde(deserialize_with = "json::nan_if_null")]
    pub loo_mm: f64,
}

impl From<&Identified> for FitReport {
    fn from(f: &Identified) -> Self {
        let d = &f.diagnostics;
        Self {
            termination: d.termination.clone(),
            converged: d.converged,
            evaluations: d.evaluations,
            active_set_rounds: d.active_set_rounds,
            failed_steps: d.failed_steps,
            irls_rounds: d.irls_rounds,
            at_bound: d.at_bound.clone(),
            weak: f
                .estimates
                .iter()
                .filter(|e| e.weak)
                .map(|e| e.id)
                .collect(),
            rms_before_mm: d.rms_before_m * 1e3,
            rms_after_mm: d.rms_after_m * 1e3,
            sigma_mm: d.sigma_m * 1e3,
            condition: d.condition,
            loo_mean_mm: d.loo_mean_m * 1e3,
            servo_correlation_deg: (f.options.prior
                && f.estimates
                    .iter()
                    .any(|e| matches!(e.id, ParamKey::ServoKnot { .. })))
            .then_some(f.options.servo_correlation_deg),
            parameters: f.estimates.iter().map(FittedParam::from).collect(),
            outliers: f.outliers.iter().map(OutlierReport::from).collect(),
            per_pose: f
                .per_measurement
                .iter()
                .enumerate()
                .map(|(k, p)| FitPoseReport {
                    pose: p.pose,
                    load_kg: p.load_kg,
                    target: p.target,
                    xyz_mm: (p.measured_m * 1e3).into(),
                    before_mm: p.before_m * 1e3,
                    after_mm: p.after_m * 1e3,
                    loo_mm: d.loo_errors_m.get(k).map_or(f64::NAN, |e| e * 1e3),
                })
                .collect(),
        }
    }
}

/// Validation statistics of one measurement set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValidationReport {
    /// Payload, kg.
    pub load_kg: f64,
    /// Nominal model, m.
    pub before: ErrorStats,
    /// Calibrated model, m.
    pub after: ErrorStats,
    /// Mean error reduction, %.
    pub reduction_pct: f64,
    /// Measurements whose calibrated error is far beyond the others', largest first.
    pub outliers: Vec<ValidationOutlier>,
    /// Each measurement's error before and after, in the order validated
    /// (since version 4; empty when read from an older report).
    #[serde(default)]
    pub per_pose: Vec<PoseErrorReport>,
    /// A camera's reprojection errors before and after, px (since version
    /// 6; absent for a tracker).
    #[serde(default)]
    pub pixels: Option<PixelsBeforeAfter>,
}

/// Reprojection errors of a set of corners, px.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PixelErrors {
    /// Corners.
    pub count: usize,
    /// Median, px.
    pub median_px: f64,
    /// Root mean square, px.
    pub rms_px: f64,
    /// 95th percentile, px.
    pub p95_px: f64,
    /// Largest, px.
    pub max_px: f64,
}

impl From<&ErrorStats> for PixelErrors {
    /// Statistics of pixel distances (the fields named `_m` hold pixels).
    fn from(s: &ErrorStats) -> Self {
        Self {
            count: s.count,
            median_px: s.median_m,
            rms_px: s.rms_m,
            p95_px: s.p95_m,
            max_px: s.max_m,
        }
    }
}

/// A camera's reprojection errors at held-out corners, px.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PixelsBeforeAfter {
    /// The nominal arm's.
    pub before: PixelErrors,
    /// The calibrated arm's.
    pub after: PixelErrors,
}

/// The camera an option's fit found (a camera's calibration only).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraReport {
    /// How the camera and the board were carried.
    pub mount: Mount,
    /// Its optical frame (x right, y down, z forward) in the arm's base
    /// frame (eye-to-hand) or in its last frame, the flange (eye-in-hand):
    /// position, mm.
    pub xyz_mm: [f64; 3],
    /// Its roll, pitch and yaw there (`Rz(yaw) Ry(pitch) Rx(roll)`), degrees.
    pub rpy_deg: [f64; 3],
    /// Its rotation as a quaternion, x y z w.
    pub quaternion_xyzw: [f64; 4],
    /// The lens the fit ended with.
    pub lens: LensReport,
    /// The lens the camera setup told.
    pub lens_told: LensReport,
    /// Whether the fit refined the lens (otherwise it is the told one).
    pub lens_refined: bool,
    /// Reprojection errors at the fitted corners, px.
    pub fit_px: PixelErrors,
}

/// A lens: pinhole with OpenCV's radial-tangential distortion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LensReport {
    /// Focal lengths, px.
    pub fx: f64,
    /// See `fx`.
    pub fy: f64,
    /// Principal point, px.
    pub cx: f64,
    /// See `cx`.
    pub cy: f64,
    /// k1, k2, p1, p2, k3.
    pub distortion: [f64; 5],
}

impl From<&Intrinsics> for LensReport {
    fn from(i: &Intrinsics) -> Self {
        Self {
            fx: i.fx,
            fy: i.fy,
            cx: i.cx,
            cy: i.cy,
            distortion: i.distortion,
        }
    }
}

impl CameraReport {
    /// Where it is, as a ROS user publishes it: its optical frame in the
    /// arm's base frame (`base_link`, eye-to-hand) or on the flange
    /// (`flange`, eye-in-hand).
    pub fn static_transform(&self) -> StaticTransform {
        let [x, y, z, w] = self.quaternion_xyzw;
        let rotation =
            nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        StaticTransform {
            parent: match self.mount {
                Mount::EyeToHand => "base_link",
                Mount::EyeInHand => "flange",
            }
            .into(),
            child: "camera_optical_frame".into(),
            child_in_parent: nalgebra::IsometryMatrix3::from_parts(
                nalgebra::Vector3::from(self.xyz_mm.map(|v| v * 1e-3)).into(),
                rotation.to_rotation_matrix(),
            ),
        }
    }

    /// The camera of `r`'s fit, when a camera measured; `None` for a tracker.
    fn of(r: &OptionResult) -> Option<Self> {
        let rig = &r.identified.rig;
        let camera = rig.camera.as_ref()?;
        // The fit's world is the arm's; a standing camera is at
        // `from_world` of it, the base at its frame; a camera on the flange
        // is the tool frame.
        let in_base = match camera.mount {
            Mount::EyeToHand => rig.arm.base.isometry().inverse() * camera.from_world.inverse(),
            Mount::EyeInHand => rig.arm.tool.isometry(),
        };
        let t = in_base.translation.vector * 1e3;
        let (roll, pitch, yaw) = in_base.rotation.euler_angles();
        let q = nalgebra::UnitQuaternion::from_rotation_matrix(&in_base.rotation);
        Some(Self {
            mount: camera.mount,
            xyz_mm: t.into(),
            rpy_deg: [roll, pitch, yaw].map(f64::to_degrees),
            quaternion_xyzw: [q.i, q.j, q.k, q.w],
            lens: (&camera.lens_now()).into(),
            lens_told: (&camera.intrinsics).into(),
            lens_refined: camera.lens.is_some(),
            fit_px: r.fit_px.as_ref()?.into(),
        })
    }
}

/// One validation measurement's error, in report units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseErrorReport {
    /// Pose id (measured under the validation's load).
    pub pose: u32,
    /// Index of the measured target in the calibration's targets.
    pub target: usize,
    /// 3D error of the nominal model, mm.
    pub before_mm: f64,
    /// 3D error of the calibrated model, mm.
    pub after_mm: f64,
    /// The measured point in the arm's frame, as [`FitPoseReport::xyz_mm`]
    /// (since version 5; absent from older reports).
    #[serde(default)]
    pub xyz_mm: Option<[f64; 3]>,
}

/// A validation measurement named as an outlier, in report units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValidationOutlier {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// 3D error of the calibrated model there, mm: the worst of the pose's
    /// outlying measurements.
    pub error_mm: f64,
    /// How many of the pose's measurements are outliers (since version 6;
    /// 1 in older reports, which listed each measurement).
    #[serde(default = "one")]
    pub measurements: usize,
}

/// One measurement, what reports before version 6 listed per outlier.
fn one() -> usize {
    1
}

impl ValidationReport {
    /// Summarises a validation under `load_kg`.
    pub fn new(load_kg: f64, v: &Validation) -> Self {
        Self {
            load_kg,
            before: v.before,
            after: v.after,
            reduction_pct: v.reduction_pct,
            outliers: v
                .outlying_poses()
                .iter()
                .map(|(o, measurements)| ValidationOutlier {
                    pose: o.pose,
                    load_kg: o.load_kg,
                    error_mm: o.after_m * 1e3,
                    measurements: *measurements,
                })
                .collect(),
            per_pose: v
                .per_measurement
                .iter()
                .map(|p| PoseErrorReport {
                    pose: p.pose,
                    target: p.target,
                    before_mm: p.before_m * 1e3,
                    after_mm: p.after_m * 1e3,
                    xyz_mm: Some((p.measured_m * 1e3).into()),
                })
                .collect(),
            pixels: v.pixels.as_ref().map(|[before, after]| PixelsBeforeAfter {
                before: before.into(),
                after: after.into(),
            }),
        }
    }
}

/// Everything about one option.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OptionReport {
    /// The option.
    pub option: ModelOption,
    /// The load whose measurements were fitted, kg.
    pub identify_load_kg: f64,
    /// Rank analysis.
    pub identifiability: IdentifiabilityReport,
    /// Selected pose ids.
    pub selected_poses: Vec<u32>,
    /// ln det of the selection's scaled information matrix.
    #[serde(deserialize_with = "json::nan_if_null")]
    pub log_det: f64,
    /// ln det reached by each DETMAX start.
    #[serde(deserialize_with = "json::nan_if_null_each")]
    pub start_log_dets: Vec<f64>,
    /// Observability indices of the selection.
    pub observability: Observability,
    /// The fit.
    pub fit: FitReport,
    /// How the servo curves' knot spacing was chosen, for an option that fits them.
    pub knots: Option<KnotChoice>,
    /// How the model was chosen, for an option fitted as a ladder of them;
    /// absent in reports written before the choice existed.
    #[serde(default)]
    pub model: Option<ModelChoice>,
    /// Validation on held-out poses under the identification load, if any were held out.
    pub validation: Option<ValidationReport>,
    /// Validation under the other load.
    pub cross_load: Option<ValidationReport>,
    /// Each servo curve the fit identified, joint by joint (since version 5;
    /// empty for an option without servo curves and in older reports).
    #[serde(default)]
    pub servo_curves: Vec<ServoCurveReport>,
    /// The camera the fit found, when a camera measured (since version 6).
    #[serde(default)]
    pub camera: Option<CameraReport>,
}

impl From<&OptionResult> for OptionReport {
    fn from(r: &OptionResult) -> Self {
        Self {
            option: r.option(),
            identify_load_kg: r.identify_load_kg,
            identifiability: (&r.selection.candidates.identifiability).into(),
            selected_poses: r.pose_ids(),
            log_det: r.selection.design.log_det,
            start_log_dets: r.selection.design.start_log_dets.clone(),
            observability: r.selection.observability,
            fit: (&r.identified).into(),
            knots: r.knots.clone(),
            model: r.model.clone(),
            validation: r
                .validation
                .as_ref()
                .map(|v| ValidationReport::new(r.identify_load_kg, v)),
            cross_load: r
                .cross_load
                .as_ref()
                .map(|c| ValidationReport::new(c.load_kg, &c.validation)),
            servo_curves: servo_curves(&r.identified),
            camera: CameraReport::of(r),
        }
    }
}

/// The whole report of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Always [`REPORT_SCHEMA`].
    pub schema: String,
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
    /// Per option, in the order run.
    pub options: Vec<OptionReport>,
    /// DETMAX versus random selection, when computed.
    pub random_baseline: Option<RandomBaseline>,
    /// O1 of DETMAX selections per number of poses, when computed.
    pub o1_vs_poses: Vec<O1Point>,
    /// The error of calibrations from DETMAX selections per number of poses, when computed.
    pub error_vs_poses: Vec<ErrorPoint>,
    /// Where the arm was found in the measurement frame, when `identify`
    /// registered it (since version 4).
    #[serde(default)]
    pub registration: Option<RegistrationReport>,
}

/// A registration of the arm in the measurement frame, in report units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegistrationReport {
    /// The arm's frame 0 in the measurement frame: position, mm.
    pub base_xyz_mm: [f64; 3],
    /// Its roll, pitch and yaw, degrees.
    pub base_rpy_deg: [f64; 3],
    /// Angle between frame 0's `z` and up, degrees.
    pub base_tilt_deg: f64,
    /// RMS distance of the nominal arm, as the arm file places it, from the measured points, mm.
    pub before_rms_mm: f64,
    /// RMS distance after registration over the points kept, mm.
    pub after_rms_mm: f64,
    /// Largest distance after registration over every point, mm.
    pub after_max_mm: f64,
    /// The tool point found in the last DH frame (frame 6 of a six-joint
    /// arm), mm; `None` when the arm file's was kept.
    pub tool_mm: Option<[f64; 3]>,
    /// How far the last link turns over the poses kept (`calib::fit::registration`).
    pub tool_turn: f64,
    /// The turn needed to find the tool point.
    pub tool_turn_needed: f64,
    /// Measurements left out of the registration as far off.
    pub left_out: Vec<LeftOut>,
}

/// A measurement left out of the registration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LeftOut {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
}

impl From<&Registration> for RegistrationReport {
    fn from(reg: &Registration) -> Self {
        let base = frame_of(&reg.base);
        let mm = |v: [f64; 3]| v.map(|x| x * 1e3);
        Self {
            base_xyz_mm: mm(base.xyz),
            base_rpy_deg: base.rpy.map(f64::to_degrees),
            base_tilt_deg: reg.base_tilt_rad.to_degrees(),
            before_rms_mm: reg.before_rms_m * 1e3,
            after_rms_mm: reg.after_rms_m * 1e3,
            after_max_mm: reg.after_max_m * 1e3,
            tool_mm: reg.tool.map(|t| mm(t.into())),
            tool_turn: reg.tool_turn,
            tool_turn_needed: MIN_TOOL_TURN,
            left_out: reg
                .trimmed
                .iter()
                .map(|&(pose, load_kg)| LeftOut { pose, load_kg })
                .collect(),
        }
    }
}

impl Report {
    /// The report of `results` (fitted under `identify_load_kg`, except the
    /// demo's reverse cross-load check, which says its own load), with the
    /// arm's origin, the number of candidate poses and how the measurements
    /// were made; without experiments until the caller adds them.
    pub fn new<'a>(
        arm: String,
        candidates: usize,
        identify_load_kg: f64,
        measurements: serde_json::Value,
        results: impl IntoIterator<Item = &'a OptionResult>,
    ) -> Self {
        Self {
            schema: REPORT_SCHEMA.into(),
            schema_version: REPORT_SCHEMA_VERSION,
            arm,
            candidates,
            identify_load_kg,
            measurements,
            options: results.into_iter().map(OptionReport::from).collect(),
            random_baseline: None,
            o1_vs_poses: Vec::new(),
            error_vs_poses: Vec::new(),
            registration: None,
        }
    }

    /// Reads a report's JSON text back: versions [`REPORT_OLDEST_READ`] to
    /// [`REPORT_SCHEMA_VERSION`], the schema header checked first.
    pub fn parse(text: &str) -> Result<Self, InputError> {
        json::parse_upgrading(
            text,
            REPORT_SCHEMA,
            REPORT_OLDEST_READ..=REPORT_SCHEMA_VERSION,
            // Versions 3 and 4 lack only optional fields.
            |_, _| Ok(()),
        )
    }

    /// The report as pretty JSON.
    pub fn to_json(&self) -> String {
        // Numbers, strings and vectors only: serialisation cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::progress::Silent;
    use crate::calib::results::experiments::{O1_SIZES, o1_vs_poses};
    use crate::calib::testing::{LOAD_KG, calibrate_in_arm_frame, elastic_run, elastic_settings};

    /// The schema header comes from one place, and every list entry is an
    /// object with named fields.
    #[test]
    fn report_json_has_its_header_and_named_entries() {
        let (nominal, poses, all) = elastic_run();
        let r = calibrate_in_arm_frame(&nominal, &all, ModelOption::Elastic, &elastic_settings())
            .unwrap();
        let mut report = Report::new(
            "test arm".into(),
            poses.len(),
            LOAD_KG,
            serde_json::json!({ "source": "test" }),
            [&r],
        );
        report.o1_vs_poses = o1_vs_poses(std::slice::from_ref(&r), &O1_SIZES, &Silent).unwrap();
        let json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
        assert_eq!(json["schema"], REPORT_SCHEMA);
        assert_eq!(json["schema_version"], REPORT_SCHEMA_VERSION);
        let option = &json["options"][0];
        assert_eq!(option["option"], "elastic");
        assert_eq!(option["identify_load_kg"], LOAD_KG);
        assert_eq!(option["identifiability"]["removed"][0]["name"], "k1");
        let point = &json["o1_vs_poses"][0];
        assert_eq!(point["option"], "elastic");
        assert_eq!(point["poses"], 10);
        assert!(point["o1"].as_f64().unwrap() > 0.0);
        let outlier = serde_json::to_value(OutlierReport {
            pose: 3,
            load_kg: LOAD_KG,
            residual_mm: 1.5,
            weight: 1.0,
        })
        .unwrap();
        assert_eq!(outlier["residual_mm"], 1.5);
        let removed = serde_json::to_value(RemovedReport {
            name: ParamKey::from_name("j3.d").unwrap(),
            residual: 0.0,
            confounded_with: vec![Confounder {
                name: ParamKey::from_name("j2.d").unwrap(),
                coefficient: 1.0,
            }],
        })
        .unwrap();
        assert_eq!(removed["confounded_with"][0]["name"], "j2.d");
        assert_eq!(removed["confounded_with"][0]["coefficient"], 1.0);
    }

    /// The report reads back as written (every number exactly, a `null`
    /// as NaN); a version-3 report without the fields added since reads
    /// with them empty; another kind of file is named by its schema.
    #[test]
    fn report_json_reads_back_as_written() {
        let (nominal, poses, all) = elastic_run();
        let r = calibrate_in_arm_frame(&nominal, &all, ModelOption::Elastic, &elastic_settings())
            .unwrap();
        let report = Report::new("test arm".into(), poses.len(), LOAD_KG, 0.into(), [&r]);
        let validation = report.options[0].validation.as_ref().unwrap();
        assert_eq!(validation.per_pose.len(), validation.after.count);
        assert!(validation.per_pose.iter().all(|p| p.xyz_mm.is_some()));
        // Every fitted measurement, with its leave-one-out error.
        let fit = &report.options[0].fit;
        assert_eq!(
            fit.per_pose.len(),
            r.identified.diagnostics.loo_errors_m.len()
        );
        assert!(
            fit.per_pose
                .iter()
                .all(|p| p.loo_mm >= p.after_mm - 1e-9 && p.before_mm > 0.0)
        );
        assert_eq!(Report::parse(&report.to_json()).unwrap(), report);

        let mut json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
        json["schema_version"] = 3.into();
        json["options"][0]["fit"]["loo_mean_mm"] = serde_json::Value::Null;
        json["options"][0]["validation"]
            .as_object_mut()
            .unwrap()
            .remove("per_pose");
        json.as_object_mut().unwrap().remove("registration");
        json["options"][0]["fit"]
            .as_object_mut()
            .unwrap()
            .remove("per_pose");
        json["options"][0]
            .as_object_mut()
            .unwrap()
            .remove("servo_curves");
        let old = Report::parse(&json.to_string()).unwrap();
        assert!(old.options[0].fit.loo_mean_mm.is_nan());
        assert!(
            old.options[0]
                .validation
                .as_ref()
                .unwrap()
                .per_pose
                .is_empty()
        );
        assert!(old.options[0].fit.per_pose.is_empty() && old.options[0].servo_curves.is_empty());

        json["schema"] = "lrmcal-calibration".into();
        let e = Report::parse(&json.to_string()).unwrap_err().to_string();
        assert!(
            e.contains("lrmcal-report") && e.contains("lrmcal-calibration"),
            "{e}"
        );
        json["schema"] = REPORT_SCHEMA.into();
        json["schema_version"] = 2.into();
        let e = Report::parse(&json.to_string()).unwrap_err().to_string();
        assert!(e.contains("schema_version"), "{e}");
    }
}
