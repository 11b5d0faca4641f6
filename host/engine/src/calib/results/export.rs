//! The engine's results in the file formats of [`lrmcal_core::io`]: the formats are
//! plain data owned by `io` (which knows nothing of the engine), and the
//! conversions from the engine's types live here.

use model::Arm;
use nalgebra::Vector3;

use crate::calib::ParamKey;
use crate::calib::fit::identify::{Estimate, Identified};
use crate::calib::fit::pipeline::OptionResult;
use crate::calib::fit::registration::Registration;
use crate::calib::parameters::camera::RigCamera;
use crate::calib::parameters::targets::{Rig, Targets};
use lrmcal_core::camera::{Intrinsics, Mount};
use lrmcal_core::dataset::TargetName;
use lrmcal_core::io::calibration_file::{
    CalibrationFile, ErrorStats, FittedParam, SCHEMA, SCHEMA_VERSION, TargetTool, ValidationSummary,
};

impl From<&Estimate> for FittedParam {
    fn from(e: &Estimate) -> Self {
        Self {
            name: e.id,
            error: e.error,
            value: e.value,
            std: e.std,
        }
    }
}

/// The calibration file of an identification from `nominal` (its rated
/// payload the one the fit's bounds held up to, the identified arm's): `removed` are
/// the candidates held at nominal as unidentifiable, `poses_used` and `loads_kg`
/// the measurements fitted, `fit_residual` the error on them. Targets are
/// listed when the measurements named them, without their held-out error
/// (the caller adds it where there was a validation).
pub fn calibration_file(
    nominal: &Arm<f64>,
    identified: &Identified,
    removed: &[ParamKey],
    poses_used: Vec<u32>,
    loads_kg: Vec<f64>,
    fit_residual: ErrorStats,
    validation: Option<ValidationSummary>,
) -> CalibrationFile {
    CalibrationFile {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        option: identified.option,
        nominal: Arm {
            rated_payload_kg: identified.rig.arm.rated_payload_kg,
            ..*nominal
        },
        arm: identified.rig.arm,
        // A refined lens is the camera's, written as its camera_info (as the
        // registration is the instrument's, not the arm's).
        parameters: identified
            .estimates
            .iter()
            .filter(|e| !matches!(e.id, ParamKey::Lens { .. }))
            .map(FittedParam::from)
            .collect(),
        at_bound: identified
            .diagnostics
            .at_bound
            .iter()
            .map(|p| p.name().into_owned())
            .collect(),
        removed: removed
            .iter()
            .filter(|p| !matches!(p, ParamKey::Lens { .. }))
            .map(|p| p.name().into_owned())
            .collect(),
        poses_used,
        loads_kg,
        fit_residual,
        converged: identified.diagnostics.converged,
        validation,
        registration: None,
        // A board's corners are where its board file puts them, not part of
        // the calibration: its tool point is the board's origin, the arm's.
        targets: if identified.rig.targets.named() && identified.rig.board.is_none() {
            target_tools(identified, &[])
        } else {
            Vec::new()
        },
        // The command that knows the arm's names adds them (`CalibrationFile::for_arm`).
        arm_name: None,
        joint_names: Vec::new(),
    }
}

/// The nominal and the corrected rig of `file`: its arms with its targets'
/// tool points (the nominal arm with the fitted ones: it has no idea where
/// they are). A file without targets is its arms alone. Both rigs are
/// commanded through the nominal arm's servo curves, as its measurements
/// were, and bounded by the nominal arm's bounds.
pub fn rigs_of(file: &CalibrationFile) -> (Rig, Rig) {
    let names: Vec<TargetName> = file
        .targets
        .iter()
        .filter_map(|t| TargetName::from(&t.name).ok())
        .collect();
    let command_curves = file.nominal.joints.map(|j| j.servo);
    let rig = |arm: Arm<f64>| {
        let mut rig = Rig::from(arm);
        rig.command_curves = command_curves;
        rig.bounds = model::bounds::Bounds::of(&file.nominal);
        if !file.targets.is_empty() && names.len() == file.targets.len() {
            rig.targets = Targets::named_as(&names);
            rig.tools = file.targets[1..]
                .iter()
                .map(|t| Vector3::from(t.tool_m))
                .collect();
        }
        rig
    };
    (rig(file.nominal), rig(file.arm))
}

/// [`rigs_of`] for a camera's calibration, measured by a camera of
/// `intrinsics` seeing the board's `corners` (each target's place in the
/// board frame, as `calib::run::CameraInput` holds them), at their pixels,
/// the two carried as `mount` says. `identify --camera` registers the arm
/// in what stands still: eye-to-hand the file's world is the camera's frame
/// and its tool frame the board's; eye-in-hand its world is the board's
/// frame and its tool frame the camera's.
pub fn camera_rigs_of(
    file: &CalibrationFile,
    intrinsics: &Intrinsics,
    corners: &[(TargetName, Vector3<f64>)],
    mount: Mount,
) -> (Rig, Rig) {
    let names: Vec<TargetName> = corners.iter().map(|(name, _)| *name).collect();
    let corners: Vec<Vector3<f64>> = corners.iter().map(|(_, c)| *c).collect();
    let seen = |rig: Rig| Rig {
        command_curves: rig.command_curves,
        bounds: rig.bounds,
        ..Rig::on_board(
            rig.arm,
            Targets::named_as(&names),
            corners.clone(),
            match mount {
                Mount::EyeToHand => {
                    RigCamera::fixed(intrinsics.clone(), nalgebra::IsometryMatrix3::identity())
                }
                Mount::EyeInHand => RigCamera::on_flange(intrinsics.clone()),
            },
        )
    };
    let (nominal, calibrated) = rigs_of(file);
    (seen(nominal), seen(calibrated))
}

