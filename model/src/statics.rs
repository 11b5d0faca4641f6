//! The tool point and the gravity torques of one deflected state, in one sweep
//! through the links' own frames.
//!
//! No world frame is built. Gravity is carried forward from the base into the
//! frame of each joint (12 operations per joint); the tool point and the load
//! moment are carried back from the tool (14 and 16). The load moment of joint
//! `i`, `v_i = Σ m (c − o_i)` over the links beyond it and the payload, is the
//! next joint's plus the mass between them; in frame `i` the joint's axis is
//! `z`, so its gravity torque `z · (v_i × g_i)` is `v_x g_y − v_y g_x`. A
//! prismatic joint's is the force along its axis, `M_i g_z` with `M_i` the
//! mass beyond it (the generalised force of its value, as the torque is a
//! revolute joint's).
//! About 50 operations per joint, where world frames and world sums take 90.

use nalgebra::Vector3;

use crate::kinematics::{Chain, tilt_sin_cos, untilt};
use crate::{PerJoint, Real};

/// Gravity torques for one configuration, Nm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Torques<T> {
    /// Torque about joint axis z(i-1) of links i..n and the payload, Nm;
    /// for a prismatic joint the force along the axis, N.
    pub joints: PerJoint<T>,
    /// Torque about the y axis of (tilted) frame 0 of the whole arm and the payload.
    pub base: T,
}

/// One deflected state of the arm as each joint sees it, in its own frame.
///
/// Index `i` is joint `i + 1` of the DH convention: its axis is `z` of frame
/// `i`, through the frame's origin `o_i`; frame 0 is the tilted base frame.
#[derive(Clone, Copy, Debug)]
pub struct Statics<T: Real> {
    /// `(sin, cos)` of each joint's DH angle (`qa_i + theta_i`, or
    /// `theta_i` for a prismatic joint).
    pub joint_sin_cos: PerJoint<(T, T)>,
    /// The payload at the tool, kg.
    pub payload_kg: T,
    /// `(sin, cos)` of the base tilt.
    pub tilt_sin_cos: (T, T),
    /// The tool point relative to `o_i`, in frame `i`, m.
    pub tool_points: PerJoint<Vector3<T>>,
    /// The load moment `v_i` of joint `i`, in frame `i`, kg·m.
    pub moments: PerJoint<Vector3<T>>,
    /// Gravity in frame 0, m/s².
    pub gravity0: Vector3<T>,
    /// The gravity torques.
    pub torques: Torques<T>,
}

impl<T: Real> Statics<T> {
    /// The mass beyond joint `i` of `chain` (the chain these statics are
    /// of), the payload included, kg: the weight a prismatic joint carries.
    pub fn mass_beyond(&self, chain: &Chain<T>, i: usize) -> T {
        chain.links[i..]
            .iter()
            .fold(self.payload_kg, |m, link| m + link.mass)
    }
}

impl<T: Real> Chain<T> {
    /// The statics of the arm at deflected angles `qa`, base tilt `beta` (rad)
    /// and a payload of `payload_kg` at the tool.
    pub fn statics(&self, qa: &[T], beta: T, payload_kg: T) -> Statics<T> {
        let n = self.links.len();
        let joint_sin_cos =
            PerJoint::from_fn(n, |i| self.links[i].placement(qa[i]).0.joint_sin_cos());
        let tilt = tilt_sin_cos(beta);
        // Gravity into frame 0, then into each joint's frame.
        let gravity0 = untilt(&self.base_gravity, tilt);
        let mut gravity = PerJoint::splat(n, gravity0);
        for i in 1..n {
            gravity[i] = self.links[i - 1].rotate_to_child(&gravity[i - 1], joint_sin_cos[i - 1]);
        }
        // The tool point and the load moment, back from the tool.
        let last = &self.links[n - 1];
        let mut point = self.tool_point;
        let mut moment = self.payload_com * payload_kg + last.mass_com;
        let mut mass = payload_kg + last.mass;
        let mut tool_points = PerJoint::splat(n, point);
        let mut moments = PerJoint::splat(n, moment);
        let mut joints = PerJoint::splat(n, T::zero());
        for i in (0..n).rev() {
            let link = &self.links[i];
            let sc = joint_sin_cos[i];
            let d = if link.prismatic {
                link.d + qa[i]
            } else {
                link.d
            };
            point = link.to_parent(&point, sc, (link.a, d));
            let v = link.to_parent(&moment, sc, (link.a * mass, d * mass));
            let g = &gravity[i];
            joints[i] = if link.prismatic {
                mass * g.z
            } else {
                v.x * g.y - v.y * g.x
            };
            tool_points[i] = point;
            moments[i] = v;
            if i > 0 {
                let inner = &self.links[i - 1];
                moment = v + inner.mass_com;
                mass += inner.mass;
            }
        }
        // The base tilts about y0: (v0 × g0)_y.
        let (v0, g0) = (&moments[0], &gravity0);
        let base = v0.z * g0.x - v0.x * g0.z;
        Statics {
            joint_sin_cos,
            payload_kg,
            tilt_sin_cos: tilt,
            tool_points,
            moments,
            gravity0,
            torques: Torques { joints, base },
        }
    }

