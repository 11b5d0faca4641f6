//! Gravity torques on the six joints and on the elastic base.
//!
//! Everything is summed in the world frame, so gravity is automatically "seen
//! through the deflected chain". With `S_i = Σ_{j≥i} m_j c_j + m_p c_p` and
//! `M_i = Σ_{j≥i} m_j + m_p`, the torque of links `i..6` and the payload about
//! the axis `z(i-1)` through `o(i-1)` is `z(i-1) · ((S_i − M_i o(i-1)) × g)`:
//! one pass from the tip, no per-link cross products.

use nalgebra::Vector3;

use crate::kinematics::{Chain, ChainFrames};
use crate::{JOINTS, Real};

/// Gravity torques for one configuration, Nm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Torques<T> {
    /// Torque about joint axis z(i-1) of links i..6 and the payload.
    pub joints: [T; JOINTS],
    /// Torque about the y axis of (tilted) frame 0 of the whole arm and the payload.
    pub base: T,
}

impl<T: Real> Chain<T> {
    /// The load moment of each joint: `v_i = S_i − M_i o(i-1)`, world frame, kg·m.
    ///
    /// `v_i × g` is the gravity moment of links `i..6` and the payload about
    /// `o(i-1)`; joint 1's moment (index 0) is also the whole arm's about the base.
    pub fn load_moments(&self, f: &ChainFrames<T>, payload_kg: T) -> [Vector3<T>; JOINTS] {
        let last = &f.frames[JOINTS];
        let mut weighted: Vector3<T> =
            (last.rotation * self.payload_com + last.translation.vector) * payload_kg;
        let mut mass = payload_kg;
        let mut moments = [Vector3::zeros(); JOINTS];
        for i in (0..JOINTS).rev() {
            let link = &self.links[i];
            let frame = &f.frames[i + 1];
            weighted += frame.rotation * link.mass_com + frame.translation.vector * link.mass;
            mass += link.mass;
            moments[i] = weighted - f.joint_origin(i) * mass;
        }
        moments
    }

    /// Gravity torques at the given frames with a payload of `payload_kg` at the tool.
    pub fn gravity_torques(&self, f: &ChainFrames<T>, payload_kg: T) -> Torques<T> {
        self.torques_from_moments(f, &self.load_moments(f, payload_kg))
    }

    /// Gravity torques from load moments already computed by [`Chain::load_moments`].
    pub fn torques_from_moments(
        &self,
        f: &ChainFrames<T>,
        moments: &[Vector3<T>; JOINTS],
    ) -> Torques<T> {
        let g = self.gravity;
        let joints = core::array::from_fn(|i| f.joint_axis(i).dot(&moments[i].cross(&g)));
        let base = f.base_tilt_axis().dot(&moments[0].cross(&g));
        Torques { joints, base }
    }
}

#[cfg(test)]
mod tests {
    use crate::test_arms::planar_arm;
    use approx::assert_relative_eq;

    /// A horizontal arm with all twists zero has vertical joint axes: gravity
    /// makes no torque about them, but it tilts the base.
    #[test]
    fn vertical_axes_carry_no_gravity_torque() {
        let chain = planar_arm::<f64>().chain();
        let f = chain.frames(&[0.4, -0.2, 0.9, 0.1, 0.0, 0.3], 0.0);
        let t = chain.gravity_torques(&f, 0.1);
        for tau in t.joints {
            assert_relative_eq!(tau, 0.0, epsilon = 1e-12);
        }
        assert!(t.base.abs() > 1e-3);
    }

    /// Hand-derived: a shoulder joint holding a point mass at horizontal reach r
    /// carries torque m g r.
    #[test]
    fn shoulder_torque_matches_hand_derivation() {
        let mut arm = planar_arm::<f64>();
        arm.joints[0].alpha = core::f64::consts::FRAC_PI_2;
        arm.joints[0].a = 0.0;
        for j in &mut arm.joints {
            j.mass = 0.0;
        }
        arm.tool.xyz = [0.0; 3];
        let chain = arm.chain();
        let (m, g, reach) = (0.2, 9.80665, 0.25);
        for pitch in [0.0, 0.5, -1.0] {
            let f = chain.frames(&[0.3, pitch, 0.0, 0.0, 0.0, 0.0], 0.0);
            let t = chain.gravity_torques(&f, m);
            // z1 = (sin yaw, -cos yaw, 0); the mass pulls the arm down (negative pitch).
            assert_relative_eq!(
                t.joints[1],
                -m * g * reach * f64::cos(pitch),
                epsilon = 1e-12
            );
            assert_relative_eq!(t.joints[0], 0.0, epsilon = 1e-12);
        }
    }
}
