//! Whether the camera sees the whole board, facing it: the test the planner
//! keeps a pose by when a camera measures (like the collision contacts, a
//! geometric test that belongs to the files' objects; the planner calls it).

use nalgebra::{IsometryMatrix3, Vector3};

use super::{AprilGrid, Intrinsics};

/// Distance every projected corner keeps from the image's edges, px: a tag
/// cut by the edge is not detected, and the corner refinement's window
/// (a few pixels each side) must lie inside the image.
pub const DEFAULT_MARGIN_PX: f64 = 10.0;

/// The largest angle between the board's normal and the line of sight to its
/// centre, degrees. At 60° a tag is foreshortened to half its width: on a
/// webcam a 12 cm board about 1 m away spans about 120 px face-on, each of a
/// tag's 10 cells then a pixel or two across, about where AprilTag detection
/// starts to miss tags, and the corners' error grows as the cells narrow.
pub const DEFAULT_MAX_OBLIQUITY_DEG: f64 = 60.0;

/// The margin the planner keeps from the image's edges, px: a setup is told
/// within a few centimetres and degrees, and where the camera really stands
/// moves the board's image by tens of pixels (about 0.8 m away, 2 cm is
/// 23 px and 2° is 32 px on a 720p webcam), and the arm itself is off by
/// centimetres. Of the 120 views `lrmcal demo --camera` planned (seed 1,
/// the simulated camera off its setup by such errors), the true camera saw
/// 91 with the detector's own margin ([`DEFAULT_MARGIN_PX`], and 60°), 102
/// with 60 px (and 55°), 112 with these.
pub const PLANNING_MARGIN_PX: f64 = 100.0;

/// The largest obliquity the planner keeps, degrees: the camera's own limit
/// ([`DEFAULT_MAX_OBLIQUITY_DEG`]) less the few degrees a setup may be off.
pub const PLANNING_MAX_OBLIQUITY_DEG: f64 = 50.0;

/// How far from the edges and how obliquely the board may be seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewLimits {
    /// See [`DEFAULT_MARGIN_PX`].
    pub margin_px: f64,
    /// See [`DEFAULT_MAX_OBLIQUITY_DEG`].
    pub max_obliquity_deg: f64,
}

impl ViewLimits {
    /// What the planner keeps: a margin for a setup told roughly
    /// ([`PLANNING_MARGIN_PX`], [`PLANNING_MAX_OBLIQUITY_DEG`]).
    pub const PLANNING: Self = Self {
        margin_px: PLANNING_MARGIN_PX,
        max_obliquity_deg: PLANNING_MAX_OBLIQUITY_DEG,
    };
}

/// What a camera needs to detect every tag of the board.
impl Default for ViewLimits {
    fn default() -> Self {
        Self {
            margin_px: DEFAULT_MARGIN_PX,
            max_obliquity_deg: DEFAULT_MAX_OBLIQUITY_DEG,
        }
    }
}

/// Why the camera does not see the board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unseen {
    /// The board's centre is at or behind the camera's plane.
    Behind,
    /// The board shows its back, or is seen more obliquely than allowed.
    Oblique {
        /// The angle between its normal and the line of sight, degrees.
        angle_deg: f64,
    },
    /// A corner projects outside the image (or within the margin of its edge).
    OutOfImage,
}

