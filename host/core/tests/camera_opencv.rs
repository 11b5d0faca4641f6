//! Our projection against OpenCV's own: the intrinsics file OpenCV's
//! FileStorage wrote and the pixels `cv2.projectPoints` gave for points in
//! the camera frame (`tests/data/camera/`, made by
//! `tools/camera/opencv_reference.py`, whose docstring says how to remake
//! them; the OpenCV version is on the CSV's first line).

use lrmcal_core::camera::intrinsics_file;
use nalgebra::Point3;

const CALIBRATION: &str = include_str!("data/camera/opencv_calibration.yaml");
const PROJECTED: &str = include_str!("data/camera/opencv_projected.csv");

#[test]
fn opencv_files_read_as_written() {
    let camera = intrinsics_file::parse(CALIBRATION).unwrap();
    assert_eq!((camera.width_px, camera.height_px), (1280, 720));
    assert_eq!(
        (camera.fx, camera.fy, camera.cx, camera.cy),
        (910.5, 905.25, 642.3, 358.7)
    );
    assert_eq!(camera.distortion, [-0.12, 0.08, 0.0012, -0.0009, -0.02]);
    // OpenCV before 5 wrote `%YAML:1.0`, which no YAML parser takes.
    let old = CALIBRATION.replacen("%YAML 1.2", "%YAML:1.0", 1);
    assert_eq!(intrinsics_file::parse(&old).unwrap(), camera);
}

#[test]
fn the_projection_is_opencvs() {
    let camera = intrinsics_file::parse(CALIBRATION).unwrap();
    let rows: Vec<Vec<f64>> = PROJECTED
        .lines()
        .skip(2)
        .map(|line| line.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 12);
    for row in rows {
        let pixel = camera
            .project(&Point3::new(row[0], row[1], row[2]))
            .unwrap();
        // OpenCV computes in double too: the same formula, another order of
        // operations, agrees to the last bits of a pixel.
        for (ours, theirs) in [(pixel.x, row[3]), (pixel.y, row[4])] {
            assert!(
                (ours - theirs).abs() <= 1e-9 * theirs.abs().max(1.0),
                "{row:?}: ours {ours}, OpenCV {theirs}"
            );
        }
    }
}
