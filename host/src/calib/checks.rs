//! Input checks that come before any fitting: measurements that cannot be
//! right for this arm, and measurements of poses that are not candidates.
//! Each names the file, the pose and what was expected.

use model::Arm;

use super::jacobian::tool_points;
use super::{CalibError, Sample};
use crate::dataset::{Measurement, Pose};

/// A measured point farther than this from the nominal model's prediction is
/// refused, m. An uncalibrated hobby arm misses by centimetres (the paper: 33 mm
/// mean); 150 mm means a wrong unit, a wrong pose or a wrong arm.
pub const IMPLAUSIBLE_M: f64 = 0.15;

/// Refuses measurements that no plausible version of `nominal` could produce.
pub fn check_plausible(
    nominal: &Arm<f64>,
    measurements: &[Measurement],
    file: &str,
) -> Result<(), CalibError> {
    let samples: Vec<Sample> = measurements.iter().map(Sample::from).collect();
    let predicted = tool_points(nominal, &samples)?;
    for (m, p) in measurements.iter().zip(&predicted) {
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
                "it is {:.0} mm from where the nominal arm puts the tool ({:.1}, {:.1}, {:.1}) mm; expected within {:.0} mm{hint}",
                miss * 1e3,
                p.x * 1e3,
                p.y * 1e3,
                p.z * 1e3,
                IMPLAUSIBLE_M * 1e3
            )));
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{rigid_nominal, small_samples};

    fn measured() -> Vec<Measurement> {
        let arm = rigid_nominal();
        let samples = small_samples(4);
        tool_points(&arm, &samples)
            .unwrap()
            .into_iter()
            .zip(&samples)
            .map(|(p, s)| Measurement {
                pose: Pose { id: s.id, q: s.q },
                load_kg: s.load_kg,
                position: p,
            })
            .collect()
    }

    #[test]
    fn metres_instead_of_millimetres_are_named() {
        let mut m = measured();
        assert!(check_plausible(&rigid_nominal(), &m, "m.csv").is_ok());
        m[2].position /= 1000.0;
        let e = check_plausible(&rigid_nominal(), &m, "m.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.csv") && e.contains("pose 2") && e.contains("metres"),
            "{e}"
        );
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
}