/// What an arm source's arm means: a calibration file's corrected rig
/// ([`rigs_of`]: its servo curves say where the nominal curves' pulses go,
/// its targets' tool points), or a nominal arm, commanded through its own curves.
pub fn rig_of(loaded: &lrmcal_core::io::arm_source::LoadedArm) -> Rig {
    match &loaded.calibration {
        Some(file) => rigs_of(file).1,
        None => Rig::from(loaded.arm),
    }
}

/// Every target of `identified` with its tool point, fit residual and
/// held-out error (`validation_per_target`, in target order, when there was one).
pub fn target_tools(
    identified: &Identified,
    validation_per_target: &[ErrorStats],
) -> Vec<TargetTool> {
    let rig = &identified.rig;
    rig.targets
        .names()
        .into_iter()
        .enumerate()
        .map(|(t, name)| TargetTool {
            name,
            tool_m: rig.tool_point(t).map_or(rig.arm.tool.xyz, Into::into),
            fit_residual: identified
                .fit_residual_per_target
                .get(t)
                .copied()
                .unwrap_or_else(|| ErrorStats::of(&[])),
            validation_after: validation_per_target.get(t).copied(),
        })
        .collect()
}

/// The calibration file `identify` writes for `result`, fitted from
/// `nominal` (in the arm file's frame) after `registration`: the arms in the
/// measurement frame, each target's held-out error, and the registration's
/// record (`registered` false when the arm file's base was kept).
pub fn registered_calibration_file(
    registration: &Registration,
    registered: bool,
    nominal: &Arm<f64>,
    result: &OptionResult,
) -> CalibrationFile {
    let mut cal = result_calibration_file(
        &registration.arm_in_measurement_frame(nominal),
        &registration.identified_in_measurement_frame(nominal, &result.identified),
        result,
    );
    let per_target = result
        .validation
        .as_ref()
        .map(|v| v.after_per_target(result.identified.rig.targets.len()))
        .unwrap_or_default();
    for (target, after) in cal.targets.iter_mut().zip(per_target) {
        target.validation_after = Some(after);
    }
    cal.with_registration(registration.record(registered))
}

/// The calibration file of `result`'s run: `identified` (its identification,
/// in the frame of `nominal`) with the parameters it held, the poses and
/// load it used and its validation.
pub fn result_calibration_file(
    nominal: &Arm<f64>,
    identified: &Identified,
    result: &OptionResult,
) -> CalibrationFile {
    let load = result.identify_load_kg;
    calibration_file(
        nominal,
        identified,
        &result.held(),
        result.pose_ids(),
        vec![load],
        result.identified.fit_residual,
        result.validation.as_ref().map(|v| ValidationSummary {
            load_kg: load,
            before: v.before,
            after: v.after,
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::ParamId;

    use crate::calib::ModelOption;
    use crate::calib::fit::identify::{Diagnostics, IdentifyOptions};
    use crate::calib::testing::rigid_nominal;

    #[test]
    fn an_identification_becomes_a_calibration_file_that_reads_back() {
        let nominal = rigid_nominal();
        let k2 = ParamId::from_name("k2").unwrap();
        let k6 = ParamId::from_name("k6").unwrap();
        let identified = Identified {
            option: ModelOption::Elastic,
            options: IdentifyOptions::default(),
            rig: nominal.with_errors(&[k2], &[0.1]).into(),
            estimates: vec![
                Estimate {
                    id: k2.into(),
                    error: 0.1,
                    value: 0.1,
                    std: Some(1e-3),
                    weak: false,
                },
                Estimate {
                    id: k6.into(),
                    error: 0.0,
                    value: 0.0,
                    std: None,
                    weak: false,
                },
            ],
            diagnostics: Diagnostics {
                termination: "Converged".into(),
                converged: true,
                exhausted: false,
                evaluations: 3,
                active_set_rounds: 1,
                failed_steps: 0,
                irls_rounds: 1,
                at_bound: vec![k6.into()],
                rms_before_m: 0.01,
                rms_after_m: 0.001,
                sigma_m: 0.001,
                condition: 1.0,
                loo_mean_m: 0.0012,
                loo_errors_m: vec![0.0012],
            },
            fit_residual: ErrorStats::of(&[0.001]),
            fit_residual_per_target: vec![ErrorStats::of(&[0.001])],
            outliers: vec![],
            per_measurement: vec![],
            covariance: nalgebra::DMatrix::zeros(0, 0),
        };
        let k1 = ParamId::from_name("k1").unwrap();
        let file = calibration_file(
            &nominal,
            &identified,
            &[k1.into()],
            vec![1, 2],
            vec![0.0663],
            ErrorStats::of(&[0.001]),
            None,
        );
        assert_eq!(file.option, ModelOption::Elastic);
        assert_eq!(file.arm, identified.rig.arm);
        assert_eq!(file.at_bound, ["k6"]);
        assert_eq!(file.removed, ["k1"]);
        assert_eq!(
            file.parameters[0],
            FittedParam {
                name: ParamKey::from_name("k2").unwrap(),
                error: 0.1,
                value: 0.1,
                std: Some(1e-3)
            }
        );
        assert_eq!(CalibrationFile::parse(&file.to_json()).unwrap(), file);
    }
}
