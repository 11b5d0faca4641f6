//! What a command does: the joint angles an arm stands at when a pose is
//! commanded, its servos driven through given curves and each joint's play
//! taken up the way it arrived. With the elastic deflection
//! ([`crate::elastic`]) on top, this is what a calibration means: commanded
//! pose, load and approach in, tool point out. The host's identification,
//! prediction and validation all evaluate a calibration through it.
//!
//! The commands of a measurement went out through the curves of the arm the
//! board had then (the nominal arm's, for a calibration's own measurements):
//! pulse `p = sent(q)`. The arm's own curve says which angle each pulse
//! really reaches, so the joint drives to `own⁻¹(p)`; where the two curves
//! are the same it drives to `q` exactly.

use crate::backlash::{Approach, settled};
use crate::{Arm, PerJoint, Real, ServoCurve};

/// The joint angles the servos of `arm` drive to when commanded `q` (rad)
/// through the curves `sent`, rad. A joint without a curve, on either
/// side, is moved by its own controller: it reaches its command.
pub fn reached<T: Real>(arm: &Arm<T>, sent: &[Option<ServoCurve<T>>], q: &[T]) -> PerJoint<T> {
    PerJoint::from_fn(arm.joints.len(), |j| {
        match (&sent[j], &arm.joints[j].servo) {
            (Some(sent), Some(own)) if sent != own => own.angle(sent.pulse_us(q[j])),
            _ => q[j],
        }
    })
}

/// The joint angles `arm` stands at, before it deflects, when commanded `q`
/// through the curves `sent`, each joint arriving the way `approach` says:
/// [`reached`], short of it or beyond by half the play
/// ([`crate::backlash::settled`]).
pub fn standing<T: Real>(
    arm: &Arm<T>,
    sent: &[Option<ServoCurve<T>>],
    q: &[T],
    approach: &[Approach],
) -> PerJoint<T> {
    let reached = reached(arm, sent, q);
    PerJoint::from_fn(arm.joints.len(), |j| {
        settled(reached[j], arm.joints[j].backlash, approach[j])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::lrm_like_arm;
    use crate::{ServoCurve, real};

    #[test]
    fn own_curves_reach_the_command_and_play_moves_it_by_half() {
        let mut arm = lrm_like_arm::<f64>();
        let sent = arm.joints.map(|j| j.servo);
        let q = [0.1, -0.4, 0.7, 0.0, 1.2, -1.0];
        assert_eq!(reached(&arm, &sent, &q), q);
        arm.joints[2].backlash = 0.02;
        let rising = [Approach::Rising; 6];
        let s = standing(&arm, &sent, &q, &rising);
        assert_eq!(s[2], q[2] - 0.01);
        assert_eq!(s[1], q[1]);
    }

    #[test]
    fn a_calibrated_curve_says_where_the_nominal_pulse_goes() {
        let mut arm = lrm_like_arm::<f64>();
        let sent = arm.joints.map(|j| j.servo);
        // Joint 4's servo really reaches 2° more at every pulse of the upper half.
        let c = ServoCurve::<f64>::nominal();
        let shifted: [f64; 3] = [
            c.angles_rad()[0],
            c.angles_rad()[1],
            c.angles_rad()[2] + real::<f64>(2f64.to_radians()),
        ];
        arm.joints[3].servo = ServoCurve::new(&shifted, c.pulses_us()).ok();
        let q = [0.0, 0.0, 0.0, 50f64.to_radians(), 0.0, 0.0];
        let r = reached(&arm, &sent, &q);
        assert!(
            (r[3] - 51f64.to_radians()).abs() < 1e-12,
            "{}",
            r[3].to_degrees()
        );
        // A joint without a curve on either side reaches its command.
        arm.joints[3].servo = None;
        assert_eq!(reached(&arm, &sent, &q)[3], q[3]);
        assert_eq!(r[0], 0.0);
    }
}