/// Whether `camera` sees every corner of `board`, facing it, with the board
/// frame at `camera_from_board` (the board's pose in the camera frame).
pub fn check(
    camera: &Intrinsics,
    board: &AprilGrid,
    camera_from_board: &IsometryMatrix3<f64>,
    limits: &ViewLimits,
) -> Result<(), Unseen> {
    let centre = camera_from_board * board.centre();
    if centre.z.is_nan() || centre.z <= 0.0 {
        return Err(Unseen::Behind);
    }
    // The normal is the board's z, out of its face: facing the camera, it
    // points back along the line of sight.
    let normal = camera_from_board * Vector3::z();
    let cos = normal.dot(&-centre.coords) / centre.coords.norm();
    let angle_deg = cos.clamp(-1.0, 1.0).acos().to_degrees();
    if angle_deg.is_nan() || angle_deg > limits.max_obliquity_deg {
        return Err(Unseen::Oblique { angle_deg });
    }
    let inside = board.corners().all(|corner| {
        camera
            .project(&(camera_from_board * corner))
            .is_some_and(|pixel| camera.contains(&pixel, limits.margin_px))
    });
    if inside {
        Ok(())
    } else {
        Err(Unseen::OutOfImage)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Rotation3, Translation3};

    use super::*;

    fn webcam() -> Intrinsics {
        Intrinsics {
            width_px: 1280,
            height_px: 720,
            fx: 910.0,
            fy: 910.0,
            cx: 639.5,
            cy: 359.5,
            distortion: [-0.1, 0.05, 0.0, 0.0, 0.0],
        }
    }

    /// A 4x4 board of 4 cm tags: 17.8 cm across.
    fn board() -> AprilGrid {
        AprilGrid {
            rows: 4,
            cols: 4,
            tag_size_m: 0.04,
            spacing: 0.3,
            first_id: 0,
        }
    }

    /// The board `distance_m` ahead, its centre on the optical axis, turned
    /// by `turn` about its centre, then moved by `shift_m`. Facing the
    /// camera (turn identity) its z points at the camera: the board frame is
    /// the camera's turned half a turn about x.
    fn placed(
        distance_m: f64,
        turn: Rotation3<f64>,
        shift_m: Vector3<f64>,
    ) -> IsometryMatrix3<f64> {
        let facing = Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI) * turn;
        let centre = board().centre().coords;
        let at = Vector3::new(0.0, 0.0, distance_m) + shift_m;
        IsometryMatrix3::from_parts(Translation3::from(at - facing * centre), facing)
    }

    fn seen(pose: &IsometryMatrix3<f64>) -> Result<(), Unseen> {
        check(&webcam(), &board(), pose, &ViewLimits::default())
    }

    #[test]
    fn a_board_straight_ahead_is_seen() {
        assert_eq!(
            seen(&placed(0.8, Rotation3::identity(), Vector3::zeros())),
            Ok(())
        );
        // Turned 50° about its vertical: still within the limit.
        let turn = Rotation3::from_axis_angle(&Vector3::y_axis(), 50f64.to_radians());
        assert_eq!(seen(&placed(0.8, turn, Vector3::zeros())), Ok(()));
    }

    #[test]
    fn a_board_turned_away_or_too_oblique_is_not_seen() {
        let away = Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
        assert!(matches!(
            seen(&placed(0.8, away, Vector3::zeros())),
            Err(Unseen::Oblique { angle_deg }) if angle_deg > 179.0
        ));
        let steep = Rotation3::from_axis_angle(&Vector3::x_axis(), 70f64.to_radians());
        assert!(matches!(
            seen(&placed(0.8, steep, Vector3::zeros())),
            Err(Unseen::Oblique { angle_deg }) if (angle_deg - 70.0).abs() < 1e-9
        ));
    }

    #[test]
    fn a_board_behind_the_camera_is_not_seen() {
        let pose = placed(0.8, Rotation3::identity(), Vector3::new(0.0, 0.0, -1.6));
        assert_eq!(seen(&pose), Err(Unseen::Behind));
    }

    #[test]
    fn a_board_partly_out_of_the_image_is_not_seen() {
        // The image's half width at 0.8 m is about 0.56 m: the board's right
        // half falls outside.
        let pose = placed(0.8, Rotation3::identity(), Vector3::new(0.55, 0.0, 0.0));
        assert_eq!(seen(&pose), Err(Unseen::OutOfImage));
        // Too close: it fills more than the image.
        let pose = placed(0.1, Rotation3::identity(), Vector3::zeros());
        assert_eq!(seen(&pose), Err(Unseen::OutOfImage));
    }
}
