//! Validation poses: the few candidates `lrmcal select` sets aside, beside
//! the poses it selects for the fit, to be measured with them and held out
//! of the fit (`identify --poses`), so that before -> after is shown on
//! poses the fit never saw.
//!
//! They are chosen greedily, farthest point first, in joint space: each is
//! the candidate farthest from every pose already chosen, fitted or
//! validating, each joint's angle scaled by its range (limits). So they
//! spread over the servos' ranges and the workspace, and none lies next to
//! a fitted pose, where a fit is right by construction. Ties go to the
//! smaller pose id, so the choice depends on the set of candidates only.

use model::Arm;

use lrmcal_core::dataset::Pose;

/// Validation poses a selection sets aside unless told otherwise.
pub const DEFAULT_VALIDATION_POSES: usize = 10;

/// Up to `n` poses of `candidates` not in `chosen` (pose ids), farthest
/// point first in `arm`'s scaled joint space (module docs), in the order
/// chosen.
pub fn validation_poses(
    arm: &Arm<f64>,
    candidates: &[Pose],
    chosen: &[u32],
    n: usize,
) -> Vec<Pose> {
    let spans: Vec<f64> = arm
        .joints
        .iter()
        .map(|j| {
            let span = j.limits[1] - j.limits[0];
            if span.is_finite() && span > 0.0 {
                span
            } else {
                1.0
            }
        })
        .collect();
    let distance2 = |a: &[f64], b: &[f64]| -> f64 {
        a.iter()
            .zip(b)
            .zip(&spans)
            .map(|((x, y), s)| ((x - y) / s).powi(2))
            .sum()
    };
    let fitted: Vec<&Pose> = candidates
        .iter()
        .filter(|p| chosen.contains(&p.id))
        .collect();
    let mut free: Vec<&Pose> = candidates
        .iter()
        .filter(|p| !chosen.contains(&p.id))
        .collect();
    free.sort_by_key(|p| p.id);
    free.dedup_by_key(|p| p.id);
    // The index of the largest of `score` over the poses still free; the
    // first (smallest id) of equals.
    let farthest = |score: &[f64], taken: &[bool]| {
        (0..free.len())
            .filter(|&k| !taken[k])
            .reduce(|best, k| if score[k] > score[best] { k } else { best })
    };
    let mut taken = vec![false; free.len()];
    let mut out: Vec<Pose> = Vec::new();
    // Each free pose's squared distance to the nearest pose chosen so far.
    let mut nearest: Vec<f64> = free
        .iter()
        .map(|p| {
            fitted
                .iter()
                .map(|f| distance2(&p.q, &f.q))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    if fitted.is_empty() && n > 0 {
        // Nothing chosen yet: the first is the pose farthest from the middle
        // of the joint ranges.
        let middle: Vec<f64> = arm
            .joints
            .iter()
            .map(|j| 0.5 * (j.limits[0] + j.limits[1]))
            .map(|m| if m.is_finite() { m } else { 0.0 })
            .collect();
        let from_middle: Vec<f64> = free.iter().map(|p| distance2(&p.q, &middle)).collect();
        nearest = match farthest(&from_middle, &taken) {
            Some(k) => {
                taken[k] = true;
                out.push(*free[k]);
                free.iter().map(|p| distance2(&p.q, &free[k].q)).collect()
            }
            None => nearest,
        };
    }
    while out.len() < n {
        let Some(k) = farthest(&nearest, &taken) else {
            break;
        };
        taken[k] = true;
        let pose = *free[k];
        out.push(pose);
        for (d, p) in nearest.iter_mut().zip(&free) {
            *d = d.min(distance2(&p.q, &pose.q));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::PerJoint;

    fn arm() -> Arm<f64> {
        lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm
    }

    fn pose(id: u32, deg: [f64; 6]) -> Pose {
        Pose {
            id,
            q: PerJoint::from_slice(&deg.map(f64::to_radians)).unwrap(),
        }
    }

    /// None of the chosen poses is taken again; the first is the candidate
    /// farthest from them, the next the one farthest from both; never more
    /// than asked for or than there are; with none chosen, the first is the
    /// farthest from the middle of the ranges.
    #[test]
    fn farthest_first_and_never_a_chosen_pose() {
        let candidates = vec![
            pose(1, [0.0; 6]),
            pose(2, [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            pose(3, [100.0, 100.0, 0.0, 0.0, 0.0, 0.0]),
            pose(4, [-100.0, -100.0, 0.0, 0.0, 0.0, 0.0]),
            pose(5, [90.0, 100.0, 0.0, 0.0, 0.0, 0.0]),
        ];
        let v = validation_poses(&arm(), &candidates, &[1], 2);
        let ids: Vec<u32> = v.iter().map(|p| p.id).collect();
        // 3 and 4 are equally far from pose 1: the smaller id first; then 4,
        // far from both, rather than 5, next to 3.
        assert_eq!(ids, [3, 4]);
        let all = validation_poses(&arm(), &candidates, &[1], 10);
        assert_eq!(all.len(), 4);
        assert!(all.iter().all(|p| p.id != 1));
        assert!(validation_poses(&arm(), &candidates, &[1], 0).is_empty());
        // The order of the candidates does not matter.
        let mut reversed = candidates.clone();
        reversed.reverse();
        assert_eq!(validation_poses(&arm(), &reversed, &[1], 2), v);
        let first = validation_poses(&arm(), &candidates, &[], 2);
        assert_eq!(first.iter().map(|p| p.id).collect::<Vec<_>>(), [3, 4]);
    }
}
