//! From a calibration file (JSON, [`crate::io::calibration_file`]) to the
//! payload the board stores.

use model::Arm;
use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::{Calibration, CalibrationFault};

use crate::io::calibration_file::CalibrationFile;

/// The payload for `file`, in single precision, with the home pose `home_rad`.
pub fn payload(
    file: &CalibrationFile,
    home_rad: [f32; 6],
) -> Result<Calibration, CalibrationFault> {
    identified(Calibration {
        id: 0,
        option: file.option,
        nominal: file.nominal.map(|x| x as f32),
        calibrated: file.arm.map(|x| x as f32),
        home_rad,
    })
}

/// `fault` in words; for a servo curve, with the knots of `arm` (the
/// calibrated arm it was found in) so the user sees where the curve turns,
/// for a backlash with its width.
pub fn explain(fault: CalibrationFault, arm: &Arm<f64>) -> String {
    if let CalibrationFault::Backlash { joint } = fault
        && let Some(j) = arm.joints.get(usize::from(joint))
    {
        return format!(
            "{fault}: found {:.3}° (`backlash` of joint {} in the calibrated arm); not sent, the \
             board keeps the calibration it has",
            j.backlash.to_degrees(),
            joint + 1
        );
    }
    let CalibrationFault::ServoCurve { joint, .. } = fault else {
        return fault.to_string();
    };
    let Some(curve) = arm.joints.get(usize::from(joint)).map(|j| j.servo) else {
        return fault.to_string();
    };
    let knots: Vec<String> = curve
        .angles_rad()
        .iter()
        .zip(curve.pulses_us())
        .map(|(a, p)| format!("{:.2}° {p} µs", a.to_degrees()))
        .collect();
    format!(
        "{fault} (knots: {}); not sent: the board must never map angle to pulse non-monotonically",
        knots.join(", ")
    )
}

/// Checks `calibration` and gives it its id: the CRC-32 of the payload
/// encoded with id 0, so the same calibration always has the same id and
/// `status` shows which one is in use.
pub fn identified(mut calibration: Calibration) -> Result<Calibration, CalibrationFault> {
    calibration.check()?;
    calibration.id = 0;
    let mut buf = [0u8; MAX_CALIBRATION_LEN];
    let bytes = calibration
        .encode(&mut buf)
        .map_err(|_| CalibrationFault::NotFinite)?;
    calibration.id = protocol::frame::crc32(bytes);
    Ok(calibration)
}
