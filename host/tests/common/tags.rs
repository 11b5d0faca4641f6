//! Rendered images of an AprilTag board whose corners are known exactly: each
//! tag's bits from the AprilTag C library itself (`apriltag_to_image`), drawn
//! by the homography of a pinhole camera looking at the board, each pixel the
//! mean of 4x4 samples (anti-aliased edges), pixel centres at integer
//! coordinates (OpenCV's convention).

// The tag bit images come from the C library through its FFI.
#![allow(unsafe_code)]

use lrmcal_core::camera::AprilGrid;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

/// The rendered images' size, a 720p webcam's.
pub const WIDTH: u32 = 1280;
/// See [`WIDTH`].
pub const HEIGHT: u32 = 720;

/// Cells across a tag36h11 bit image: the white border, the black border, 6 bits.
const CELLS: usize = 10;

/// A 3x2 grid of 4 cm tags from id 5.
pub fn board() -> AprilGrid {
    AprilGrid {
        rows: 2,
        cols: 3,
        tag_size_m: 0.04,
        spacing: 0.3,
        first_id: 5,
    }
}

/// Where the camera looks at the board from: the board's centre `distance_m`
/// in front of it, the board turned by `roll_deg` about the optical axis
/// (0: upright) and tilted by `tilt_deg` about the image's horizontal.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Turn about the optical axis, degrees, counter-clockwise as seen in the image.
    pub roll_deg: f64,
    /// Tilt about the camera's x axis, degrees.
    pub tilt_deg: f64,
    /// Distance from the camera to the board's centre, m.
    pub distance_m: f64,
}

/// Each tag's id and its true corners in the board's order, (u, v) px.
pub type Truth = Vec<(u32, [[f64; 2]; 4])>;

/// A rendered image: grey pixels row by row, and each tag's id and true
/// corners in the board's order, OpenCV pixels.
pub struct Rendered {
    /// `WIDTH · HEIGHT` grey pixels.
    pub pixels: Vec<u8>,
    /// The board's tags with their true corners, (u, v) px.
    pub truth: Truth,
}

/// The board-to-image homography of `view` (a 900 px focal length, the
/// principal point in the middle of the image), board points in metres.
fn homography(board: &AprilGrid, view: View) -> Matrix3<f64> {
    let k = Matrix3::new(
        900.0,
        0.0,
        f64::from(WIDTH) / 2.0,
        0.0,
        900.0,
        f64::from(HEIGHT) / 2.0,
        0.0,
        0.0,
        1.0,
    );
    // Facing the camera upright: board x along the camera's x, board y
    // against the camera's y (down), board z towards the camera.
    let facing = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    let r = Rotation3::from_axis_angle(&Vector3::x_axis(), view.tilt_deg.to_radians())
        * Rotation3::from_axis_angle(&Vector3::z_axis(), -view.roll_deg.to_radians());
    let r = r.matrix() * facing;
    let t = Vector3::new(0.0, 0.0, view.distance_m) - r * board.centre().coords;
    k * Matrix3::from_columns(&[r.column(0).into(), r.column(1).into(), t])
}

/// The tag36h11 bit image of tag `id`, `CELLS` x `CELLS`, row by row.
fn tag_bits(id: u32) -> Vec<u8> {
    let index = std::os::raw::c_int::try_from(id).expect("a tag36h11 id");
    // SAFETY: the family and the image are the library's, used while alive
    // and destroyed once; the image is CELLS x CELLS with its own stride.
    unsafe {
        let family = apriltag_sys::tag36h11_create();
        let image = apriltag_sys::apriltag_to_image(family, index);
        let im = &*image;
        assert_eq!((im.width, im.height), (CELLS as i32, CELLS as i32));
        let stride = usize::try_from(im.stride).expect("stride");
        let bits = (0..CELLS * CELLS)
            .map(|k| *im.buf.add(k / CELLS * stride + k % CELLS))
            .collect();
        apriltag_sys::image_u8_destroy(image);
        apriltag_sys::tag36h11_destroy(family);
        bits
    }
}

/// Renders `board` seen from `view` on a white page.
pub fn render(board: &AprilGrid, view: View) -> Rendered {
    let h = homography(board, view);
    let back = h.try_inverse().expect("an invertible homography");
    let bits: Vec<Vec<u8>> = (0..board.tag_count())
        .map(|i| tag_bits(board.first_id + i))
        .collect();
    let s = board.tag_size_m;
    let pitch = s * (1.0 + board.spacing);
    let cell = s / 8.0;
    // The grey level of the page at board point (x, y), m.
    let shade = |x: f64, y: f64| -> f64 {
        let (col, row) = ((x / pitch).floor(), (y / pitch).floor());
        if col < 0.0 || row < 0.0 || col >= f64::from(board.cols) || row >= f64::from(board.rows) {
            return 255.0;
        }
        // Cells of the tag image: the black square from 1 to 9, its top row first.
        let tx = 1.0 + (x - col * pitch) / cell;
        let ty = 1.0 + (s - (y - row * pitch)) / cell;
        if !(0.0..CELLS as f64).contains(&tx) || !(0.0..CELLS as f64).contains(&ty) {
            return 255.0;
        }
        let tag = &bits[(row as u32 * board.cols + col as u32) as usize];
        f64::from(tag[ty as usize * CELLS + tx as usize])
    };
    const SUB: usize = 4;
    let mut pixels = vec![255u8; (WIDTH * HEIGHT) as usize];
    for (k, pixel) in pixels.iter_mut().enumerate() {
        let (i, j) = ((k % WIDTH as usize) as f64, (k / WIDTH as usize) as f64);
        let mut sum = 0.0;
        for a in 0..SUB {
            for b in 0..SUB {
                let u = i - 0.5 + (a as f64 + 0.5) / SUB as f64;
                let v = j - 0.5 + (b as f64 + 0.5) / SUB as f64;
                let p = back * Vector3::new(u, v, 1.0);
                sum += shade(p.x / p.z, p.y / p.z);
            }
        }
        *pixel = (sum / (SUB * SUB) as f64).round() as u8;
    }
    let project = |p: Point3<f64>| {
        let q = h * Vector3::new(p.x, p.y, 1.0);
        [q.x / q.z, q.y / q.z]
    };
    let truth = board
        .tags()
        .map(|(id, corners)| (id, corners.map(project)))
        .collect();
    Rendered { pixels, truth }
}
