//! A camera's views as the fit's measurements: one per corner seen, its
//! target the corner (`tag7.c2`: tag 7's corner 2), its pixel what the fit
//! compares, and the point the view's board pose puts it at
//! ([`super::board_pose`]), in the camera frame, what registration and the
//! plausibility checks start from.

use nalgebra::{Point2, Vector3};

use super::board_pose::{MIN_CORNERS, board_pose};
use lrmcal_core::camera::views::View;
use lrmcal_core::camera::{AprilGrid, Intrinsics, Mount};
use lrmcal_core::dataset::{Measurement, TargetName};

/// Why a camera's views cannot be measurements.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ViewError {
    /// A tag the board does not have.
    #[error(
        "pose {pose} under {load_kg} kg: tag {tag} is not on the board (ids {first} to {last}): is it the board file of the board the arm carried?"
    )]
    ForeignTag {
        /// Pose id.
        pose: u32,
        /// Load, kg.
        load_kg: f64,
        /// The tag's id.
        tag: u32,
        /// The board's first id.
        first: u32,
        /// The board's last id.
        last: u32,
    },
    /// The view's corners do not place the board.
    #[error(
        "pose {pose} under {load_kg} kg: its {corners} corners do not place the board in front of the camera (at least {MIN_CORNERS} corners of one plane are needed, seen through the lens the intrinsics describe): remove the pose, or check the intrinsics and the board file"
    )]
    Unplaced {
        /// Pose id.
        pose: u32,
        /// Load, kg.
        load_kg: f64,
        /// Corners the view has.
        corners: usize,
    },
}

/// The name of tag `tag`'s corner `corner` as a target.
pub fn corner_target(tag: u32, corner: usize) -> TargetName {
    let mut name = TargetName::new();
    // At most "tag4294967295.c3": 16 bytes of the 32 a name holds.
    let _ = std::fmt::Write::write_fmt(&mut name, format_args!("tag{tag}.c{corner}"));
    name
}

/// Each corner target's place in the board frame, m.
pub type BoardCorners = Vec<(TargetName, Vector3<f64>)>;

/// The measurements of `views` (in their order, each corner of each tag),
/// with the board's corners by target name, in the order the measurements
/// first name them. Each measurement's point is what registration places
/// the arm by, from the view's board pose: the corner in the camera frame
/// when the arm carries the board (`mount` eye-to-hand), the camera's
/// centre in the board frame when it carries the camera (eye-in-hand).
pub fn corner_measurements(
    camera: &Intrinsics,
    board: &AprilGrid,
    views: &[View],
    mount: Mount,
) -> Result<(Vec<Measurement>, BoardCorners), ViewError> {
    let layout: Vec<(u32, [nalgebra::Point3<f64>; 4])> = board.tags().collect();
    let mut measurements = Vec::new();
    let mut corners: BoardCorners = Vec::new();
    for view in views {
        let mut placed = Vec::new();
        for tag in &view.tags {
            let Some((_, at)) = layout.iter().find(|(id, _)| *id == tag.id) else {
                return Err(ViewError::ForeignTag {
                    pose: view.pose.id,
                    load_kg: view.load_kg,
                    tag: tag.id,
                    first: board.first_id,
                    last: board.first_id + board.tag_count() - 1,
                });
            };
            placed.push((tag, at));
        }
        let pose = board_pose(camera, board, &view.tags).ok_or(ViewError::Unplaced {
            pose: view.pose.id,
            load_kg: view.load_kg,
            corners: 4 * view.tags.len(),
        })?;
        for (tag, at) in placed {
            for (k, ([u, v], corner)) in tag.corners_px.iter().zip(at).enumerate() {
                let target = corner_target(tag.id, k);
                if !corners.iter().any(|(name, _)| *name == target) {
                    corners.push((target, corner.coords));
                }
                let position = match mount {
                    Mount::EyeToHand => pose * corner,
                    Mount::EyeInHand => pose.inverse() * nalgebra::Point3::origin(),
                };
                measurements.push(Measurement {
                    pose: view.pose,
                    load_kg: view.load_kg,
                    position: position.coords,
                    pixel: Some(Point2::new(*u, *v)),
                    target: Some(target),
                    approach: view.approach,
                });
            }
        }
    }
    Ok((measurements, corners))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::testing::{board, webcam};
    use lrmcal_core::camera::corners::TagCorners;
    use lrmcal_core::dataset::Pose;
    use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3};

    fn view_at(pose: &IsometryMatrix3<f64>, ids: &[u32]) -> View {
        let tags = board()
            .tags()
            .filter(|(id, _)| ids.contains(id))
            .map(|(id, corners)| TagCorners {
                id,
                corners_px: corners.map(|c| {
                    let p = webcam().project(&(pose * c)).unwrap();
                    [p.x, p.y]
                }),
            })
            .collect();
        View::new(
            Pose {
                id: 5,
                q: model::PerJoint::splat(6, 0.0),
            },
            0.0,
            None,
            tags,
        )
    }

    /// Each corner is a measurement of its own target, at its pixel and at
    /// the point the view's board pose puts it; the targets' corners are
    /// the board's.
    #[test]
    fn every_corner_is_a_target_seen_at_its_pixel_and_point() {
        let truth = IsometryMatrix3::from_parts(
            Translation3::new(0.05, -0.02, 0.8),
            Rotation3::from_euler_angles(0.3, -0.2, 0.4),
        );
        let (measurements, corners) = corner_measurements(
            &webcam(),
            &board(),
            &[view_at(&truth, &[0, 7])],
            Mount::EyeToHand,
        )
        .unwrap();
        assert_eq!(measurements.len(), 8);
        assert_eq!(corners.len(), 8);
        assert_eq!(corners[4].0.as_str(), "tag7.c0");
        for m in &measurements {
            let (_, corner) = corners.iter().find(|(n, _)| Some(*n) == m.target).unwrap();
            let point = truth * Point3::from(*corner);
            assert!((m.position - point.coords).norm() < 1e-9);
            let pixel = webcam().project(&point).unwrap();
            assert!((m.pixel.unwrap() - pixel).norm() < 1e-9);
        }
    }

    #[test]
    fn a_tag_off_the_board_and_an_unplaceable_view_are_refused_by_pose() {
        let truth =
            IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.8), Rotation3::identity());
        let mut view = view_at(&truth, &[3]);
        view.tags[0].id = 40;
        let e = corner_measurements(&webcam(), &board(), &[view], Mount::EyeToHand).unwrap_err();
        assert!(
            e.to_string().contains("pose 5") && e.to_string().contains("tag 40"),
            "{e}"
        );
        let mut view = view_at(&truth, &[3]);
        view.tags.clear();
        let e = corner_measurements(&webcam(), &board(), &[view], Mount::EyeToHand).unwrap_err();
        assert!(e.to_string().contains("do not place the board"), "{e}");
    }
}
