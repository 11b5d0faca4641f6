//! Standard Denavit–Hartenberg forward kinematics of the (possibly deflected) chain.
//!
//! [`Chain`] is an [`Arm`] prepared for evaluation: the sines and cosines of
//! every constant angle (DH twists, base and tool rotations) are taken once,
//! which matters on the MCU where each costs a soft-float `sinf`.

use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};

use crate::{Arm, JOINTS, Real};

/// One DH link prepared for evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Link<T: Real> {
    /// DH joint-angle offset, rad.
    pub theta: T,
    /// DH d, m.
    pub d: T,
    /// DH a, m.
    pub a: T,
    /// sin(alpha).
    pub sin_alpha: T,
    /// cos(alpha).
    pub cos_alpha: T,
    /// Joint compliance, rad/Nm.
    pub compliance: T,
    /// Link mass, kg.
    pub mass: T,
    /// Centre of mass in DH frame i, m.
    pub com: Point3<T>,
}

/// An [`Arm`] ready for fast, repeated evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Chain<T: Real> {
    /// World -> frame 0, before the elastic base tilt.
    pub base: IsometryMatrix3<T>,
    /// Frame 6 -> tool point frame.
    pub tool: IsometryMatrix3<T>,
    /// The six links.
    pub links: [Link<T>; JOINTS],
    /// Base tilt compliance about y0, rad/Nm.
    pub base_compliance: T,
    /// Gravity, world frame, m/s².
    pub gravity: Vector3<T>,
    /// Payload centre of mass in the tool frame, m.
    pub payload_com: Point3<T>,
}

/// World poses of every frame of the chain for one set of actual joint angles.
#[derive(Clone, Copy, Debug)]
pub struct ChainFrames<T: Real> {
    /// Frames 0..=6 in the world; frame 0 includes the elastic base tilt.
    pub frames: [IsometryMatrix3<T>; JOINTS + 1],
    /// The tool frame in the world; its origin is the measured point.
    pub tool: IsometryMatrix3<T>,
}

impl<T: Real> ChainFrames<T> {
    /// The measured point (tool frame origin), world frame, m.
    pub fn tool_point(&self) -> Vector3<T> {
        self.tool.translation.vector
    }

    /// Axis z(i-1) of joint `i` (0-based `joint`), world frame.
    pub fn joint_axis(&self, joint: usize) -> Vector3<T> {
        self.frames[joint].rotation.matrix().column(2).into_owned()
    }

    /// Axis y0 of the (tilted) frame 0: the axis of the elastic base tilt, world frame.
    pub fn base_tilt_axis(&self) -> Vector3<T> {
        self.frames[0].rotation.matrix().column(1).into_owned()
    }

    /// Origin of frame i-1 of joint `i` (0-based `joint`), world frame.
    pub fn joint_origin(&self, joint: usize) -> Vector3<T> {
        self.frames[joint].translation.vector
    }
}

/// The DH transform `Rz(angle) Tz(d) Tx(a) Rx(alpha)` with alpha given by its sine and cosine.
#[inline]
pub fn dh_transform<T: Real>(
    angle: T,
    d: T,
    a: T,
    sin_alpha: T,
    cos_alpha: T,
) -> IsometryMatrix3<T> {
    let (st, ct) = angle.sin_cos();
    #[rustfmt::skip]
    let r = Matrix3::new(
        ct, -st * cos_alpha, st * sin_alpha,
        st, ct * cos_alpha, -ct * sin_alpha,
        T::zero(), sin_alpha, cos_alpha,
    );
    IsometryMatrix3::from_parts(
        Translation3::new(a * ct, a * st, d),
        Rotation3::from_matrix_unchecked(r),
    )
}

impl<T: Real> Arm<T> {
    /// Prepares the arm for evaluation.
    pub fn chain(&self) -> Chain<T> {
        Chain {
            base: self.base.isometry(),
            tool: self.tool.isometry(),
            links: self.joints.map(|j| {
                let (sin_alpha, cos_alpha) = j.alpha.sin_cos();
                Link {
                    theta: j.theta,
                    d: j.d,
                    a: j.a,
                    sin_alpha,
                    cos_alpha,
                    compliance: j.compliance,
                    mass: j.mass,
                    com: Point3::from(j.com),
                }
            }),
            base_compliance: self.base_compliance,
            gravity: self.gravity_vector(),
            payload_com: Point3::from(self.payload_com),
        }
    }
}

