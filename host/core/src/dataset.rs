//! In-memory forms of the files users exchange with us (`docs/FORMATS.md`):
//! measured poses, pose lists and predictions, in SI units.
//!
//! Files carry degrees and millimetres; everything in memory is radians and
//! metres. The parsers and writers live in `crate::io`.
//!
//! A measurement file's rows are in the order the poses were visited
//! (`docs/FORMATS.md`): that order says which way each joint arrived at each
//! pose ([`visiting_order`]), which the backlash of the joints depends on.

use model::PerJoint;
use model::backlash::{Approach, ApproachTracker};
use nalgebra::{Point2, Vector3};

/// One commanded joint configuration with its id.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Integer id of the configuration; the same id is the same configuration.
    pub id: u32,
    /// Commanded joint angles, rad, one per joint of the arm.
    pub q: PerJoint<f64>,
}

/// Longest target name, in bytes.
pub const TARGET_NAME_MAX: usize = 32;

/// Most targets one measurement file may name (a target's index is a byte).
pub const MAX_TARGETS: usize = 255;

/// The name of a measured target (a marker, a retro-reflector) on the end
/// effector; fixed capacity, so measurements stay `Copy`.
pub type TargetName = arrayvec::ArrayString<TARGET_NAME_MAX>;

/// One row of a measurement file: a pose, its load and the measured point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    /// The commanded pose.
    pub pose: Pose,
    /// Payload mass at the tool, kg.
    pub load_kg: f64,
    /// Measured point in the world frame, m. A camera's measurement: the
    /// point the camera puts its target at, the corner of the board where
    /// the view's corners place the board (`pixel` is what it measured).
    pub position: Vector3<f64>,
    /// A camera's measurement: the pixel its target (a corner of the board)
    /// was seen at, OpenCV's convention, px; `None` for a tracker's. The fit
    /// works on the pixel where there is one.
    pub pixel: Option<Point2<f64>>,
    /// Which target was measured; `None` in a file without a `target`
    /// column, whose rows are all of the one target (the arm's tool point).
    pub target: Option<TargetName>,
    /// The way each joint arrived at the pose, from the rows' order
    /// ([`visiting_order`]); not a column of the file.
    pub approach: PerJoint<Approach>,
}

/// The approach of the `joints` joints of an arm that has not moved since
/// home: the arm starts there, every joint taken to have arrived rising.
pub fn from_home(joints: usize) -> PerJoint<Approach> {
    PerJoint::splat(joints, Approach::Rising)
}

/// The way each joint arrives at each of the commanded poses `qs`, visited
/// in order from home (`q = 0`, every joint rising,
/// [`model::backlash::ApproachTracker`]): the one definition the simulator,
/// identification and validation share. A pose repeated (another load or
/// target at the same pose) moves no joint and keeps the approaches.
pub fn approaches<'a>(qs: impl IntoIterator<Item = &'a PerJoint<f64>>) -> Vec<PerJoint<Approach>> {
    let mut qs = qs.into_iter().peekable();
    let joints = qs.peek().map_or(0, |q| q.len());
    let mut tracker = ApproachTracker::new(&PerJoint::splat(joints, 0.0));
    qs.map(|q| tracker.visit(q)).collect()
}

/// Sets every row's approach from the rows' order, the visiting order.
pub fn visiting_order(rows: &mut [Measurement]) {
    let ways = approaches(rows.iter().map(|m| &m.pose.q));
    for (m, way) in rows.iter_mut().zip(ways) {
        m.approach = way;
    }
}

/// A predicted tool point for a pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// Pose id.
    pub pose: u32,
    /// Predicted tool point, world frame, m.
    pub position: Vector3<f64>,
}

/// One row of a pose list: a pose and, if the list says, the load to measure it with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseRow {
    /// The commanded pose.
    pub pose: Pose,
    /// Payload mass at the tool, kg, when the list gives one.
    pub load_kg: Option<f64>,
}

/// The distinct loads of `rows`, ascending.
pub fn loads_of(rows: &[Measurement]) -> Vec<f64> {
    let mut loads: Vec<f64> = rows.iter().map(|m| m.load_kg).collect();
    loads.sort_by(f64::total_cmp);
    loads.dedup();
    loads
}

/// The distinct poses of `rows` measured under `load_kg`, in file order.
pub fn poses_under(rows: &[Measurement], load_kg: f64) -> Vec<Pose> {
    let mut seen = std::collections::HashSet::new();
    rows.iter()
        .filter(|m| m.load_kg == load_kg && seen.insert(m.pose.id))
        .map(|m| m.pose)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use Approach::{Falling, Rising};

    fn row(q: [f64; 6], load_kg: f64) -> Measurement {
        Measurement {
            pose: Pose { id: 0, q: q.into() },
            load_kg,
            position: Vector3::zeros(),
            pixel: None,
            target: None,
            approach: from_home(6),
        }
    }

    /// From home, a joint whose command rises arrives rising, one whose
    /// command falls arrives falling, one not moved keeps its way; the same
    /// pose again (another load) moves nothing.
    #[test]
    fn the_rows_order_gives_each_joint_its_way_in() {
        let mut rows = [
            row([0.5, 0.0, -0.5, 0.0, 0.0, 0.0], 0.0),
            row([0.2, 0.0, -0.5, 0.3, 0.0, 0.0], 0.0),
            row([0.2, 0.0, -0.5, 0.3, 0.0, 0.0], 0.07),
            row([0.2, 1.0, 0.0, 0.3, -0.1, 0.0], 0.0),
        ];
        visiting_order(&mut rows);
        let ways: Vec<_> = rows.iter().map(|m| m.approach).collect();
        assert_eq!(ways[0], [Rising, Rising, Falling, Rising, Rising, Rising]);
        assert_eq!(ways[1], [Falling, Rising, Falling, Rising, Rising, Rising]);
        assert_eq!(ways[2], ways[1]);
        assert_eq!(ways[3], [Falling, Rising, Rising, Rising, Falling, Rising]);
    }
}
