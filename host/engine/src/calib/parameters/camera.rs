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
//! Eye-to-hand, the camera stands where registration found it, fixed
//! through the fit (`from_world`, the arm's world frame to the camera
//! frame); the base's six parameters, refined by the fit, move the arm in
//! front of it, as they move it in a tracker's frame. Eye-in-hand, the
//! mirror: the board lies where registration found it (its corners fixed
//! points of the world), and the camera is the arm's tool frame, whose six
//! parameters place it on the flange. A corner then moves in the camera's
//! frame as a point carried with the camera moves the other way: its slope
//! is the same chain rule on the velocity of a point the flange carries
//! where the corner is, negated ([`RigCamera::observe_carried`]).
//!
//! Its lens is held as told, or refined with the arm ([`RigCamera::lens`],
//! the [`ParamKey::Lens`] corrections): the arm moving the board gives the
//! views a camera calibration needs, at many distances and across the
//! image. The corrections are dimensionless, so that one step size and one
//! typical size serve them all: focal lengths change relatively
//! (`fx (1 + e)`), the principal point by a fraction of the focal length
//! (`cx + e fx`, a turn of the optical axis by `e` rad), the distortion
//! coefficients by `e` itself. A lens column is the pixel's derivative in
//! the intrinsics ([`Intrinsics::intrinsics_slope`]) times that unit,
//! carried to the target's distance like every pixel.

use nalgebra::{IsometryMatrix3, Matrix3, Point3, SMatrix, Vector3};

use lrmcal_core::camera::{Intrinsics, Mount};
use lrmcal_core::param_key::{LENS_FIELDS, ParamKey};

/// The lens corrections refined, by index in [`LENS_FIELDS`]: fx, fy, k1,
/// k2, what a lens's nominal figures get most wrong and what the arm's
/// views determine. The principal point and the tangential terms stay as
/// told: a shift of the principal point is, but for the distortion about
/// it, a turn of the camera, which the fit already has (the base's turn
/// in front of it), and p1, p2 mimic the rest. Freed, on a simulated arm
/// (seed 2, `camera_figures -- 2 2 off-refined` with them in this list),
/// cy came out 19 px off the true lens with p1, p2 three times theirs and
/// the residual at the corners' noise, the camera 17 mm off. k3, with
/// k2, bends only the image's far corners, where a board on an arm is
/// rarely seen (OpenCV's guides fix it for such lenses too).
const REFINED: [u8; 4] = [0, 1, 4, 5];

/// The lens corrections, in [`LENS_FIELDS`]' order.
pub type LensErrors = [f64; LENS_FIELDS.len()];

/// A pixel's derivative in the lens corrections, m per unit (rows u, v).
pub type LensSlope = SMatrix<f64, 2, { LENS_FIELDS.len() }>;

/// The camera that measures a rig's targets.
#[derive(Clone, Debug, PartialEq)]
pub struct RigCamera {
    /// Its lens as told (the intrinsics file's).
    pub intrinsics: Intrinsics,
    /// How it is carried: standing ([`RigCamera::observe`]) or on the
    /// flange as the tool frame ([`RigCamera::observe_carried`]).
    pub mount: Mount,
    /// Eye-to-hand, the arm's world frame → the camera frame; eye-in-hand
    /// the identity (the camera rides the tool frame).
    pub from_world: IsometryMatrix3<f64>,
    /// The lens's corrections when the fit refines it (module docs);
    /// `None`: the lens is held as told.
    pub lens: Option<LensErrors>,
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
    /// The derivative of `value · scale` with respect to the lens's
    /// corrections, when the lens is refined.
    pub lens_slope: Option<LensSlope>,
}

impl Observation {
    /// The residual block against `measured` (a measurement's block, in
    /// `value`'s units), m: `(value − measured) · scale`.
    pub fn residual(&self, measured: &Vector3<f64>) -> Vector3<f64> {
        (self.value - measured) * self.scale
    }
}

impl RigCamera {
    /// A camera standing at `from_world` whose lens is held as told.
    pub fn fixed(intrinsics: Intrinsics, from_world: IsometryMatrix3<f64>) -> Self {
        Self {
            intrinsics,
            mount: Mount::EyeToHand,
            from_world,
            lens: None,
        }
    }

    /// A camera on the flange, the arm's tool frame, whose lens is held as told.
    pub fn on_flange(intrinsics: Intrinsics) -> Self {
        Self {
            mount: Mount::EyeInHand,
            ..Self::fixed(intrinsics, IsometryMatrix3::identity())
        }
    }

