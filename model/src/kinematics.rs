//! Standard Denavit–Hartenberg forward kinematics of the (possibly deflected) chain.
//!
//! [`Chain`] is an [`Arm`] prepared for evaluation: the sines and cosines of
//! every constant angle (DH twists, base and tool rotations) are taken once,
//! which matters on the MCU where each costs a soft-float `sinf`.

use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};

use crate::{Arm, JointKind, PerFrame, PerJoint, Real};

/// One DH link prepared for evaluation.
#[derive(Clone, Copy, Debug, Default)]
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
    /// sin(beta), Hayati's twist; exactly 0 for a DH link.
    pub sin_beta: T,
    /// cos(beta); exactly 1 for a DH link.
    pub cos_beta: T,
    /// Whether `beta` is not zero: a bool, so that a DH link's test costs
    /// no float comparison (a library call on the MCU).
    pub twisted: bool,
    /// Whether the joint slides (its value adds to `d`) rather than turns
    /// (its value adds to `theta`).
    pub prismatic: bool,
    /// Joint compliance, rad/Nm (m/N for a prismatic joint).
    pub compliance: T,
    /// How the compliance changes with the torque, 1/Nm: the joint yields
    /// `compliance (1 + softening |tau|)` rad per Nm at torque `tau`
    /// (negative: it stiffens), [`crate::arm::Joint::softening`]; 0 is a
    /// linear spring (`crate::elastic`).
    pub softening: T,
    /// Link mass, kg.
    pub mass: T,
    /// Mass times centre of mass in DH frame i, kg·m.
    pub mass_com: Vector3<T>,
}

/// An [`Arm`] ready for fast, repeated evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Chain<T: Real> {
    /// World -> frame 0, before the elastic base tilt.
    pub base: IsometryMatrix3<T>,
    /// The measured tool point in the last frame, m.
    pub tool_point: Vector3<T>,
    /// The links, base to tip.
    pub links: PerJoint<Link<T>>,
    /// Base tilt compliance about y0, rad/Nm.
    pub base_compliance: T,
    /// The base's [`Link::softening`], 1/Nm.
    pub base_softening: T,
    /// Gravity in the base frame (before the elastic tilt), m/s².
    pub base_gravity: Vector3<T>,
    /// Payload centre of mass in the last frame, m.
    pub payload_com: Vector3<T>,
}

/// World poses of every frame of the chain for one set of actual joint angles.
#[derive(Clone, Copy, Debug)]
pub struct ChainFrames<T: Real> {
    /// Frames 0..=n in the world; frame 0 includes the elastic base tilt.
    pub frames: PerFrame<IsometryMatrix3<T>>,
    /// The measured point (tool frame origin), world frame, m.
    pub tool_point: Vector3<T>,
}

impl<T: Real> ChainFrames<T> {
    /// The measured point (tool frame origin), world frame, m.
    pub fn tool_point(&self) -> Vector3<T> {
        self.tool_point
    }
}

/// Frame i from frame i-1: `parent · Rz(angle) Tz(d) Tx(a) Rx(alpha) Ry(beta)`,
/// `angle` and `d` the link's at its joint value ([`Link::placement`]).
///
/// Worked column by column (`Rz` mixes the first two columns, `Rx` the last
/// two, `Ry` the first and last): 36 multiplications where a general product
/// of poses takes 63, 12 more for a link with Hayati's twist.
#[inline]
pub fn dh_child<T: Real>(
    parent: &IsometryMatrix3<T>,
    (angle, d): (T, T),
    link: &Link<T>,
) -> IsometryMatrix3<T> {
    let (st, ct) = angle.joint_sin_cos();
    let r = parent.rotation.matrix();
    let (x, y, z) = (r.column(0), r.column(1), r.column(2));
    let x1 = x * ct + y * st;
    let y1 = y * ct - x * st;
    let y2 = y1 * link.cos_alpha + z * link.sin_alpha;
    let z2 = z * link.cos_alpha - y1 * link.sin_alpha;
    let t = parent.translation.vector + z * d + x1 * link.a;
    let (x3, z3) = if !link.twisted {
        (x1, z2)
    } else {
        (
            x1 * link.cos_beta - z2 * link.sin_beta,
            x1 * link.sin_beta + z2 * link.cos_beta,
        )
    };
    IsometryMatrix3::from_parts(
        Translation3::from(t),
        Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x3, y2, z3])),
    )
}

impl<T: Real> Link<T> {
    /// The link's DH angle and offset `(theta, d)` at joint value `q`: `q`
    /// turns a revolute joint and slides a prismatic one.
    #[inline]
    pub fn placement(&self, q: T) -> (T, T) {
        if self.prismatic {
            (self.theta, self.d + q)
        } else {
            (self.theta + q, self.d)
        }
    }

    /// `Ry(beta) v`, exactly `v` for a DH link.
    #[inline]
    fn twist_y(&self, v: &Vector3<T>) -> Vector3<T> {
        if !self.twisted {
            *v
        } else {
            Vector3::new(
                self.cos_beta * v.x + self.sin_beta * v.z,
                v.y,
                self.cos_beta * v.z - self.sin_beta * v.x,
            )
        }
    }

