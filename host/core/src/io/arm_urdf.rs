//! An arm description read from a URDF: the serial chain from a base link to
//! a tip link ([`super::urdf_chain`]) as the model's arm, with the defaults
//! for what a URDF cannot say.
//!
//! | from the URDF | default |
//! |---|---|
//! | joint origins and axes (as DH), kinds, limits | continuous joints: ±180° |
//! | each DH link's mass and centre of mass (inertials) | |
//! | the tip link's frame as the tool frame (the measured point at its origin) | |
//! | | gravity 9.80665 m/s² along −z of the base link (ROS's z up) |
//! | | compliances 0: a rigid nominal arm, calibration finds them |
//! | | no servo curves: an arm moved by its own controller, calibration-only for the board |
//! | | no collision bodies: the planner tests the arm's skeleton |

use std::path::Path;

use model::{Arm, Frame, Joint, JointKind, MAX_JOINTS, PerJoint};

use super::arm_toml::ArmDescription;
use super::read_text;
use super::urdf_chain::{self, DhChain};
use crate::collision::CollisionSpec;
use crate::error::{Error, InputError, Location, Problem};

/// Gravity of an arm read from a URDF, world frame, m/s².
pub const GRAVITY: [f64; 3] = [0.0, 0.0, -9.80665];

/// Reads the arm from `path`'s chain from `base_link` to `tip_link` (the
/// file's one root link and the one end below it when not given).
pub fn read(
    path: &Path,
    base_link: Option<&str>,
    tip_link: Option<&str>,
) -> Result<ArmDescription, Error> {
    let text = read_text(path)?;
    parse(&text, base_link, tip_link).map_err(|e| e.in_file(path))
}

/// [`read`] from the URDF's text.
pub fn parse(
    text: &str,
    base_link: Option<&str>,
    tip_link: Option<&str>,
) -> Result<ArmDescription, InputError> {
    let (base, tip) = urdf_chain::chain_ends(text, base_link, tip_link)?;
    from_chain(&urdf_chain::parse(text, &base, &tip)?)
}

/// The arm of a chain read from a URDF, with the defaults of the module docs.
pub fn from_chain(chain: &DhChain) -> Result<ArmDescription, InputError> {
    let n = chain.joints.len();
    if !(1..=MAX_JOINTS).contains(&n) {
        return Err(InputError::new(
            Location::default(),
            Problem::Invalid {
                message: format!(
                    "expected a chain of 1 to {MAX_JOINTS} moving joints, found {n}: choose \
                     other base and tip links"
                ),
            },
        ));
    }
    let joints: Vec<Joint<f64>> = chain
        .joints
        .iter()
        .map(|j| Joint {
            theta: j.theta,
            d: j.d,
            a: j.a,
            alpha: j.alpha,
            beta: 0.0,
            kind: match j.kind {
                urdf_chain::JointKind::Revolute => JointKind::Revolute,
                urdf_chain::JointKind::Prismatic => JointKind::Prismatic,
            },
            compliance: 0.0,
            limits: j
                .limits
                .unwrap_or([-std::f64::consts::PI, std::f64::consts::PI]),
            mass: j.mass,
            com: j.com,
            servo: None,
            backlash: 0.0,
            softening: 0.0,
        })
        .collect();
    let frame = |f: &urdf_chain::FrameXyzRpy| Frame {
        xyz: f.xyz,
        rpy: f.rpy,
    };
    let arm = Arm {
        gravity: GRAVITY,
        base: frame(&chain.base),
        base_compliance: 0.0,
        base_softening: 0.0,
        tool: frame(&chain.tool),
        payload_com: [0.0; 3],
        rated_payload_kg: 0.0,
        joints: PerJoint::from_slice(&joints).expect("length checked above"),
    };
    Ok(ArmDescription {
        name: chain.robot.clone(),
        joint_names: chain.joints.iter().map(|j| j.name.clone()).collect(),
        arm,
        collision: CollisionSpec::default(),
        levels_deg: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SO101: &str = include_str!("../../arms/so101/so101.urdf");

    #[test]
    fn the_so101_reads_as_five_revolute_joints_and_its_ends_are_named() {
        let e = parse(SO101, None, None).unwrap_err().to_string();
        assert!(
            e.contains("gripper_frame_link") && e.contains("--tip-link"),
            "{e}"
        );
        let d = parse(SO101, None, Some("gripper_frame_link")).unwrap();
        assert_eq!(d.arm.joints.len(), 5);
        assert!(d.arm.joints.iter().all(|j| j.kind == JointKind::Revolute));
        assert_eq!(d.joint_names[0], "shoulder_pan");
        assert_eq!(d.arm.gravity, GRAVITY);
        // No servo curves: the board refuses it until the arm file gives them.
        assert!(d.arm.joints.iter().all(|j| j.servo.is_none()));
    }

    #[test]
    fn a_chain_with_a_lift_keeps_its_prismatic_joint_and_a_continuous_joint_turns_all_round() {
        let urdf = r#"<robot name="lift">
          <link name="base"/><link name="column"/><link name="arm"/>
          <joint name="lift" type="prismatic"><parent link="base"/><child link="column"/>
            <axis xyz="0 0 1"/><limit lower="0" upper="0.35" effort="1" velocity="1"/></joint>
          <joint name="turn" type="continuous"><parent link="column"/><child link="arm"/>
            <origin xyz="0.1 0 0.2"/><axis xyz="0 0 1"/></joint>
        </robot>"#;
        let d = parse(urdf, None, None).unwrap();
        assert_eq!(d.name, "lift");
        assert_eq!(d.arm.joints[0].kind, JointKind::Prismatic);
        assert_eq!(d.arm.joints[0].limits, [0.0, 0.35]);
        let pi = std::f64::consts::PI;
        assert_eq!(d.arm.joints[1].limits, [-pi, pi]);
        // Lifting by 0.1 m raises the tip by 0.1 m.
        let chain = d.arm.chain();
        let (low, high) = (
            chain.rigid_tool_point(&[0.0, 0.3]),
            chain.rigid_tool_point(&[0.1, 0.3]),
        );
        assert!((high - low - nalgebra::Vector3::new(0.0, 0.0, 0.1)).norm() < 1e-12);
        assert!((low - nalgebra::Vector3::new(0.1, 0.0, 0.2)).norm() < 1e-12);
    }
}