    /// The lens as the fit has it: as told, its corrections applied.
    pub fn lens_now(&self) -> Intrinsics {
        let Some(e) = self.lens else {
            return self.intrinsics.clone();
        };
        let told = &self.intrinsics;
        let mut distortion = told.distortion;
        for (d, e) in distortion.iter_mut().zip(&e[4..]) {
            *d += e;
        }
        Intrinsics {
            fx: told.fx * (1.0 + e[0]),
            fy: told.fy * (1.0 + e[1]),
            cx: told.cx + e[2] * told.fx,
            cy: told.cy + e[3] * told.fy,
            distortion,
            ..told.clone()
        }
    }

    /// The keys of the lens's corrections when it is refined, none when
    /// it is held: the focal lengths and the radial distortion's k1, k2
    /// ([`REFINED`]).
    pub fn lens_keys(&self) -> Vec<ParamKey> {
        match self.lens {
            Some(_) => REFINED.map(|field| ParamKey::Lens { field }).to_vec(),
            None => Vec::new(),
        }
    }

    /// What the standing camera sees of `point` (the arm's world frame);
    /// `None` when it does not project (behind the camera, past the lens's
    /// fold). The slope is against the point's motion.
    pub fn observe(&self, point: &Vector3<f64>) -> Option<Observation> {
        self.observe_from(&self.from_world, point, 1.0)
    }

    /// What the camera on the flange, standing at `camera_in_world`, sees
    /// of `point`, fixed in the world. The slope is against the motion of a
    /// point carried with the camera where `point` is (module docs).
    pub fn observe_carried(
        &self,
        camera_in_world: &IsometryMatrix3<f64>,
        point: &Vector3<f64>,
    ) -> Option<Observation> {
        self.observe_from(&camera_in_world.inverse(), point, -1.0)
    }

    /// What a camera at `from_world` sees of `point`, the slope's sign
    /// `sign`.
    fn observe_from(
        &self,
        from_world: &IsometryMatrix3<f64>,
        point: &Vector3<f64>,
        sign: f64,
    ) -> Option<Observation> {
        let lens = self.lens_now();
        let seen = from_world * Point3::from(*point);
        let (pixel, slope) = lens.project_with_slope(&seen)?;
        let scale = seen.z / (0.5 * (lens.fx + lens.fy));
        let turned = slope * from_world.rotation.matrix() * (sign * scale);
        let mut block = Matrix3::zeros();
        block.fixed_view_mut::<2, 3>(0, 0).copy_from(&turned);
        let lens_slope = match self.lens {
            Some(_) => {
                let told = &self.intrinsics;
                let units = [told.fx, told.fy, told.fx, told.fy, 1.0, 1.0, 1.0, 1.0, 1.0];
                let mut s = lens.intrinsics_slope(&seen)? * scale;
                for (mut column, unit) in s.column_iter_mut().zip(units) {
                    column *= unit;
                }
                Some(s)
            }
            None => None,
        };
        Some(Observation {
            value: Vector3::new(pixel.x, pixel.y, 0.0),
            scale,
            slope: block,
            lens_slope,
        })
    }
}

/// A tracker's observation of `point`: the point.
pub fn tracked(point: &Vector3<f64>) -> Observation {
    Observation {
        value: *point,
        scale: 1.0,
        slope: Matrix3::identity(),
        lens_slope: None,
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
        let camera = RigCamera::fixed(
            crate::camera::testing::webcam(),
            IsometryMatrix3::from_parts(
                Translation3::new(0.05, 0.2, 0.8),
                Rotation3::from_euler_angles(-1.5, 0.1, 1.6),
            ),
        );
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

    /// The lens corrections' slope is their central differences, and a
    /// camera refining nothing has no lens slope.
    #[test]
    fn the_lens_slope_is_its_differences() {
        let mut camera = RigCamera::fixed(
            crate::camera::testing::webcam(),
            IsometryMatrix3::from_parts(
                Translation3::new(0.05, 0.2, 0.8),
                Rotation3::from_euler_angles(-1.5, 0.1, 1.6),
            ),
        );
        let point = Vector3::new(0.2, -0.1, 0.3);
        assert!(camera.observe(&point).unwrap().lens_slope.is_none());
        assert!(camera.lens_keys().is_empty());
        camera.lens = Some([0.01, -0.02, 0.003, -0.001, 0.02, -0.01, 1e-4, -2e-4, 0.003]);
        assert_eq!(camera.lens_keys().len(), 4);
        let seen = camera.observe(&point).unwrap();
        let slope = seen.lens_slope.unwrap();
        let h = 1e-7;
        for field in 0..9 {
            let at = |step: f64| {
                let mut c = camera.clone();
                c.lens.as_mut().unwrap()[field] += step;
                c.observe(&point).unwrap().value
            };
            let diff = (at(h) - at(-h)) * seen.scale / (2.0 * h);
            for row in 0..2 {
                let exact = slope[(row, field)];
                assert!(
                    (exact - diff[row]).abs() < 1e-6 * exact.abs().max(1e-3),
                    "{field} {row}: {exact} against {}",
                    diff[row]
                );
            }
        }
    }
}
