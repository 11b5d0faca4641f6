//! The intrinsics files: read from a ROS `camera_info` YAML
//! (camera_calibration_parsers' format, `plumb_bob` only) or an OpenCV
//! FileStorage YAML (as `cv::FileStorage` writes it after `calibrateCamera`),
//! written as a ROS `camera_info` YAML.
//!
//! The kind is recognised from the content: a `%YAML` directive or an
//! `opencv-matrix` tag is OpenCV's (ROS writes neither), anything else
//! is read as `camera_info`.

use std::path::Path;

use serde::Deserialize;
use serde_norway::Value;

use super::intrinsics::{Intrinsics, distortion_of};
use super::yaml::{at, from_value, parse_value};
use crate::error::{Error, InputError, Problem};
use crate::io::read_text;

/// Reads and checks an intrinsics file of either kind.
pub fn read(path: &Path) -> Result<Intrinsics, Error> {
    let text = read_text(path)?;
    parse(&text).map_err(|e| e.in_file(path))
}

/// Parses and checks the text of an intrinsics file of either kind.
pub fn parse(text: &str) -> Result<Intrinsics, InputError> {
    let opencv = text.trim_start().starts_with("%YAML") || text.contains("opencv-matrix");
    let value = parse_value(text)?;
    let intrinsics = if opencv {
        from_opencv(value)?
    } else {
        from_ros(value)?
    };
    intrinsics.check()?;
    Ok(intrinsics)
}

/// The ROS `camera_info` YAML of `intrinsics` (camera_calibration_parsers'
/// layout, `plumb_bob`), named `camera_name`: what `camera_info_manager`
/// loads. The images are taken as they come (no rectification): the
/// rectification matrix is the identity and the projection matrix is the
/// camera matrix beside a zero column, as ROS writes for a single camera.
/// Numbers are written in full, so the file reads back to the same
/// intrinsics ([`parse`]).
pub fn to_camera_info(intrinsics: &Intrinsics, camera_name: &str) -> String {
    let Intrinsics {
        width_px,
        height_px,
        fx,
        fy,
        cx,
        cy,
        distortion: [k1, k2, p1, p2, k3],
    } = intrinsics;
    format!(
        "image_width: {width_px}\n\
         image_height: {height_px}\n\
         camera_name: {camera_name}\n\
         camera_matrix:\n  rows: 3\n  cols: 3\n  data: [{fx:?}, 0.0, {cx:?}, 0.0, {fy:?}, {cy:?}, 0.0, 0.0, 1.0]\n\
         distortion_model: plumb_bob\n\
         distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [{k1:?}, {k2:?}, {p1:?}, {p2:?}, {k3:?}]\n\
         rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]\n\
         projection_matrix:\n  rows: 3\n  cols: 4\n  \
         data: [{fx:?}, 0.0, {cx:?}, 0.0, 0.0, {fy:?}, {cy:?}, 0.0, 0.0, 0.0, 1.0, 0.0]\n"
    )
}

/// A matrix as both kinds write it (OpenCV adds its element type, `dt`).
#[derive(Debug, Deserialize)]
struct RawMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl RawMatrix {
    /// The data, checked against the shape, which must be `rows` × `cols`
    /// (`None`: any shape with one row or one column).
    fn data(&self, key: &str, shape: Option<(usize, usize)>) -> Result<&[f64], InputError> {
        let fits = match shape {
            Some(shape) => (self.rows, self.cols) == shape,
            None => self.rows == 1 || self.cols == 1,
        };
        if !fits || self.data.len() != self.rows * self.cols {
            return Err(at(
                key,
                Problem::Invalid {
                    message: format!(
                        "expected {} with rows × cols numbers in `data`, found rows {}, cols {} \
                         and {} numbers",
                        shape.map_or("a row or column".to_owned(), |(r, c)| format!("{r}x{c}")),
                        self.rows,
                        self.cols,
                        self.data.len()
                    ),
                },
            ));
        }
        Ok(&self.data)
    }
}

/// [`Intrinsics`] from a size, a camera matrix and distortion coefficients.
fn intrinsics(
    (width_px, height_px): (u32, u32),
    camera_matrix: &RawMatrix,
    distortion: &RawMatrix,
) -> Result<Intrinsics, InputError> {
    let k = camera_matrix.data("camera_matrix", Some((3, 3)))?;
    if k[1] != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(at(
            "camera_matrix",
            Problem::Invalid {
                message: format!("expected [fx, 0, cx, 0, fy, cy, 0, 0, 1] (no skew), found {k:?}"),
            },
        ));
    }
    let key = "distortion_coefficients";
    Ok(Intrinsics {
        width_px,
        height_px,
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
        distortion: distortion_of(key, distortion.data(key, None)?)?,
    })
}

/// ROS `camera_info` YAML, as camera_calibration_parsers writes it.
#[derive(Debug, Deserialize)]
struct RawRos {
    image_width: u32,
    image_height: u32,
    camera_matrix: RawMatrix,
    distortion_model: String,
    distortion_coefficients: RawMatrix,
}

