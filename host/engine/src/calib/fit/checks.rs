//! Input checks that come before any fitting: measurements that cannot be
//! right for this arm, and measurements of poses that are not candidates.
//! Each names the file, the pose and what was expected.

use model::Arm;

use std::cmp::Ordering;

use nalgebra::Vector3;

use crate::calib::{CalibError, Rig, Sample};
use lrmcal_core::dataset::{Measurement, Pose};

/// A measured point farther than this from the nominal model's prediction is
/// implausible, m. An uncalibrated hobby arm misses by centimetres (the
/// paper: 33 mm mean, the demo's simulated arms about 50 mm and at their
/// worst poses beyond this); 150 mm on many points means a wrong unit, a
/// wrong pose or a wrong arm.
pub const IMPLAUSIBLE_M: f64 = 0.15;

/// Refuses measurements that no plausible version of `nominal` could
/// produce: any point twice [`IMPLAUSIBLE_M`] off (or not finite), or more
/// than a quarter beyond it (a wrong unit, arm or frame puts most points
/// there). Some points just beyond it are a much-bent arm at its worst
/// poses (the project's simulated arms reach 200 mm at a few), or glitches
/// the fit's robust weighting deals with.
pub fn check_plausible(
    nominal: &Arm<f64>,
    measurements: &[Measurement],
    file: &str,
) -> Result<(), CalibError> {
    let samples: Vec<Sample> = measurements.iter().map(Sample::from).collect();
    let predicted = Rig::from(*nominal).tool_points(&samples)?;
    let miss = |(m, p): &(&Measurement, &Vector3<f64>)| (m.position - *p).norm();
    let pairs: Vec<_> = measurements.iter().zip(&predicted).collect();
    // Not finite, or far: NaN compares as neither near nor far, so it is far.
    let far: Vec<_> = pairs
        .iter()
        .filter(|pair| miss(pair).partial_cmp(&IMPLAUSIBLE_M) != Some(Ordering::Less))
        .collect();
    let Some(worst) = far.iter().max_by(|a, b| miss(a).total_cmp(&miss(b))) else {
        return Ok(());
    };
    let refused = miss(worst).partial_cmp(&(2.0 * IMPLAUSIBLE_M)) != Some(Ordering::Less)
        || 4 * far.len() > measurements.len();
    if !refused {
        return Ok(());
    }
    let share = if far.len() > 1 {
        format!(
            "; {} of the {} measurements are over {:.0} mm off",
            far.len(),
            measurements.len(),
            IMPLAUSIBLE_M * 1e3
        )
    } else {
        String::new()
    };
    let (m, p) = **worst;
    implausible(m, p, file, "the nominal arm puts the tool", &share)
}

/// Refuses measurements to validate `calibrated` on when more than half of
/// them are farther than [`IMPLAUSIBLE_M`] from where it puts their
/// targets (a wrong unit, arm or frame, said with the first of them); a
/// few far ones are left to the validation, which names them as outliers.
pub fn check_plausible_calibrated(
    calibrated: &Rig,
    measurements: &[Measurement],
    file: &str,
) -> Result<(), CalibError> {
    let predicted = calibrated.tool_points(&calibrated.samples(measurements)?)?;
    let far: Vec<(&Measurement, &Vector3<f64>)> = measurements
        .iter()
        .zip(&predicted)
        // A non-finite position is far too.
        .filter(|(m, p)| {
            (m.position - *p).norm().partial_cmp(&IMPLAUSIBLE_M) != Some(Ordering::Less)
        })
        .collect();
    if 2 * far.len() <= measurements.len() {
        return Ok(());
    }
    let (m, p) = far[0];
    let share = format!(
        "; {} of the {} measurements are that far: is it the arm, the unit and the frame the \
         calibration was made for?",
        far.len(),
        measurements.len()
    );
    implausible(m, p, file, "the calibrated arm puts its target", &share)
}

/// Refuses `m` when its position is not finite or farther than
/// [`IMPLAUSIBLE_M`] from `p`, where `whose` (words) puts it; `more` ends the message.
fn implausible(
    m: &Measurement,
    p: &Vector3<f64>,
    file: &str,
    whose: &str,
    more: &str,
) -> Result<(), CalibError> {
    let bad = |problem: String| CalibError::BadMeasurement {
        pose: m.pose.id,
        load_kg: m.load_kg,
        file: file.into(),
        problem,
    };
    if !m.position.iter().all(|v| v.is_finite()) {
        return Err(bad("the position is not a finite number".into()));
    }
    let miss = (m.position - p).norm();
    if miss > IMPLAUSIBLE_M {
        let hint = if m.position.norm() < 2e-3 && p.norm() > 0.02 {
            "; the values look like metres where millimetres are expected"
        } else if m.position.norm() > 100.0 * p.norm().max(1e-3) {
            "; the values look a thousand times too large (micrometres?)"
        } else {
            ""
        };
        return Err(bad(format!(
            "it is {:.0} mm from where {whose} ({:.1}, {:.1}, {:.1}) mm; expected within {:.0} mm{hint}{more}",
            miss * 1e3,
            p.x * 1e3,
            p.y * 1e3,
            p.z * 1e3,
            IMPLAUSIBLE_M * 1e3
        )));
    }
    Ok(())
}