    /// `Ry(beta)ᵀ v`, exactly `v` for a DH link.
    #[inline]
    fn untwist_y(&self, v: &Vector3<T>) -> Vector3<T> {
        if !self.twisted {
            *v
        } else {
            Vector3::new(
                self.cos_beta * v.x - self.sin_beta * v.z,
                v.y,
                self.cos_beta * v.z + self.sin_beta * v.x,
            )
        }
    }

    /// A point or moment of frame i+1 in frame i: `Rz(angle) (Rx(alpha)
    /// Ry(beta) v + (x, 0, z))`, with `(x, z)` the link's `(a, d)` for a
    /// point or `m (a, d)` for a moment of mass `m`; `(sin, cos)` of the
    /// joint's DH angle. 14 operations for a DH link.
    #[inline]
    pub fn to_parent(&self, v: &Vector3<T>, (s, c): (T, T), (x, z): (T, T)) -> Vector3<T> {
        let v = self.twist_y(v);
        let wx = v.x + x;
        let wy = v.y * self.cos_alpha - v.z * self.sin_alpha;
        let wz = v.y * self.sin_alpha + v.z * self.cos_alpha + z;
        Vector3::new(c * wx - s * wy, s * wx + c * wy, wz)
    }

    /// A direction of frame i+1 in frame i: `Rz(angle) Rx(alpha) Ry(beta) v`.
    /// 12 operations for a DH link.
    #[inline]
    pub fn rotate_to_parent(&self, v: &Vector3<T>, (s, c): (T, T)) -> Vector3<T> {
        let v = self.twist_y(v);
        let wy = v.y * self.cos_alpha - v.z * self.sin_alpha;
        let wz = v.y * self.sin_alpha + v.z * self.cos_alpha;
        Vector3::new(c * v.x - s * wy, s * v.x + c * wy, wz)
    }

    /// [`Link::rotate_to_parent`] of a direction `(x, y, 0)`. 8 operations
    /// for a DH link.
    #[inline]
    pub fn rotate_to_parent_xy(&self, x: T, y: T, sc: (T, T)) -> Vector3<T> {
        if self.twisted {
            return self.rotate_to_parent(&Vector3::new(x, y, T::zero()), sc);
        }
        let (s, c) = sc;
        let wy = y * self.cos_alpha;
        Vector3::new(c * x - s * wy, s * x + c * wy, y * self.sin_alpha)
    }

    /// A direction of frame i in frame i+1: `Ry(beta)ᵀ Rx(alpha)ᵀ Rz(angle)ᵀ v`.
    /// 12 operations for a DH link.
    #[inline]
    pub fn rotate_to_child(&self, v: &Vector3<T>, (s, c): (T, T)) -> Vector3<T> {
        let hx = c * v.x + s * v.y;
        let hy = c * v.y - s * v.x;
        self.untwist_y(&Vector3::new(
            hx,
            hy * self.cos_alpha + v.z * self.sin_alpha,
            v.z * self.cos_alpha - hy * self.sin_alpha,
        ))
    }
}

impl<T: Real> Arm<T> {
    /// Prepares the arm for evaluation.
    pub fn chain(&self) -> Chain<T> {
        let tool = self.tool.isometry();
        let base = self.base.isometry();
        Chain {
            base,
            tool_point: tool.translation.vector,
            links: self.joints.map(|j| {
                let (sin_alpha, cos_alpha) = j.alpha.sin_cos();
                // Exactly (0, 1) for a DH link, so it costs no rotation.
                let (sin_beta, cos_beta) = if j.beta == T::zero() {
                    (T::zero(), T::one())
                } else {
                    j.beta.sin_cos()
                };
                Link {
                    theta: j.theta,
                    d: j.d,
                    a: j.a,
                    sin_alpha,
                    cos_alpha,
                    sin_beta,
                    cos_beta,
                    twisted: j.beta != T::zero(),
                    prismatic: j.kind == JointKind::Prismatic,
                    compliance: j.compliance,
                    softening: j.softening,
                    mass: j.mass,
                    mass_com: Vector3::from(j.com) * j.mass,
                }
            }),
            base_compliance: self.base_compliance,
            base_softening: self.base_softening,
            base_gravity: base.rotation.inverse() * self.gravity_vector(),
            payload_com: (tool * Point3::from(self.payload_com)).coords,
        }
    }
}

impl<T: Real> Chain<T> {
    /// Frames of the chain at actual joint angles `qa` and elastic base tilt `beta` (rad).
    pub fn frames(&self, qa: &[T], beta: T) -> ChainFrames<T> {
        let base = self.tilted_base(tilt_sin_cos(beta));
        let mut frames = PerFrame::splat(self.links.len() + 1, base);
        for (i, link) in self.links.iter().enumerate() {
            frames[i + 1] = dh_child(&frames[i], link.placement(qa[i]), link);
        }
        let last = &frames.last_value();
        let tool_point = last.rotation * self.tool_point + last.translation.vector;
        ChainFrames { frames, tool_point }
    }