impl<T: Real> Chain<T> {
    /// Frames of the chain at actual joint angles `qa` and elastic base tilt `beta` (rad).
    pub fn frames(&self, qa: &[T; JOINTS], beta: T) -> ChainFrames<T> {
        let (sb, cb) = beta.sin_cos();
        #[rustfmt::skip]
        let tilt = Rotation3::from_matrix_unchecked(Matrix3::new(
            cb, T::zero(), sb,
            T::zero(), T::one(), T::zero(),
            -sb, T::zero(), cb,
        ));
        let mut frames = [self.base * tilt; JOINTS + 1];
        for (i, link) in self.links.iter().enumerate() {
            let local = dh_transform(
                qa[i] + link.theta,
                link.d,
                link.a,
                link.sin_alpha,
                link.cos_alpha,
            );
            frames[i + 1] = frames[i] * local;
        }
        let tool = frames[JOINTS] * self.tool;
        ChainFrames { frames, tool }
    }

    /// The measured point of the rigid arm (no deflection) at joint angles `q`, m.
    pub fn rigid_tool_point(&self, q: &[T; JOINTS]) -> Vector3<T> {
        self.frames(q, T::zero()).tool_point()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_arms::planar_arm;
    use approx::assert_relative_eq;

    /// A hand-derived check: with all twists zero the first three links form a
    /// planar arm in the x-y plane, lifted by d1.
    #[test]
    fn fk_matches_hand_derived_planar_positions() {
        let arm = planar_arm::<f64>();
        let chain = arm.chain();
        // Link lengths 0.2, 0.15, 0.1, d1 = 0.05, tool z offset 0.03.
        let (l1, l2, l3, d1, tz) = (0.2, 0.15, 0.1, 0.05, 0.03);
        for q in [
            [0.0, 0.0, 0.0],
            [0.5, -0.3, 1.2],
            [-1.4, 0.9, 0.2],
            [3.0, -2.0, 1.0],
        ] {
            let p = chain.rigid_tool_point(&[q[0], q[1], q[2], 0.0, 0.0, 0.0]);
            let (a1, a2, a3) = (q[0], q[0] + q[1], q[0] + q[1] + q[2]);
            let x = l1 * a1.cos() + l2 * a2.cos() + l3 * a3.cos();
            let y = l1 * a1.sin() + l2 * a2.sin() + l3 * a3.sin();
            assert_relative_eq!(p, Vector3::new(x, y, d1 + tz), epsilon = 1e-12);
        }
    }

    /// A hand-derived check through a twisted joint: alpha1 = 90° turns joint 2
    /// into a shoulder pitching in the vertical plane.
    #[test]
    fn fk_matches_hand_derived_shoulder_positions() {
        let mut arm = planar_arm::<f64>();
        arm.joints[0].alpha = core::f64::consts::FRAC_PI_2;
        arm.joints[0].a = 0.0;
        arm.tool.xyz = [0.0; 3];
        let chain = arm.chain();
        let (l2, l3, d1) = (0.15, 0.1, 0.05);
        for (yaw, pitch) in [(0.0, 0.0), (0.7, 0.4), (-1.2, -0.8)] {
            let p = chain.rigid_tool_point(&[yaw, pitch, 0.0, 0.0, 0.0, 0.0]);
            // Links 2 and 3 are straight; the reach is l2 + l3 at elevation `pitch`.
            let r = (l2 + l3) * f64::cos(pitch);
            let expected = Vector3::new(r * yaw.cos(), r * yaw.sin(), d1 + (l2 + l3) * pitch.sin());
            assert_relative_eq!(p, expected, epsilon = 1e-12);
        }
    }

    #[test]
    fn base_frame_moves_and_rotates_the_whole_chain() {
        let mut arm = planar_arm::<f64>();
        let p0 = arm.chain().rigid_tool_point(&[0.3; 6]);
        arm.base = crate::Frame {
            xyz: [0.1, -0.2, 0.3],
            rpy: [0.0, 0.0, core::f64::consts::FRAC_PI_2],
        };
        let p1 = arm.chain().rigid_tool_point(&[0.3; 6]);
        assert_relative_eq!(
            p1,
            Vector3::new(0.1 - p0.y, -0.2 + p0.x, 0.3 + p0.z),
            epsilon = 1e-12
        );
    }
}
