//! Re-teaching the tool points after a tool change (`identify --tool-only`):
//! every target's tool point fitted with the arm of an earlier calibration
//! held fixed, and that calibration written again with the new points.

use crate::calib::CalibError;
use crate::calib::fit::guard;
use crate::calib::fit::identify::{IdentifyOptions, identify};
use crate::calib::parameters::targets::{Rig, Targets, tool_keys};
use crate::calib::results::export::target_tools;
use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::CalibrationFile;

/// `old` with the tool point of every target of `measurements` (all under
/// `load`, whose targets are `targets`) fitted again, its arm held fixed. A
/// target `old` knows starts from where it was.
pub fn retaught(
    old: CalibrationFile,
    targets: Targets,
    measurements: &[Measurement],
    load: f64,
    options: &IdentifyOptions,
) -> Result<CalibrationFile, CalibError> {
    let mut rig = Rig::new(old.arm, targets);
    for (t, name) in rig.targets.names().iter().enumerate().skip(1) {
        if let Some(known) = old.targets.iter().find(|k| &k.name == name) {
            rig.tools[t - 1] = known.tool_m.into();
        }
    }
    let keys = tool_keys(0..rig.targets.len());
    let fit = identify(&rig, old.option, &keys, measurements, options)?;
    guard::check(old.option, &old.arm, &fit, None)?;
    let mut poses: Vec<u32> = measurements.iter().map(|m| m.pose.id).collect();
    poses.dedup();
    let mut parameters: Vec<_> = old
        .parameters
        .iter()
        .filter(|p| !p.name.is_tool())
        .cloned()
        .collect();
    parameters.extend(fit.estimates.iter().map(Into::into));
    Ok(CalibrationFile {
        arm: fit.rig.arm,
        parameters,
        poses_used: poses,
        loads_kg: vec![load],
        fit_residual: fit.fit_residual,
        converged: fit.diagnostics.converged,
        // Every measurement fitted the tool points: none is left to validate on.
        validation: None,
        targets: target_tools(&fit, &[]),
        ..old
    })
}
