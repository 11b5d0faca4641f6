//! The chain's joint axes at q = 0 made into standard DH frames and
//! parameters (the module's conventions say which frames).
//!
//! Each link's parameters are worked out in the DH frame before it as the
//! previous parameters rebuild it, not as it was meant to be: the rounding
//! of one link cannot then tilt the axes of the next, and the frames the
//! parameters give are the ones the masses and the tool are expressed in.

use std::f64::consts::PI;

use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

use super::frames::{self, Pose};
use super::{FrameXyzRpy, PARALLEL_TOLERANCE_RAD};

/// DH lengths below this are rounding, m: written as 0 rather than as 1e-17,
/// and axes closer than this coincide or intersect.
const LENGTH_NOISE_M: f64 = 1e-12;

/// A joint's axis: a point on it and its unit direction.
pub(super) struct AxisLine {
    /// A point of the axis, m.
    pub point: Vector3<f64>,
    /// The URDF's axis direction, unit.
    pub direction: Vector3<f64>,
}

/// One link's DH parameters.
pub(super) struct DhLink {
    pub theta: f64,
    pub d: f64,
    pub a: f64,
    pub alpha: f64,
    /// See [`super::DhJoint::parallel_deviation`].
    pub parallel_deviation: Option<f64>,
}

/// The chain's DH form at q = 0.
pub(super) struct Geometry {
    /// The base link's frame -> DH frame 0.
    pub base: FrameXyzRpy,
    /// Links 1..=n.
    pub links: Vec<DhLink>,
    /// DH frames 0..=n in the base link's frame at q = 0.
    pub frames: Vec<Pose>,
    /// DH frame n -> the tip link's frame.
    pub tool: FrameXyzRpy,
}

/// The DH form of a chain with these axes (at least one) ending at `tip`,
/// all in the base link's frame at q = 0.
pub(super) fn convert(axes: &[AxisLine], tip: &Pose) -> Geometry {
    // Frame 0 as its rounded numbers give it, so that the links that follow
    // are worked out from the frame the chain will really start from.
    let base = frames::cleaned(frames::to_frame(&frame_zero(&axes[0])));
    let mut frame = frames::pose(base.xyz, base.rpy);
    let mut frames = vec![frame];
    let mut links = Vec::with_capacity(axes.len());
    for next in &axes[1..] {
        let local = AxisLine {
            point: frame.inverse_transform_point(&next.point.into()).coords,
            direction: frame.inverse_transform_vector(&next.direction),
        };
        let link = link_to(&local);
        frame *= transform(&link);
        frames.push(frame);
        links.push(link);
    }
    // The last link is the identity at q = 0; the tool holds the rest.
    links.push(DhLink {
        theta: 0.0,
        d: 0.0,
        a: 0.0,
        alpha: 0.0,
        parallel_deviation: None,
    });
    frames.push(frame);
    Geometry {
        base,
        links,
        frames,
        tool: frames::cleaned(frames::to_frame(&(frame.inverse() * tip))),
    }
}

/// DH frame 0: z along joint 1's axis, origin at the axis's point nearest the
/// base link's origin, x the base link's x made normal to z (or its y, when
/// x is nearly along z).
fn frame_zero(axis: &AxisLine) -> Pose {
    let z = axis.direction;
    let origin = axis.point - z * axis.point.dot(&z);
    let normal_part = |e: Vector3<f64>| e - z * e.dot(&z);
    let x = normal_part(Vector3::x());
    // When |x| < 1e-3, z is within 0.06° of x and y's part is longer than 0.999.
    let x = if x.norm() >= 1e-3 {
        x.normalize()
    } else {
        normal_part(Vector3::y()).normalize()
    };
    Pose::from_parts(
        Translation3::from(origin),
        Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, z.cross(&x), z])),
    )
}

/// The DH link from frame i-1 to frame i, given joint i+1's axis in frame i-1.
fn link_to(next: &AxisLine) -> DhLink {
    let (c, w) = (next.point, next.direction);
    let sin_alpha = w.x.hypot(w.y);
    let deviation = sin_alpha.atan2(w.z.abs());
    if deviation <= PARALLEL_TOLERANCE_RAD {
        // The common normal through frame i-1's origin: it meets the next
        // axis where that crosses the plane z = 0.
        let t = -c.z / w.z;
        let (x, y) = (c.x + t * w.x, c.y + t * w.y);
        let a = x.hypot(y);
        let (theta, a) = if a < LENGTH_NOISE_M {
            (0.0, 0.0)
        } else {
            (y.atan2(x), a)
        };
        return DhLink {
            theta: frames::clean(theta),
            d: 0.0,
            a,
            alpha: if w.z > 0.0 { 0.0 } else { PI },
            parallel_deviation: Some(deviation),
        };
    }
    // x_i = z(i-1) × z_i / |…| = (cos θ, sin θ, 0), with z_i = (sin α sin θ, −sin α cos θ, cos α).
    let alpha = frames::clean(sin_alpha.atan2(w.z));
    let theta = frames::clean(w.x.atan2(-w.y));
    let (sin_theta, cos_theta) = theta.sin_cos();
    // Frame i's origin c + t w lies on x_i: its part along (−sin θ, cos θ, 0) is 0.
    let t = (cos_theta * c.y - sin_theta * c.x) / sin_alpha;
    DhLink {
        theta,
        d: clean_length(c.z + t * w.z),
        a: clean_length(cos_theta * c.x + sin_theta * c.y),
        alpha,
        parallel_deviation: None,
    }
}

/// A DH length, with rounding written as 0.
fn clean_length(length: f64) -> f64 {
    if length.abs() < LENGTH_NOISE_M {
        0.0
    } else {
        length
    }
}

/// `Rz(θ) Tz(d) Tx(a) Rx(α)`: frame i in frame i-1 at q = 0.
fn transform(link: &DhLink) -> Pose {
    let (st, ct) = link.theta.sin_cos();
    let (sa, ca) = link.alpha.sin_cos();
    Pose::from_parts(
        Translation3::new(link.a * ct, link.a * st, link.d),
        Rotation3::from_matrix_unchecked(Matrix3::new(
            ct,
            -st * ca,
            st * sa,
            st,
            ct * ca,
            -ct * sa,
            0.0,
            sa,
            ca,
        )),
    )
}
