//! Test fixtures shared by every crate of the workspace (feature `testing`;
//! the model's own unit tests always have them): the LRM-like test arm, a
//! planar arm, random joint angles and random error vectors.
//!
//! One definition each, so a test in `host`, `firmware` or `tests` that names
//! "the test arm" means the same numbers as the model's own tests. Not for
//! production code: these arms are invented, not measured.

use core::ops::Range;

use rand::Rng;

use crate::params::ParamKind;
use crate::{Arm, Frame, Joint, ParamId, PerJoint, Real, ServoCurve, param_count, real};

/// Joints of the test arms ([`planar_arm`], [`lrm_like_arm`]).
pub const TEST_ARM_JOINTS: usize = 6;

/// Error parameters of the test arms.
pub const TEST_ARM_PARAMS: usize = param_count(TEST_ARM_JOINTS);

fn joint<T: Real>(
    theta: f64,
    d: f64,
    a: f64,
    alpha: f64,
    k: f64,
    mass: f64,
    com: [f64; 3],
) -> Joint<T> {
    Joint {
        theta: real(theta),
        d: real(d),
        a: real(a),
        alpha: real(alpha),
        beta: T::zero(),
        kind: crate::JointKind::Revolute,
        compliance: real(k),
        limits: [real(-1.75), real(1.75)],
        mass: real(mass),
        com: com.map(real),
        servo: Some(ServoCurve::nominal()),
        backlash: real(0.0),
        softening: real(0.0),
    }
}

/// All twists zero: joints 1–3 form a planar arm (a = 0.2, 0.15, 0.1; d1 = 0.05).
pub fn planar_arm<T: Real>() -> Arm<T> {
    let z = [0.0; 3];
    Arm {
        gravity: [0.0, 0.0, -9.80665].map(real),
        base: Frame::identity(),
        base_compliance: T::zero(),
        base_softening: T::zero(),
        tool: Frame {
            xyz: [0.0, 0.0, 0.03].map(real),
            rpy: [T::zero(); 3],
        },
        payload_com: [T::zero(); 3],
        rated_payload_kg: T::zero(),
        joints: PerJoint::from([
            joint(0.0, 0.05, 0.2, 0.0, 0.0, 0.1, [-0.1, 0.0, 0.0]),
            joint(0.0, 0.0, 0.15, 0.0, 0.0, 0.1, [-0.07, 0.0, 0.0]),
            joint(0.0, 0.0, 0.1, 0.0, 0.0, 0.1, [-0.05, 0.0, 0.0]),
            joint(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, z),
            joint(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, z),
            joint(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, z),
        ]),
    }
}

/// An elbow arm with a spherical wrist, about 0.44 m reach, compliant joints
/// and base: LRM-like (the real arm's numbers are not published).
pub fn lrm_like_arm<T: Real>() -> Arm<T> {
    let h = core::f64::consts::FRAC_PI_2;
    Arm {
        gravity: [0.0, 0.0, -9.80665].map(real),
        base: Frame::identity(),
        base_compliance: real(0.03),
        base_softening: T::zero(),
        tool: Frame {
            xyz: [0.0, 0.0, 0.04].map(real),
            rpy: [T::zero(); 3],
        },
        payload_com: [T::zero(); 3],
        rated_payload_kg: T::zero(),
        joints: PerJoint::from([
            joint(0.0, 0.09, 0.0, h, 0.02, 0.15, [0.0, -0.03, 0.0]),
            joint(h, 0.0, 0.17, 0.0, 0.12, 0.12, [-0.085, 0.0, 0.01]),
            joint(h, 0.0, 0.0, h, 0.08, 0.10, [0.0, 0.0, 0.02]),
            joint(0.0, 0.17, 0.0, -h, 0.05, 0.08, [0.0, 0.08, 0.0]),
            joint(0.0, 0.0, 0.0, h, 0.06, 0.06, [0.0, 0.0, 0.01]),
            joint(0.0, 0.06, 0.0, 0.0, 0.03, 0.05, [0.0, 0.0, -0.02]),
        ]),
    }
}

