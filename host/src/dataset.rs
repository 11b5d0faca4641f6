//! In-memory forms of the files users exchange with us (`docs/FORMATS.md`):
//! measured poses, pose lists and predictions, in SI units.
//!
//! Files carry degrees and millimetres; everything in memory is radians and
//! metres. The parsers and writers live in `crate::io`.

use nalgebra::Vector3;

/// One commanded joint configuration with its id.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Integer id of the configuration; the same id is the same configuration.
    pub id: u32,
    /// Commanded joint angles, rad.
    pub q: [f64; model::JOINTS],
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
    /// Measured point in the world frame, m.
    pub position: Vector3<f64>,
    /// Which target was measured; `None` in a file without a `target`
    /// column, whose rows are all of the one target (the arm's tool point).
    pub target: Option<TargetName>,
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
