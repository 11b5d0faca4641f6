//! The pinhole camera with OpenCV's radial-tangential distortion ("plumb_bob"
//! in ROS), for one image size.
//!
//! A point (X, Y, Z) of the camera frame (x right, y down, z forward, m)
//! projects as OpenCV's `projectPoints` does: x' = X/Z, y' = Y/Z,
//! r² = x'² + y'²,
//! x'' = x'(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x'y' + p2 (r² + 2x'²),
//! y'' = y'(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y'²) + 2 p2 x'y',
//! u = fx x'' + cx, v = fy y'' + cy, in pixels with the top-left pixel's
//! centre at (0, 0).

use nalgebra::{Matrix2, Matrix2x3, Point2, Point3, SMatrix};

/// A pixel's derivative in the nine intrinsics (rows u, v; columns fx, fy,
/// cx, cy, k1, k2, p1, p2, k3).
pub type IntrinsicsSlope = SMatrix<f64, 2, 9>;

use super::yaml::{at, finite};
use crate::error::{InputError, Problem};

/// Most fixed-point iterations [`Intrinsics::undistort`] takes.
const UNDISTORT_ITERATIONS: usize = 100;
/// The step in normalised coordinates at which it has settled (1e-12 of
/// the focal length: far below a pixel's thousandth).
const UNDISTORT_TOLERANCE: f64 = 1e-12;

/// A calibrated camera at one resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct Intrinsics {
    /// Image width, px.
    pub width_px: u32,
    /// Image height, px.
    pub height_px: u32,
    /// Focal length along x, px.
    pub fx: f64,
    /// Focal length along y, px.
    pub fy: f64,
    /// Principal point, x, px.
    pub cx: f64,
    /// Principal point, y, px.
    pub cy: f64,
    /// Distortion coefficients in OpenCV's order: k1, k2, p1, p2, k3.
    pub distortion: [f64; 5],
}

impl Intrinsics {
    /// Checks the numbers: a non-empty image, finite focal lengths > 0, the
    /// principal point inside the image, finite distortion. Errors name the
    /// key of the files that hold them (`camera_matrix`,
    /// `distortion_coefficients`, `image_width`, `image_height`).
    pub fn check(&self) -> Result<(), InputError> {
        for (key, size) in [
            ("image_width", self.width_px),
            ("image_height", self.height_px),
        ] {
            if size == 0 {
                return Err(at(
                    key,
                    Problem::OutOfRange {
                        expected: "an image size > 0 px",
                        found: "0".into(),
                    },
                ));
            }
        }
        for (name, f) in [("fx", self.fx), ("fy", self.fy)] {
            if !(f.is_finite() && f > 0.0) {
                return Err(at(
                    "camera_matrix",
                    Problem::OutOfRange {
                        expected: "focal lengths fx, fy finite and > 0 px",
                        found: format!("{name} = {f}"),
                    },
                ));
            }
        }
        let inside =
            |c: f64, size: u32| c.is_finite() && (0.0..=f64::from(size) - 1.0).contains(&c);
        if !(inside(self.cx, self.width_px) && inside(self.cy, self.height_px)) {
            return Err(at(
                "camera_matrix",
                Problem::OutOfRange {
                    expected: "a principal point (cx, cy) inside the image",
                    found: format!(
                        "({}, {}) in a {}x{} image",
                        self.cx, self.cy, self.width_px, self.height_px
                    ),
                },
            ));
        }
        for k in self.distortion {
            finite("distortion_coefficients", k)?;
        }
        Ok(())
    }

