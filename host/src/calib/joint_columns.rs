//! The identification Jacobian's columns of the parameters that act on the
//! joint angles only: servo-curve knots (`calib::servo_knots`) and backlash
//! widths (`model::backlash`).
//!
//! Such a parameter moves the angle joint `j` stands at by a known amount
//! per unit at each sample (a knot's interpolation weight; `-s/2` for the
//! play's width, `s = ±1` the way the joint arrived), and nothing else. So
//! its column is the joint-angle column `d point / d q_j` times that weight:
//! one central difference per joint serves every such key of the joint,
//! where differencing each key would cost two model evaluations apiece.

use model::JOINTS;
use nalgebra::{DMatrix, Vector3};

use super::jacobian::points_at;
use super::params::ParamKey;
use super::servo_knots::knot_weight;
use super::{CalibError, Rig, Sample};

/// The joint a key acts on through its angle alone, if it does.
fn joint_of(key: ParamKey) -> Option<usize> {
    match key {
        ParamKey::ServoKnot { joint, .. } | ParamKey::Backlash { joint } => {
            Some(usize::from(joint))
        }
        ParamKey::Arm(_) | ParamKey::TargetTool { .. } | ParamKey::Softening { .. } => None,
    }
}

/// d(standing angle of the key's joint)/d(key) at `sample`.
fn weight(rig: &Rig, key: ParamKey, sample: &Sample) -> f64 {
    match key {
        ParamKey::ServoKnot { joint, knot } => {
            let j = usize::from(joint);
            knot_weight(rig, j, usize::from(knot), sample.q[j])
        }
        ParamKey::Backlash { joint } => -0.5 * sample.approach[usize::from(joint)].sign::<f64>(),
        ParamKey::Arm(_) | ParamKey::TargetTool { .. } | ParamKey::Softening { .. } => 0.0,
    }
}

/// Writes the columns of `ids` that act on a joint angle alone into `j`
/// (3 rows per sample), evaluated at `rig`; returns which columns it wrote.
pub fn fill(
    rig: &Rig,
    ids: &[ParamKey],
    samples: &[Sample],
    j: &mut DMatrix<f64>,
) -> Result<Vec<bool>, CalibError> {
    let done: Vec<bool> = ids.iter().map(|k| joint_of(*k).is_some()).collect();
    if !done.contains(&true) {
        return Ok(done);
    }
    let standing: Vec<[f64; JOINTS]> = samples.iter().map(|s| rig.standing_angles(s)).collect();
    // The balanced central-difference step for an angle (`jacobian::step`).
    let h = f64::EPSILON.cbrt();
    for joint in 0..JOINTS {
        let cols: Vec<usize> = (0..ids.len())
            .filter(|&c| joint_of(ids[c]) == Some(joint))
            .collect();
        if cols.is_empty() {
            continue;
        }
        let shifted = |by: f64| {
            let angles: Vec<[f64; JOINTS]> = standing
                .iter()
                .map(|q| {
                    let mut q = *q;
                    q[joint] += by;
                    q
                })
                .collect();
            points_at(rig, samples, &angles)
        };
        let (up, down) = (shifted(h)?, shifted(-h)?);
        let slope: Vec<Vector3<f64>> = up
            .iter()
            .zip(&down)
            .map(|(u, d)| (u - d) / (2.0 * h))
            .collect();
        for &col in &cols {
            for (i, (s, d)) in samples.iter().zip(&slope).enumerate() {
                let w = weight(rig, ids[col], s);
                j.fixed_view_mut::<3, 1>(3 * i, col).copy_from(&(d * w));
            }
        }
    }
    Ok(done)
}
