//! When registration cannot place the arm: the usual mistakes tried in
//! turn and the one that explains the misfit named, and the checks that
//! refuse measurements registration cannot use.

use model::Arm;
use model::PerJoint;
use nalgebra::Vector3;

use crate::calib::CalibError;
use lrmcal_core::dataset::Measurement;

use crate::calib::ModelOption;
use crate::calib::fit::checks::IMPLAUSIBLE_M;

use super::align::{rms, trimmed_align};

/// What to check when nothing specific explains a misfit.
pub const GENERIC_HINT: &str = "check that the positions are in millimetres, that the joint columns q1_deg..q6_deg are in the arm's order with its signs and zeros, and that --arm is the arm that was measured";

/// The usual mistake that explains why the nominal arm cannot be placed on
/// `measurements`, if one does: each is undone in turn (positions scaled by
/// 1000 either way, radians in the degree columns, two joint columns swapped,
/// one joint's sign flipped, the frame mirrored) and the one that brings the rigid arm within
/// [`IMPLAUSIBLE_M`] (RMS, after the best rigid motion), and to less than
/// half of the misfit as given, is named.
pub fn diagnose(nominal: &Arm<f64>, measurements: &[Measurement]) -> Option<String> {
    let chain = nominal.chain();
    let measured: Vec<Vector3<f64>> = measurements.iter().map(|m| m.position).collect();
    let misfit =
        |qs: &dyn Fn(&PerJoint<f64>) -> PerJoint<f64>, scale: f64, proper: bool| -> Option<f64> {
            let points: Vec<Vector3<f64>> = measurements
                .iter()
                .map(|m| chain.rigid_tool_point(&qs(&m.pose.q)))
                .collect();
            let scaled: Vec<Vector3<f64>> = measured.iter().map(|m| m * scale).collect();
            let (_, keep, d) = trimmed_align(&points, &scaled, proper)?;
            Some(rms(d
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(e, _)| *e)))
        };
    let same = |q: &PerJoint<f64>| *q;
    let given = misfit(&same, 1.0, true)?;
    let mut tries: Vec<(f64, String)> = Vec::new();
    let mut attempt = |fit: Option<f64>, what: String| {
        if let Some(f) = fit.filter(|f| *f <= IMPLAUSIBLE_M && *f < 0.5 * given) {
            tries.push((f, what));
        }
    };
    attempt(
        misfit(&same, 1e3, true),
        "the positions look like metres in millimetre columns (x_mm, y_mm, z_mm): multiply them by 1000".into(),
    );
    attempt(
        misfit(&same, 1e-3, true),
        "the positions look a thousand times too large (micrometres?): the columns x_mm, y_mm, z_mm take millimetres".into(),
    );
    // Radians in the degree columns were read as degrees: the angles used are
    // the intended ones divided by 180/π.
    let radians_read_as_degrees = |q: &PerJoint<f64>| q.map(f64::to_degrees);
    attempt(
        misfit(&radians_read_as_degrees, 1.0, true),
        "the joint angles look like radians in degree columns (q1_deg..qn_deg): multiply them by 180/π (57.2958)".into(),
    );
    let joints = nominal.joints.len();
    for a in 0..joints {
        for b in a + 1..joints {
            let swapped = |q: &PerJoint<f64>| {
                let mut q = *q;
                q.swap(a, b);
                q
            };
            attempt(
                misfit(&swapped, 1.0, true),
                format!(
                    "the joint columns q{}_deg and q{}_deg look swapped: check the order of the joint columns",
                    a + 1,
                    b + 1
                ),
            );
        }
    }
    for j in 0..joints {
        let flipped = |q: &PerJoint<f64>| {
            let mut q = *q;
            q[j] = -q[j];
            q
        };
        attempt(
            misfit(&flipped, 1.0, true),
            format!(
                "joint {} looks counted the other way: check the sign of q{}_deg (or the arm file's joint {})",
                j + 1,
                j + 1,
                j + 1
            ),
        );
    }
    attempt(
        misfit(&same, 1.0, false),
        "the measurement frame looks mirrored (left-handed: one axis reversed): export the tracker's data in a right-handed frame".into(),
    );
    tries
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(fit, what)| {
            format!(
                "{what} (the arm then fits to {:.1} mm RMS, as given {:.0} mm)",
                fit * 1e3,
                given * 1e3
            )
        })
}

/// Coordinates of a rigid motion: what registration takes from the
/// measurements before the fit sees them.
pub const REGISTRATION_DOF: usize = 6;

/// Refuses a fit of `params` parameters from `poses` registered poses when
/// their `coordinates` (three a point of a tracker, two a pixel of a
/// camera, every target's) do not also cover the base's place that
/// registration took from them: three poses of one point register exactly
/// and would leave the fit nothing to check itself against.
pub fn check_registered_count(
    poses: usize,
    coordinates: usize,
    params: usize,
    option: ModelOption,
) -> Result<(), CalibError> {
    // Fewer coordinates than parameters: the selection and the fit refuse
    // those themselves, with their own counts.
    if coordinates >= params && coordinates < params + REGISTRATION_DOF {
        return Err(CalibError::Registration {
            problem: format!(
                "the {poses} poses give {coordinates} coordinates, fewer than the {REGISTRATION_DOF} the base's place takes plus the {params} parameters of the {option} model; measure more poses, or pass --no-register if the positions are in the arm file's frame",
            ),
        });
    }
    Ok(())
}

/// [`crate::calib::fit::checks::check_plausible`] on registered measurements: a point
/// still 150 mm off after the best rigid motion gets the likely cause
/// ([`diagnose`]) in its message.
pub fn check_plausible_registered(
    nominal: &Arm<f64>,
    measurements: &[Measurement],
    file: &str,
) -> Result<(), CalibError> {
    crate::calib::fit::checks::check_plausible(nominal, measurements, file).map_err(|e| match e {
        CalibError::BadMeasurement {
            pose,
            load_kg,
            file,
            problem,
        } => {
            let hint = diagnose(nominal, measurements).unwrap_or_else(|| GENERIC_HINT.into());
            CalibError::BadMeasurement {
                pose,
                load_kg,
                file,
                problem: format!("{problem}; {hint}"),
            }
        }
        other => other,
    })
}