fn from_ros(value: Value) -> Result<Intrinsics, InputError> {
    let raw: RawRos = from_value(value)?;
    if raw.distortion_model != "plumb_bob" {
        return Err(at(
            "distortion_model",
            Problem::Invalid {
                message: format!(
                    "expected `plumb_bob` (OpenCV's k1, k2, p1, p2, k3), found `{}`, a model \
                     lrmcal does not support",
                    raw.distortion_model
                ),
            },
        ));
    }
    intrinsics(
        (raw.image_width, raw.image_height),
        &raw.camera_matrix,
        &raw.distortion_coefficients,
    )
}

/// OpenCV's FileStorage YAML: the keys OpenCV's calibration samples write
/// (`samples/cpp/calibration.cpp`, the camera calibration tutorial), and
/// the capitalised ones of the OpenCV 2 tutorial's output.
#[derive(Debug, Deserialize)]
struct RawOpenCv {
    #[serde(alias = "image_Width")]
    image_width: u32,
    #[serde(alias = "image_Height")]
    image_height: u32,
    #[serde(alias = "Camera_Matrix")]
    camera_matrix: RawMatrix,
    #[serde(alias = "Distortion_Coefficients")]
    distortion_coefficients: RawMatrix,
}

fn from_opencv(value: Value) -> Result<Intrinsics, InputError> {
    let raw: RawOpenCv = from_value(value)?;
    intrinsics(
        (raw.image_width, raw.image_height),
        &raw.camera_matrix,
        &raw.distortion_coefficients,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROS: &str = "\
image_width: 640
image_height: 480
camera_name: webcam
camera_matrix:
  rows: 3
  cols: 3
  data: [600.0, 0.0, 319.5, 0.0, 601.0, 239.5, 0.0, 0.0, 1.0]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.1, 0.05, 0.001, -0.002, 0.0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [600.0, 0.0, 319.5, 0.0, 0.0, 601.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0]
";

    #[test]
    fn a_camera_info_file_reads() {
        let camera = parse(ROS).unwrap();
        assert_eq!((camera.width_px, camera.height_px), (640, 480));
        assert_eq!(
            (camera.fx, camera.fy, camera.cx, camera.cy),
            (600.0, 601.0, 319.5, 239.5)
        );
        assert_eq!(camera.distortion, [-0.1, 0.05, 0.001, -0.002, 0.0]);
    }

    /// What is written reads back to the same numbers, and it is the layout
    /// ROS writes: the test file's keys, in its order.
    #[test]
    fn a_written_camera_info_reads_back() {
        let camera = Intrinsics {
            fx: 912.345_678_901_234_5,
            cy: 358.000_000_000_1,
            distortion: [-0.1, 0.06, 1e-7, -0.0005, 0.01],
            ..parse(ROS).unwrap()
        };
        let text = to_camera_info(&camera, "webcam");
        assert_eq!(parse(&text).unwrap(), camera);
        let keys = |t: &str| -> Vec<String> {
            t.lines()
                .filter(|l| !l.starts_with(' '))
                .filter_map(|l| l.split(':').next().map(str::to_owned))
                .collect()
        };
        assert_eq!(keys(&text), keys(ROS));
    }

    #[test]
    fn other_distortion_models_are_refused_by_name() {
        for model in ["rational_polynomial", "equidistant"] {
            let text = ROS.replace("plumb_bob", model);
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.contains("distortion_model") && e.contains(model), "{e}");
        }
    }

    #[test]
    fn a_missing_key_or_a_bad_matrix_is_named() {
        let e = parse(&ROS.replace("image_height: 480\n", ""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("image_height"), "{e}");
        let e = parse(&ROS.replace("cols: 5", "cols: 4"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("distortion_coefficients"), "{e}");
        let e = parse(&ROS.replace("319.5, 0.0, 601.0", "319.5, 0.0, -601.0"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("camera_matrix") && e.contains("fy"), "{e}");
    }

    #[test]
    fn an_opencv_2_file_with_its_directive_and_capitals_reads() {
        let text = "%YAML:1.0\n\
image_Width: 640\n\
image_Height: 480\n\
Camera_Matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   \
data: [ 600., 0., 319.5, 0., 601., 239.5, 0., 0., 1. ]\n\
Distortion_Coefficients: !!opencv-matrix\n   rows: 4\n   cols: 1\n   dt: d\n   \
data: [ -0.1, 0.05, 0.001, -0.002 ]\n";
        let camera = parse(text).unwrap();
        assert_eq!(camera.distortion, [-0.1, 0.05, 0.001, -0.002, 0.0]);
        assert_eq!(camera.fy, 601.0);
        let eight = text
            .replace("rows: 4", "rows: 8")
            .replace("-0.002 ]", "-0.002, 0., 0., 0., 0. ]");
        let e = parse(&eight).unwrap_err().to_string();
        assert!(e.contains("found 8"), "{e}");
    }
}
