//! An arm's size relative to the bundled one, measured by gravity torques.
//!
//! Some defaults are a printed arm's and in per-newton-metre units: the
//! simulator's compliance ranges and softening (`sim`), the typical error of
//! a compliance in the rank analysis (`calib::identifiability`). Carried to
//! another arm by the ratio of the bundled arm's largest gravity torque to
//! that arm's, they mean the same sag angles there. For the bundled arm the
//! ratio is exactly 1, so nothing meant for it changes.

use std::sync::OnceLock;

use model::Arm;

use lrmcal_core::io::arm_source::DEFAULT_ARM;

use crate::plan::Levels;

/// The bundled arm's largest gravity torque over that of `arm`, for the
/// joints and for the base (`[joints, base]`); 1 where either carries none.
pub fn torque_ratio_to_bundled(arm: &Arm<f64>) -> [f64; 2] {
    static BUNDLED: OnceLock<[f64; 2]> = OnceLock::new();
    // The bundled arm is text compiled in; its unit tests read it.
    let reference = BUNDLED.get_or_init(|| {
        let bundled = lrmcal_core::io::arm_source::bundled(DEFAULT_ARM)
            .expect("the bundled arm description parses");
        largest_gravity_torques(&bundled.arm)
    });
    let own = largest_gravity_torques(arm);
    [0, 1].map(|i| {
        let ratio = reference[i] / own[i];
        if ratio.is_finite() && ratio > 0.0 {
            ratio
        } else {
            1.0
        }
    })
}

/// The largest gravity torque, Nm, on any joint and on the base of `arm`
/// over the -100/0/+100° grid of every joint, without payload: a property of
/// the arm, not of the poses someone measured.
pub fn largest_gravity_torques(arm: &Arm<f64>) -> [f64; 2] {
    let chain = arm.chain();
    let mut largest = [0.0f64; 2];
    for pose in Levels::paper().grid(arm.joints.len()) {
        let t = chain.gravity_torques(&pose.q, 0.0, 0.0);
        let joint = t.joints.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        largest[0] = largest[0].max(joint);
        largest[1] = largest[1].max(t.base.abs());
    }
    largest
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm(text: &str) -> Arm<f64> {
        lrmcal_core::io::arm_toml::parse(text).unwrap().arm
    }

    #[test]
    fn the_bundled_arm_is_its_own_unit_and_an_industrial_one_is_hundreds_of_times_heavier() {
        let bundled = arm(lrmcal_core::io::arm_source::BUNDLED[0].1);
        assert_eq!(torque_ratio_to_bundled(&bundled), [1.0, 1.0]);
        let ur10 = arm(include_str!("../../tests/data/ur10_like.toml"));
        let [joints, base] = torque_ratio_to_bundled(&ur10);
        let torques = largest_gravity_torques(&ur10);
        // A UR10's shoulder carries about a hundred newton metres.
        assert!((80.0..200.0).contains(&torques[0]), "{torques:?}");
        assert!((1e-3..1e-2).contains(&joints), "{joints}");
        assert!((1e-3..1e-2).contains(&base), "{base}");
        let mut massless = ur10;
        for j in &mut massless.joints {
            j.mass = 0.0;
        }
        assert_eq!(torque_ratio_to_bundled(&massless), [1.0, 1.0]);
    }
}
