//! The identification Jacobian's columns of the parameters that act on the
//! joint angles only: servo-curve knots (`calib::servo_knots`) and backlash
//! widths (`model::backlash`).
//!
//! Such a parameter moves the angle joint `j` stands at by a known amount
//! per unit at each sample (a knot's interpolation weight; `-s/2` for the
//! play's width, `s = ±1` the way the joint arrived), and nothing else. So
//! its column is the exact joint-angle column `d point / d q_j`
//! (`jacobian::Slopes::joints`) times that weight.

use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::knot_weight;
use crate::calib::{Rig, Sample};

/// The joint a key acts on through its angle alone, if it does.
pub(crate) fn joint_of(key: ParamKey) -> Option<usize> {
    match key {
        ParamKey::ServoKnot { joint, .. } | ParamKey::Backlash { joint } => {
            Some(usize::from(joint))
        }
        ParamKey::Arm(_)
        | ParamKey::TargetTool { .. }
        | ParamKey::Softening { .. }
        | ParamKey::Lens { .. } => None,
    }
}

/// d(standing angle of the key's joint)/d(key) at `sample`.
pub(crate) fn weight(rig: &Rig, key: ParamKey, sample: &Sample) -> f64 {
    match key {
        ParamKey::ServoKnot { joint, knot } => {
            let j = usize::from(joint);
            knot_weight(rig, j, usize::from(knot), sample.q[j])
        }
        ParamKey::Backlash { joint } => -0.5 * sample.approach[usize::from(joint)].sign::<f64>(),
        ParamKey::Arm(_)
        | ParamKey::TargetTool { .. }
        | ParamKey::Softening { .. }
        | ParamKey::Lens { .. } => 0.0,
    }
}