/// Refuses measurements whose pose is not among `candidates` (by id, with the
/// same joint angles to 1e-6 rad).
pub fn check_in_candidates(
    measurements: &[Measurement],
    candidates: &[Pose],
    file: &str,
) -> Result<(), CalibError> {
    for m in measurements {
        let detail = match candidates.iter().find(|c| c.id == m.pose.id) {
            None => "no candidate has this id".to_string(),
            Some(c)
                if c.q
                    .iter()
                    .zip(&m.pose.q)
                    .all(|(a, b)| (a - b).abs() <= 1e-6) =>
            {
                continue;
            }
            Some(c) => format!(
                "the candidate with this id has other joint angles ({:?} deg)",
                c.q.map(|v| (v.to_degrees() * 1e3).round() / 1e3)
            ),
        };
        return Err(CalibError::PoseNotInCandidates {
            pose: m.pose.id,
            file: file.into(),
            detail,
        });
    }
    Ok(())
}

/// The load to identify under: `requested` when `file` has measurements
/// under it, else the file's only load; refused when the file has several
/// and none was asked for.
pub fn identification_load(
    loads: &[f64],
    requested: Option<f64>,
    file: &str,
) -> Result<f64, CalibError> {
    match (requested, loads) {
        (Some(l), _) if loads.contains(&l) => Ok(l),
        (Some(l), _) => Err(CalibError::Ambiguous {
            what: format!(
                "identify under {l} kg: {file} has no measurement with that load (it has {loads:?} kg)"
            ),
        }),
        (None, [only]) => Ok(*only),
        (None, _) => Err(CalibError::Ambiguous {
            what: format!(
                "choose the load to identify from: {file} has measurements under {loads:?} kg; pass --load-kg"
            ),
        }),
    }
}

/// Refuses pose ids of the list `list_file` that `measurements_file` has no
/// measurement of under `load_kg` (`measured` are the poses it has under it).
pub fn check_measured(
    ids: &[u32],
    measured: &[Pose],
    list_file: &str,
    measurements_file: &str,
    load_kg: f64,
) -> Result<(), CalibError> {
    match ids.iter().find(|id| !measured.iter().any(|p| p.id == **id)) {
        Some(&pose) => Err(CalibError::PoseNotInCandidates {
            pose,
            file: list_file.into(),
            detail: format!("{measurements_file} has no measurement of it under {load_kg} kg"),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{measure, rigid_nominal, small_samples};

    fn measured() -> Vec<Measurement> {
        measure(&rigid_nominal(), &small_samples(4))
    }

    #[test]
    fn metres_instead_of_millimetres_are_named() {
        let mut m = measured();
        assert!(check_plausible(&rigid_nominal(), &m, "m.csv").is_ok());
        for row in &mut m {
            row.position /= 1000.0;
        }
        let e = check_plausible(&rigid_nominal(), &m, "m.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.csv") && e.contains("pose ") && e.contains("metres"),
            "{e}"
        );
    }

    /// Some points just beyond the limit are an arm at its worst poses;
    /// most are a wrong arm, and one far beyond it is a wrong row.
    #[test]
    fn a_few_points_just_beyond_the_limit_pass_many_do_not() {
        let arm = rigid_nominal();
        let mut m = measure(&arm, &small_samples(40));
        let off = Vector3::new(0.0, 0.0, 1.2 * IMPLAUSIBLE_M);
        for k in 0..10 {
            m[3 * k].position += off;
        }
        assert!(check_plausible(&arm, &m, "m.csv").is_ok());
        m[31].position += off;
        let e = check_plausible(&arm, &m, "m.csv").unwrap_err().to_string();
        assert!(e.contains("11 of the 40 measurements"), "{e}");
        let mut one = measure(&arm, &small_samples(40));
        one[8].position += 2.5 * off;
        let e = check_plausible(&arm, &one, "m.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pose 8") && e.contains("m.csv"), "{e}");
    }

    #[test]
    fn poses_outside_the_candidates_are_named() {
        let m = measured();
        let mut candidates: Vec<Pose> = m.iter().map(|x| x.pose).collect();
        assert!(check_in_candidates(&m, &candidates, "m.csv").is_ok());
        candidates[1].q[3] += 0.1;
        let e = check_in_candidates(&m, &candidates, "m.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("pose 1") && e.contains("other joint angles"),
            "{e}"
        );
        candidates.remove(1);
        let e = check_in_candidates(&m, &candidates, "m.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no candidate has this id"), "{e}");
    }

    #[test]
    fn the_load_is_the_requested_one_or_the_only_one() {
        assert_eq!(identification_load(&[0.0], None, "m.csv").unwrap(), 0.0);
        assert_eq!(
            identification_load(&[0.0, 0.0663], Some(0.0663), "m.csv").unwrap(),
            0.0663
        );
        let e = identification_load(&[0.0, 0.0663], None, "m.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.csv") && e.contains("--load-kg"), "{e}");
        let e = identification_load(&[0.0], Some(0.1), "m.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("0.1 kg") && e.contains("[0.0]"), "{e}");
    }

    #[test]
    fn listed_poses_must_be_measured_under_the_load() {
        let measured: Vec<Pose> = measured().iter().map(|m| m.pose).collect();
        assert!(check_measured(&[0, 3], &measured, "list.csv", "m.csv", 0.0).is_ok());
        let e = check_measured(&[0, 7], &measured, "list.csv", "m.csv", 0.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("pose 7 of list.csv") && e.contains("m.csv has no measurement"),
            "{e}"
        );
    }
}