    /// Frame 0 in the world, tilted about its own y axis by the angle of `(sin, cos)`.
    fn tilted_base(&self, (sb, cb): (T, T)) -> IsometryMatrix3<T> {
        if sb == T::zero() {
            return self.base;
        }
        let r = self.base.rotation.matrix();
        let (x, z) = (r.column(0), r.column(2));
        // base · Ry(beta): x' = cb x − sb z, z' = sb x + cb z.
        let columns = [x * cb - z * sb, r.column(1).into_owned(), x * sb + z * cb];
        IsometryMatrix3::from_parts(
            self.base.translation,
            Rotation3::from_matrix_unchecked(Matrix3::from_columns(&columns)),
        )
    }

    /// A world point in the base frame (before the elastic tilt), m.
    pub fn to_base(&self, world: &Vector3<T>) -> Vector3<T> {
        self.base
            .inverse_transform_point(&Point3::from(*world))
            .coords
    }

    /// The measured point of the rigid arm (no deflection) at joint angles `q`, m.
    pub fn rigid_tool_point(&self, q: &[T]) -> Vector3<T> {
        (self.base * Point3::from(self.rigid_base_point(q))).coords
    }

    /// [`Chain::rigid_tool_point`] in the base frame, m.
    ///
    /// Carried from the tool back to the base with [`Link::to_parent`], so no
    /// frame is built: 14 operations per joint where [`Chain::frames`] takes 48.
    pub fn rigid_base_point(&self, q: &[T]) -> Vector3<T> {
        let mut p = self.tool_point;
        for (link, &qi) in self.links.iter().zip(q).rev() {
            let (angle, d) = link.placement(qi);
            p = link.to_parent(&p, angle.joint_sin_cos(), (link.a, d));
        }
        p
    }
}

/// A vector of the base frame in the tilted frame 0: `Ry(beta)ᵀ v`, with
/// `(sin, cos)` of the tilt.
#[inline]
pub fn untilt<T: Real>(v: &Vector3<T>, (s, c): (T, T)) -> Vector3<T> {
    Vector3::new(c * v.x - s * v.z, v.y, s * v.x + c * v.z)
}

/// `(sin, cos)` of the base tilt; exactly `(0, 1)` for no tilt, so a rigid
/// base costs no rotation.
pub fn tilt_sin_cos<T: Real>(beta: T) -> (T, T) {
    if beta == T::zero() {
        (T::zero(), T::one())
    } else {
        beta.joint_sin_cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::planar_arm;
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

    /// The tool point carried back to the base is the one of the frames.
    #[test]
    fn rigid_tool_point_matches_the_frames() {
        let chain = crate::testing::lrm_like_arm::<f64>().chain();
        let lift = crate::testing::lift_arm::<f64>().chain();
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(5);
        for _ in 0..100 {
            let q = crate::testing::random_q(&mut rng);
            let frames = chain.frames(&q, 0.0).tool_point();
            assert_relative_eq!(chain.rigid_tool_point(&q), frames, epsilon = 1e-14);
            let q = crate::testing::random_lift_q(&mut rng);
            let frames = lift.frames(&q, 0.0).tool_point();
            assert_relative_eq!(lift.rigid_tool_point(&q), frames, epsilon = 1e-14);
        }
    }

    /// Hand-derived: a prismatic joint lifts the whole arm along its axis by
    /// its value, and Hayati's twist tilts the next axis about y.
    #[test]
    fn a_lift_moves_the_arm_along_its_axis_and_beta_tilts_about_y() {
        let mut arm = planar_arm::<f64>();
        arm.joints[0].kind = crate::JointKind::Prismatic;
        let chain = arm.chain();
        let q = [0.0, 0.4, -0.3, 0.2, 0.0, 0.0];
        let mut lifted = q;
        lifted[0] = 0.07;
        let (p, up) = (chain.rigid_tool_point(&q), chain.rigid_tool_point(&lifted));
        assert_relative_eq!(up - p, Vector3::new(0.0, 0.0, 0.07), epsilon = 1e-14);
        // One link of length a along x, then a point 0.1 up its z: tilting
        // the link's frame by beta about y moves the point by 0.1 sin(beta) in x.
        let mut arm = planar_arm::<f64>();
        for j in &mut arm.joints {
            *j = crate::Joint {
                a: 0.0,
                d: 0.0,
                ..*j
            };
        }
        arm.tool.xyz = [0.0, 0.0, 0.1];
        arm.joints[5].beta = 0.2;
        let p = arm.chain().rigid_tool_point(&[0.0; 6]);
        assert_relative_eq!(
            p,
            Vector3::new(0.1 * 0.2f64.sin(), 0.0, 0.1 * 0.2f64.cos()),
            epsilon = 1e-14
        );
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