    /// The pixel `point` (camera frame, m) projects to; `None` for a point
    /// at or behind the camera's plane (z ≤ 0), not finite, or beyond the
    /// radius where the radial distortion stops growing outwards: there the
    /// polynomial folds back, and a point far outside the field of view
    /// would land inside the image (with k1 = −0.3 alone, a point 54° off
    /// the axis lands where one 34° off belongs).
    pub fn project(&self, point: &Point3<f64>) -> Option<Point2<f64>> {
        if !(point.z > 0.0 && point.coords.iter().all(|c| c.is_finite())) {
            return None;
        }
        let [k1, k2, p1, p2, k3] = self.distortion;
        let (x, y) = (point.x / point.z, point.y / point.z);
        let r2 = x * x + y * y;
        // d(r · radial)/dr = 1 + 3 k1 r² + 5 k2 r⁴ + 7 k3 r⁶ > 0 from the
        // axis out to the point, checked on a fine grid of r².
        const STEPS: u32 = 32;
        let outwards = (1..=STEPS).all(|i| {
            let s = r2 * f64::from(i) / f64::from(STEPS);
            1.0 + s * (3.0 * k1 + s * (5.0 * k2 + s * 7.0 * k3)) > 0.0
        });
        if !outwards {
            return None;
        }
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        Some(Point2::new(self.fx * xd + self.cx, self.fy * yd + self.cy))
    }

    /// [`Intrinsics::project`] and its derivative with respect to the
    /// point's coordinates, px/m (rows u, v; columns X, Y, Z): how a
    /// reprojection error moves when the point does.
    pub fn project_with_slope(&self, point: &Point3<f64>) -> Option<(Point2<f64>, Matrix2x3<f64>)> {
        let pixel = self.project(point)?;
        let [k1, k2, p1, p2, k3] = self.distortion;
        let (x, y) = (point.x / point.z, point.y / point.z);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let d_radial = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
        // The distorted normalised point's derivative in (x, y).
        let lens = Matrix2::new(
            radial + 2.0 * x * x * d_radial + 2.0 * p1 * y + 6.0 * p2 * x,
            2.0 * x * y * d_radial + 2.0 * p1 * x + 2.0 * p2 * y,
            2.0 * x * y * d_radial + 2.0 * p1 * x + 2.0 * p2 * y,
            radial + 2.0 * y * y * d_radial + 6.0 * p1 * y + 2.0 * p2 * x,
        );
        let iz = 1.0 / point.z;
        let pinhole = Matrix2x3::new(iz, 0.0, -x * iz, 0.0, iz, -y * iz);
        let focal = Matrix2::new(self.fx, 0.0, 0.0, self.fy);
        Some((pixel, focal * lens * pinhole))
    }

    /// The derivative of [`Intrinsics::project`]'s pixel with respect to
    /// the intrinsics themselves, per unit of each (rows u, v; columns fx,
    /// fy, cx, cy, k1, k2, p1, p2, k3): how a reprojection error moves when
    /// the lens is refined.
    pub fn intrinsics_slope(&self, point: &Point3<f64>) -> Option<IntrinsicsSlope> {
        self.project(point)?;
        let [k1, k2, p1, p2, k3] = self.distortion;
        let (x, y) = (point.x / point.z, point.y / point.z);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let (fx, fy) = (self.fx, self.fy);
        let (r4, r6) = (r2 * r2, r2 * r2 * r2);
        #[rustfmt::skip]
        let slope = IntrinsicsSlope::from_row_slice(&[
            xd, 0.0, 1.0, 0.0, fx * x * r2, fx * x * r4, fx * 2.0 * x * y, fx * (r2 + 2.0 * x * x), fx * x * r6,
            0.0, yd, 0.0, 1.0, fy * y * r2, fy * y * r4, fy * (r2 + 2.0 * y * y), fy * 2.0 * x * y, fy * y * r6,
        ]);
        Some(slope)
    }

    /// The normalised image point (x/z, y/z of the camera frame) whose
    /// projection is `pixel`: the lens's distortion undone by fixed-point
    /// iteration, as OpenCV's `undistortPoints` does; `None` when it does
    /// not settle (a pixel past the lens's fold).
    pub fn undistort(&self, pixel: &Point2<f64>) -> Option<Point2<f64>> {
        let [k1, k2, p1, p2, k3] = self.distortion;
        let xd = (pixel.x - self.cx) / self.fx;
        let yd = (pixel.y - self.cy) / self.fy;
        let (mut x, mut y) = (xd, yd);
        for _ in 0..UNDISTORT_ITERATIONS {
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            let (nx, ny) = ((xd - dx) / radial, (yd - dy) / radial);
            let step = (nx - x).hypot(ny - y);
            (x, y) = (nx, ny);
            if step < UNDISTORT_TOLERANCE {
                let back = self.project(&Point3::new(x, y, 1.0))?;
                return ((back - pixel).norm() < 1e-6).then_some(Point2::new(x, y));
            }
        }
        None
    }

