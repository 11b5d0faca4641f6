//! Rendered images of an AprilTag board whose corners are known exactly:
//! the simulator's renderer (`lrmcal_engine::sim::render`, each tag's bits
//! from the AprilTag C library itself) through a camera without distortion,
//! pixel centres at integer coordinates (OpenCV's convention).

use lrmcal_core::camera::{AprilGrid, Intrinsics};
use lrmcal_engine::sim::render::Look;
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The rendered images' size, a 720p webcam's.
pub const WIDTH: u32 = 1280;
/// See [`WIDTH`].
pub const HEIGHT: u32 = 720;

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

/// The camera of `view`: a 900 px focal length, the principal point in the
/// middle of the image, no distortion.
fn camera() -> Intrinsics {
    Intrinsics {
        width_px: WIDTH,
        height_px: HEIGHT,
        fx: 900.0,
        fy: 900.0,
        cx: f64::from(WIDTH) / 2.0,
        cy: f64::from(HEIGHT) / 2.0,
        distortion: [0.0; 5],
    }
}

/// The board's pose in the camera frame of `view`.
fn placed(board: &AprilGrid, view: View) -> IsometryMatrix3<f64> {
    // Facing the camera upright: board x along the camera's x, board y
    // against the camera's y (down), board z towards the camera.
    let facing =
        Rotation3::from_matrix_unchecked(Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)));
    let r = Rotation3::from_axis_angle(&Vector3::x_axis(), view.tilt_deg.to_radians())
        * Rotation3::from_axis_angle(&Vector3::z_axis(), -view.roll_deg.to_radians())
        * facing;
    let t = Vector3::new(0.0, 0.0, view.distance_m) - r * board.centre().coords;
    IsometryMatrix3::from_parts(Translation3::from(t), r)
}

/// Renders `board` seen from `view` by the simulator's renderer, sharp and
/// noiseless, black tags on a white page.
pub fn render(board: &AprilGrid, view: View) -> Rendered {
    let camera = camera();
    let pose = placed(board, view);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let pixels = lrmcal_engine::sim::render::render(&camera, board, &pose, &Look::IDEAL, &mut rng);
    let project = |p: Point3<f64>| {
        let q = camera
            .project(&(pose * p))
            .expect("the board is in front of the camera");
        [q.x, q.y]
    };
    let truth = board
        .tags()
        .map(|(id, corners)| (id, corners.map(project)))
        .collect();
    Rendered { pixels, truth }
}