    /// Gravity torques at deflected angles `qa` and base tilt `beta` with a
    /// payload of `payload_kg` at the tool.
    pub fn gravity_torques(&self, qa: &[T], beta: T, payload_kg: T) -> Torques<T> {
        self.statics(qa, beta, payload_kg).torques
    }
}

#[cfg(test)]
mod tests {
    use crate::Chain;
    use crate::testing::TEST_ARM_JOINTS as JOINTS;
    use crate::testing::{lift_arm, lrm_like_arm, planar_arm, random_lift_q, random_q};
    use approx::assert_relative_eq;
    use nalgebra::Vector3;

    /// A horizontal arm with all twists zero has vertical joint axes: gravity
    /// makes no torque about them, but it tilts the base.
    #[test]
    fn vertical_axes_carry_no_gravity_torque() {
        let chain = planar_arm::<f64>().chain();
        let t = chain.gravity_torques(&[0.4, -0.2, 0.9, 0.1, 0.0, 0.3], 0.0, 0.1);
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
            let t = chain.gravity_torques(&[0.3, pitch, 0.0, 0.0, 0.0, 0.0], 0.0, m);
            // The mass pulls the arm down (negative pitch).
            assert_relative_eq!(
                t.joints[1],
                -m * g * reach * f64::cos(pitch),
                epsilon = 1e-12
            );
            assert_relative_eq!(t.joints[0], 0.0, epsilon = 1e-12);
        }
    }

    /// Gravity's potential energy −Σ m g·c, from the world frames.
    fn potential(chain: &Chain<f64>, qa: &[f64], beta: f64, payload: f64) -> f64 {
        let f = chain.frames(qa, beta);
        let last = &f.frames.last_value();
        let mut weighted = (last.rotation * chain.payload_com + last.translation.vector) * payload;
        for (i, link) in chain.links.iter().enumerate() {
            let frame = &f.frames[i + 1];
            weighted += frame.rotation * link.mass_com + frame.translation.vector * link.mass;
        }
        let g: Vector3<f64> = chain.base.rotation * chain.base_gravity;
        -weighted.dot(&g)
    }

    /// Every torque is minus the derivative of the potential energy along its
    /// angle, and the tool point is the frames'.
    #[test]
    fn torques_are_the_potential_energy_gradient() {
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(12);
        for _ in 0..50 {
            let qa: [f64; JOINTS] = random_q(&mut rng);
            check_gradient(&lrm_like_arm::<f64>().chain(), &qa);
            // A prismatic joint's force and Hayati's twists too.
            check_gradient(&lift_arm::<f64>().chain(), &random_lift_q::<f64>(&mut rng));
        }
    }

    fn check_gradient(chain: &Chain<f64>, qa: &[f64]) {
        let h = 1e-6;
        let chain = *chain;
        let qa: crate::PerJoint<f64> = crate::PerJoint::from_slice(qa).unwrap();
        {
            let (beta, payload) = (0.02, 0.0663);
            let s = chain.statics(&qa, beta, payload);
            let f = chain.frames(&qa, beta);
            assert_relative_eq!(
                f.frames[0] * nalgebra::Point3::from(s.tool_points[0]),
                nalgebra::Point3::from(f.tool_point()),
                epsilon = 1e-14
            );
            for i in 0..qa.len() {
                let (mut up, mut down) = (qa, qa);
                up[i] += h;
                down[i] -= h;
                let slope = (potential(&chain, &up, beta, payload)
                    - potential(&chain, &down, beta, payload))
                    / (2.0 * h);
                assert_relative_eq!(s.torques.joints[i], -slope, epsilon = 1e-7);
            }
            let slope = (potential(&chain, &qa, beta + h, payload)
                - potential(&chain, &qa, beta - h, payload))
                / (2.0 * h);
            assert_relative_eq!(s.torques.base, -slope, epsilon = 1e-7);
        }
    }
}