    /// Whether `pixel` lies in the image at least `margin_px` from its edges
    /// (the edge pixels' centres are at 0 and width − 1).
    pub fn contains(&self, pixel: &Point2<f64>, margin_px: f64) -> bool {
        let within = |c: f64, size: u32| c >= margin_px && c <= f64::from(size) - 1.0 - margin_px;
        within(pixel.x, self.width_px) && within(pixel.y, self.height_px)
    }
}

/// Distortion coefficients as files list them, in OpenCV's order: 4 (k1,
/// k2, p1, p2; k3 is then 0) or 5. The longer lists OpenCV writes (8, 12,
/// 14: the rational, thin-prism and tilted models) are refused: this camera
/// model would silently drop their terms.
pub(crate) fn distortion_of(key: &str, coefficients: &[f64]) -> Result<[f64; 5], InputError> {
    match *coefficients {
        [k1, k2, p1, p2] => Ok([k1, k2, p1, p2, 0.0]),
        [k1, k2, p1, p2, k3] => Ok([k1, k2, p1, p2, k3]),
        _ => Err(at(
            key,
            Problem::Invalid {
                message: format!(
                    "expected 4 or 5 distortion coefficients (k1, k2, p1, p2[, k3]: \
                     plumb_bob), found {} (a model with more terms is not supported)",
                    coefficients.len()
                ),
            },
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 720p webcam without distortion.
    fn ideal() -> Intrinsics {
        Intrinsics {
            width_px: 1280,
            height_px: 720,
            fx: 900.0,
            fy: 900.0,
            cx: 639.5,
            cy: 359.5,
            distortion: [0.0; 5],
        }
    }

    #[test]
    fn the_optical_axis_lands_on_the_principal_point() {
        let uv = ideal().project(&Point3::new(0.0, 0.0, 2.0)).unwrap();
        assert_eq!((uv.x, uv.y), (639.5, 359.5));
        // x right, y down.
        let uv = ideal().project(&Point3::new(0.1, 0.2, 1.0)).unwrap();
        assert_eq!((uv.x, uv.y), (729.5, 539.5));
    }

    /// A webcam with every distortion term: the one the slope and the
    /// undistortion are checked on.
    fn distorted() -> Intrinsics {
        Intrinsics {
            fx: 910.0,
            fy: 908.0,
            distortion: [-0.1, 0.06, 0.001, -0.0005, 0.01],
            ..ideal()
        }
    }

    /// The projection's slope is its central differences, across the image.
    #[test]
    fn the_projections_slope_is_its_differences() {
        let camera = distorted();
        for point in [
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(0.31, -0.17, 0.9),
            Point3::new(-0.4, 0.22, 0.7),
        ] {
            let (pixel, slope) = camera.project_with_slope(&point).unwrap();
            assert_eq!(Some(pixel), camera.project(&point));
            let h = 1e-6;
            for axis in 0..3 {
                let mut ahead = point;
                let mut behind = point;
                ahead[axis] += h;
                behind[axis] -= h;
                let diff = (camera.project(&ahead).unwrap() - camera.project(&behind).unwrap())
                    / (2.0 * h);
                for row in 0..2 {
                    let exact = slope[(row, axis)];
                    assert!(
                        (exact - diff[row]).abs() < 1e-5 * exact.abs().max(1.0),
                        "{point} {axis}"
                    );
                }
            }
        }
    }

    /// The slope with respect to the intrinsics is their central
    /// differences: each of fx, fy, cx, cy, k1, k2, p1, p2, k3 stepped.
    #[test]
    fn the_intrinsics_slope_is_its_differences() {
        let camera = distorted();
        let stepped = |field: usize, h: f64| {
            let mut c = camera.clone();
            match field {
                0 => c.fx += h,
                1 => c.fy += h,
                2 => c.cx += h,
                3 => c.cy += h,
                k => c.distortion[k - 4] += h,
            }
            c
        };
        for point in [Point3::new(0.31, -0.17, 0.9), Point3::new(-0.4, 0.22, 0.7)] {
            let slope = camera.intrinsics_slope(&point).unwrap();
            for field in 0..9 {
                let h = if field < 4 { 1e-3 } else { 1e-6 };
                let diff = (stepped(field, h).project(&point).unwrap()
                    - stepped(field, -h).project(&point).unwrap())
                    / (2.0 * h);
                for row in 0..2 {
                    let exact = slope[(row, field)];
                    assert!(
                        (exact - diff[row]).abs() < 1e-6 * exact.abs().max(1.0),
                        "{point} {field} {row}: {exact} against {}",
                        diff[row]
                    );
                }
            }
        }
    }

    /// Undistorting a projected point gives back its normalised coordinates.
    #[test]
    fn undistortion_undoes_the_projection() {
        let camera = distorted();
        for (x, y) in [(0.0, 0.0), (0.35, -0.2), (-0.6, 0.33), (0.69, 0.38)] {
            let pixel = camera.project(&Point3::new(x, y, 1.0)).unwrap();
            let back = camera.undistort(&pixel).unwrap();
            assert!(
                (back.x - x).abs() < 1e-10 && (back.y - y).abs() < 1e-10,
                "{x} {y}: {back}"
            );
        }
    }

    #[test]
    fn points_at_or_behind_the_camera_do_not_project() {
        let camera = ideal();
        assert_eq!(camera.project(&Point3::new(0.1, 0.0, 0.0)), None);
        assert_eq!(camera.project(&Point3::new(0.0, 0.0, -1.0)), None);
        assert_eq!(camera.project(&Point3::new(f64::NAN, 0.0, 1.0)), None);
    }

    #[test]
    fn a_point_past_the_fold_of_the_distortion_does_not_project() {
        let barrel = Intrinsics {
            distortion: [-0.3, 0.0, 0.0, 0.0, 0.0],
            ..ideal()
        };
        // 54° off the axis, it would land where a point 34° off does.
        let far = barrel.project(&Point3::new(1.4, 0.0, 1.0));
        assert_eq!(far, None);
        let near = barrel.project(&Point3::new(0.66504, 0.0, 1.0)).unwrap();
        let unguarded = 0.5768 * barrel.fx + barrel.cx;
        assert!((near.x - unguarded).abs() < 0.05, "{near}");
        // Inside the fold (at 1.054 of the axis): projected.
        assert!(barrel.project(&Point3::new(1.0, 0.0, 1.0)).is_some());
        // Without distortion every point in front projects.
        assert!(ideal().project(&Point3::new(50.0, 0.0, 1.0)).is_some());
    }

    #[test]
    fn margins_count_from_the_edge_pixels_centres() {
        let camera = ideal();
        assert!(camera.contains(&Point2::new(10.0, 10.0), 10.0));
        assert!(camera.contains(&Point2::new(1269.0, 709.0), 10.0));
        assert!(!camera.contains(&Point2::new(1269.5, 300.0), 10.0));
        assert!(!camera.contains(&Point2::new(300.0, 9.9), 10.0));
    }

    #[test]
    fn bad_numbers_are_refused_naming_the_key() {
        let mut camera = ideal();
        camera.fy = 0.0;
        let e = camera.check().unwrap_err().to_string();
        assert!(e.contains("camera_matrix") && e.contains("fy = 0"), "{e}");
        let mut camera = ideal();
        camera.cx = 1280.0;
        assert!(
            camera
                .check()
                .unwrap_err()
                .to_string()
                .contains("principal point")
        );
        let mut camera = ideal();
        camera.height_px = 0;
        assert!(
            camera
                .check()
                .unwrap_err()
                .to_string()
                .contains("image_height")
        );
        let mut camera = ideal();
        camera.distortion[4] = f64::INFINITY;
        assert!(
            camera
                .check()
                .unwrap_err()
                .to_string()
                .contains("distortion_coefficients")
        );
    }

    #[test]
    fn four_or_five_coefficients_are_read_and_the_others_named() {
        assert_eq!(
            distortion_of("d", &[1.0, 2.0, 3.0, 4.0]).unwrap(),
            [1.0, 2.0, 3.0, 4.0, 0.0]
        );
        let e = distortion_of("d", &[0.0; 8]).unwrap_err().to_string();
        assert!(e.contains("found 8"), "{e}");
    }
}
