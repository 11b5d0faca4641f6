//! Arms for the model's own unit tests.

use rand::Rng;

use crate::{Arm, Frame, JOINTS, Joint, Real, ServoCurve, real};

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
        compliance: real(k),
        limits: [real(-1.75), real(1.75)],
        mass: real(mass),
        com: com.map(real),
        servo: ServoCurve::nominal(),
    }
}

/// All twists zero: joints 1–3 form a planar arm (a = 0.2, 0.15, 0.1; d1 = 0.05).
pub fn planar_arm<T: Real>() -> Arm<T> {
    let z = [0.0; 3];
    Arm {
        gravity: [0.0, 0.0, -9.80665].map(real),
        base: Frame::identity(),
        base_compliance: T::zero(),
        tool: Frame {
            xyz: [0.0, 0.0, 0.03].map(real),
            rpy: [T::zero(); 3],
        },
        payload_com: [T::zero(); 3],
        joints: [
            joint(0.0, 0.05, 0.2, 0.0, 0.0, 0.1, [-0.1, 0.0, 0.0]),
            joint(0.0, 0.0, 0.15, 0.0, 0.0, 0.1, [-0.07, 0.0, 0.0]),
            joint(0.0, 0.0, 0.1, 0.0, 0.0, 0.1, [-0.05, 0.0, 0.0]),
            joint(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, z),
            joint(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, z),
            joint(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, z),
        ],
    }
}

/// An elbow arm with a spherical wrist, about 0.44 m reach, compliant joints and base.
pub fn lrm_like_arm<T: Real>() -> Arm<T> {
    let h = core::f64::consts::FRAC_PI_2;
    Arm {
        gravity: [0.0, 0.0, -9.80665].map(real),
        base: Frame::identity(),
        base_compliance: real(0.03),
        tool: Frame {
            xyz: [0.0, 0.0, 0.04].map(real),
            rpy: [T::zero(); 3],
        },
        payload_com: [T::zero(); 3],
        joints: [
            joint(0.0, 0.09, 0.0, h, 0.02, 0.15, [0.0, -0.03, 0.0]),
            joint(h, 0.0, 0.17, 0.0, 0.12, 0.12, [-0.085, 0.0, 0.01]),
            joint(h, 0.0, 0.0, h, 0.08, 0.10, [0.0, 0.0, 0.02]),
            joint(0.0, 0.17, 0.0, -h, 0.05, 0.08, [0.0, 0.08, 0.0]),
            joint(0.0, 0.0, 0.0, h, 0.06, 0.06, [0.0, 0.0, 0.01]),
            joint(0.0, 0.06, 0.0, 0.0, 0.03, 0.05, [0.0, 0.0, -0.02]),
        ],
    }
}

/// [`lrm_like_arm`] with every joint and the base stiff.
pub fn rigid_lrm_like_arm() -> Arm<f64> {
    let mut arm = lrm_like_arm::<f64>();
    arm.base_compliance = 0.0;
    arm.joints.iter_mut().for_each(|j| j.compliance = 0.0);
    arm
}

/// Random commanded angles within ±100°.
pub fn random_q<T: Real>(rng: &mut impl Rng) -> [T; JOINTS] {
    core::array::from_fn(|_| real(rng.random_range(-1.745..1.745)))
}
