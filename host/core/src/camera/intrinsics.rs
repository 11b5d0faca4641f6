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

use nalgebra::{Point2, Point3};

use super::yaml::{at, finite};
use crate::error::{InputError, Problem};

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
