//! A camera as the rig's instrument: what it measures of a target is the
//! pixel the target projects to, not a 3D point.
//!
//! One measurement model for every instrument: the fit, the rank analysis,
//! DETMAX and the observability indices all work on 3-row blocks, one per
//! measurement, in metres. A tracker's block is the point itself. A
//! camera's is its pixel `(u, v, 0)` carried to the target's distance: the
//! reprojection error times `depth / f` (m per px there), the distance
//! across the line of sight it says the target is missed by. The third row
//! is always zero and weighs nothing; the scale, at the predicted point,
//! is held fixed in the slope (its change is the residual's size times the
//! point's relative change of depth: a second-order term at the fit's
//! end). The slope is the projection's 2 × 3 derivative
//! (`Intrinsics::project_with_slope`) times the camera's rotation over a
//! row of zeros, times the scale: the chain rule from the point's slopes
//! the Jacobian already has ([`Observation`]). Weighting pixels by the
//! depth is what a fit in metres costs: across a webcam's 0.6-1.0 m the
//! weights of equally noisy corners differ by a factor up to about 2.8.
//!
//! The camera stands where registration found it, fixed through the fit
//! (`from_world`, the arm's world frame to the camera frame); the base's
//! six parameters, refined by the fit, move the arm in front of it, as
//! they move it in a tracker's frame.

use nalgebra::{IsometryMatrix3, Matrix3, Point3, Vector3};

use lrmcal_core::camera::Intrinsics;

/// The camera that measures a rig's targets.
#[derive(Clone, Debug, PartialEq)]
pub struct RigCamera {
    /// Its lens.
    pub intrinsics: Intrinsics,
    /// The arm's world frame → the camera frame.
    pub from_world: IsometryMatrix3<f64>,
}

/// What an instrument measures of a point of the arm's world frame, as the
/// fit compares it (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// The point itself (m), or its pixel `(u, v, 0)` (px).
    pub value: Vector3<f64>,
    /// Metres per unit of `value` at the target: 1 for a point, `depth / f`
    /// for a pixel.
    pub scale: f64,
    /// The derivative of `value · scale` with respect to the point, the
    /// scale held.
    pub slope: Matrix3<f64>,
}

impl Observation {
    /// The residual block against `measured` (a measurement's block, in
    /// `value`'s units), m: `(value − measured) · scale`.
    pub fn residual(&self, measured: &Vector3<f64>) -> Vector3<f64> {
        (self.value - measured) * self.scale
    }
}

impl RigCamera {
    /// What the camera sees of `point` (the arm's world frame); `None`
    /// when it does not project (behind the camera, past the lens's fold).
    pub fn observe(&self, point: &Vector3<f64>) -> Option<Observation> {
        let seen = self.from_world * Point3::from(*point);
        let (pixel, slope) = self.intrinsics.project_with_slope(&seen)?;
        let scale = seen.z / (0.5 * (self.intrinsics.fx + self.intrinsics.fy));
        let turned = slope * self.from_world.rotation.matrix() * scale;
        let mut block = Matrix3::zeros();
        block.fixed_view_mut::<2, 3>(0, 0).copy_from(&turned);
        Some(Observation {
            value: Vector3::new(pixel.x, pixel.y, 0.0),
            scale,
            slope: block,
        })
    }
}

/// A tracker's observation of `point`: the point.
pub fn tracked(point: &Vector3<f64>) -> Observation {
    Observation {
        value: *point,
        scale: 1.0,
        slope: Matrix3::identity(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3};

    /// The observation's slope is its central differences, the camera
    /// turned and moved in the world.
    #[test]
    fn the_pixels_slope_is_its_differences() {
        let camera = RigCamera {
            intrinsics: crate::camera::testing::webcam(),
            from_world: IsometryMatrix3::from_parts(
                Translation3::new(0.05, 0.2, 0.8),
                Rotation3::from_euler_angles(-1.5, 0.1, 1.6),
            ),
        };
        let point = Vector3::new(0.1, -0.05, 0.3);
        let seen = camera.observe(&point).unwrap();
        assert_eq!(seen.value.z, 0.0);
        // A pixel at the point's distance: depth over the mean focal length.
        let depth = (camera.from_world * Point3::from(point)).z;
        assert!((seen.scale - depth / 909.0).abs() < 1e-15);
        let h = 1e-6;
        for axis in 0..3 {
            let step = Vector3::ith(axis, h);
            let diff = (camera.observe(&(point + step)).unwrap().value
                - camera.observe(&(point - step)).unwrap().value)
                * seen.scale
                / (2.0 * h);
            for row in 0..3 {
                let exact = seen.slope[(row, axis)];
                assert!(
                    (exact - diff[row]).abs() < 1e-4 * exact.abs().max(1.0),
                    "{row} {axis}"
                );
            }
        }
        assert_eq!(tracked(&point).value, point);
    }
}
