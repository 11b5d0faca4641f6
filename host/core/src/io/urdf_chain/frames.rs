//! Rigid frames: URDF `<origin>`s in, [`FrameXyzRpy`]s out.

use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, Translation3};

use super::FrameXyzRpy;

/// A rigid frame in another, as lrmcal's model computes with them.
pub(super) type Pose = IsometryMatrix3<f64>;

/// `Trans(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll)`.
pub(super) fn pose(xyz: [f64; 3], rpy: [f64; 3]) -> Pose {
    let [roll, pitch, yaw] = rpy;
    Pose::from_parts(
        Translation3::from(xyz),
        Rotation3::from_euler_angles(roll, pitch, yaw),
    )
}

/// A pose as translation and roll, pitch, yaw.
///
/// Yaw is taken first, from the image of x, and the rest from `Rz(-yaw) R`,
/// whose entries stay well away from 0 even near pitch ±90°: there, taking
/// each angle on its own from two small entries (as `Rotation3::euler_angles`
/// does) loses digits, which would move a 1 m chain by far more than 1e-12 m.
pub(super) fn to_frame(pose: &Pose) -> FrameXyzRpy {
    let r = pose.rotation.matrix();
    let cos_pitch = r[(0, 0)].hypot(r[(1, 0)]);
    // At pitch ±90° only yaw − roll (or yaw + roll) is defined: roll takes it.
    let yaw = if cos_pitch < 1e-15 {
        0.0
    } else {
        r[(1, 0)].atan2(r[(0, 0)])
    };
    // Ry(pitch) Rx(roll) = [[cp, sp sr, sp cr], [0, cr, -sr], [-sp, cp sr, cp cr]].
    let rest: Matrix3<f64> = Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), -yaw) * r;
    let pitch = (-rest[(2, 0)]).atan2(rest[(0, 0)]);
    let roll = (-rest[(1, 2)]).atan2(rest[(1, 1)]);
    FrameXyzRpy {
        xyz: pose.translation.vector.into(),
        rpy: [roll, pitch, yaw],
    }
}

/// Frame values below this are rounding (m or rad): written as 0 rather
/// than as 1e-17 or −0. Small enough that a chain a few metres long moves
/// by well under 1e-12 m for it.
const ROUNDING: f64 = 1e-14;

/// A frame value (m or rad), with rounding written as 0.
pub(super) fn clean(value: f64) -> f64 {
    if value.abs() < ROUNDING { 0.0 } else { value }
}

/// A frame with rounding written as 0.
pub(super) fn cleaned(frame: FrameXyzRpy) -> FrameXyzRpy {
    FrameXyzRpy {
        xyz: frame.xyz.map(clean),
        rpy: frame.rpy.map(clean),
    }
}