/// A seven-joint arm with a lifting column: a prismatic joint (0.2 m lift
/// range) carrying [`lrm_like_arm`]'s six joints, Hayati's twist on the
/// parallel shoulder and elbow (0.01 rad) and on the wrist; compliant
/// everywhere, the lift too (m/N).
pub fn lift_arm<T: Real>() -> Arm<T> {
    let mut arm = lrm_like_arm::<T>();
    let mut lift = joint::<T>(0.3, 0.1, 0.02, 0.0, 2e-4, 0.4, [0.0, 0.0, -0.05]);
    lift.kind = crate::JointKind::Prismatic;
    lift.limits = [real(0.0), real(0.2)];
    let mut joints = [lift; LIFT_ARM_JOINTS];
    joints[1..].copy_from_slice(&arm.joints);
    joints[2].beta = real(0.01);
    joints[5].beta = real(-0.02);
    arm.joints = PerJoint::from(joints);
    arm
}

/// Joints of [`lift_arm`].
pub const LIFT_ARM_JOINTS: usize = 7;

/// Random joint values of [`lift_arm`]: the lift within its range, the
/// angles within ±100°.
pub fn random_lift_q<T: Real>(rng: &mut impl Rng) -> [T; LIFT_ARM_JOINTS] {
    core::array::from_fn(|j| {
        if j == 0 {
            real(rng.random_range(0.0..0.2))
        } else {
            real(rng.random_range(-1.745..1.745))
        }
    })
}

/// [`lrm_like_arm`] with every joint and the base stiff.
pub fn rigid_lrm_like_arm() -> Arm<f64> {
    let mut arm = lrm_like_arm::<f64>();
    arm.base_compliance = 0.0;
    arm.joints.iter_mut().for_each(|j| j.compliance = 0.0);
    arm
}

/// Random commanded angles within ±100°.
pub fn random_q<T: Real>(rng: &mut impl Rng) -> [T; TEST_ARM_JOINTS] {
    core::array::from_fn(|_| real(rng.random_range(-1.745..1.745)))
}

/// How large random parameter errors are, per kind of parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorSizes {
    /// Lengths are drawn uniformly from `±length_m`, m.
    pub length_m: f64,
    /// Angles are drawn uniformly from `±angle_rad`, rad.
    pub angle_rad: f64,
    /// Compliance errors are drawn uniformly from this range, rad/Nm.
    pub compliance: Range<f64>,
}

impl ErrorSizes {
    /// A calibrated arm as identification finds it: errors of a few
    /// millimetres and under two degrees, every compliance raised by up to
    /// 0.05 rad/Nm (so a compliant nominal arm stays compliant).
    pub const CALIBRATED: ErrorSizes = ErrorSizes {
        length_m: 0.003,
        angle_rad: 0.03,
        compliance: 0.0..0.05,
    };
}

/// One random error per parameter of the test arms, in [`ParamId::all`] order, each drawn
/// uniformly within `sizes` for its kind (one draw per parameter, so the same
/// generator state gives the same errors whatever the sizes).
pub fn random_errors(rng: &mut impl Rng, sizes: &ErrorSizes) -> [f64; TEST_ARM_PARAMS] {
    let mut errors = [0.0; TEST_ARM_PARAMS];
    for (error, id) in errors.iter_mut().zip(ParamId::all(TEST_ARM_JOINTS)) {
        *error = match id.kind() {
            ParamKind::Length => rng.random_range(-sizes.length_m..sizes.length_m),
            ParamKind::Angle => rng.random_range(-sizes.angle_rad..sizes.angle_rad),
            ParamKind::Compliance => rng.random_range(sizes.compliance.clone()),
        };
    }
    errors
}

#[cfg(test)]
mod tests {
    use rand::{SeedableRng, rngs::StdRng};

    use super::*;

    #[test]
    fn random_errors_stay_within_their_sizes_and_follow_the_seed() {
        let sizes = ErrorSizes::CALIBRATED;
        let errors = random_errors(&mut StdRng::seed_from_u64(1), &sizes);
        for (e, id) in errors.iter().zip(ParamId::all(TEST_ARM_JOINTS)) {
            let within = match id.kind() {
                ParamKind::Length => e.abs() < sizes.length_m,
                ParamKind::Angle => e.abs() < sizes.angle_rad,
                ParamKind::Compliance => sizes.compliance.contains(e),
            };
            assert!(within, "{id}: {e}");
        }
        assert_eq!(errors, random_errors(&mut StdRng::seed_from_u64(1), &sizes));
        assert_ne!(errors, random_errors(&mut StdRng::seed_from_u64(2), &sizes));
    }
}
