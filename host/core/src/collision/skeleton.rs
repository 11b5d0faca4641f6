//! The arm's skeleton: the segments its DH offsets draw between the frame
//! origins, the stand-in for the links' bodies when the arm file gives none
//! and the measure of how far apart two bodies sit along the arm.

use model::ChainFrames;
use nalgebra::{Point3, Vector3};

use super::spec::FrameRef;

/// The arm's skeleton in one pose: frame origins, the foot of each link's
/// `d` offset, and how far along the arm each lies.
pub(super) struct Skeleton {
    /// The arm's joints, n.
    pub(super) joints: usize,
    /// Origin of DH frame i (0..=n), world.
    pub(super) origins: Vec<Vector3<f64>>,
    /// For link i (1-based), the point `d_i` along frame i-1's z axis, world.
    pub(super) feet: Vec<Vector3<f64>>,
    /// `d_i` of link i, m (signed, along frame i-1's z).
    pub(super) d_m: Vec<f64>,
    /// Distance along the skeleton from the base origin to origin i, m.
    pub(super) arc_m: Vec<f64>,
    /// The tool point in frame n, m.
    pub(super) tool_in_flange: Vector3<f64>,
}

impl Skeleton {
    pub(super) fn of(frames: &ChainFrames<f64>) -> Self {
        let joints = frames.frames.len() - 1;
        let origins: Vec<_> = frames.frames.iter().map(|f| f.translation.vector).collect();
        let mut feet = origins.clone();
        let mut d_m = vec![0.0; joints + 1];
        let mut arc_m = vec![0.0; joints + 1];
        for i in 1..=joints {
            let z = frames.frames[i - 1]
                .rotation
                .matrix()
                .column(2)
                .into_owned();
            d_m[i] = (origins[i] - origins[i - 1]).dot(&z);
            feet[i] = origins[i - 1] + z * d_m[i];
            arc_m[i] = arc_m[i - 1] + d_m[i].abs() + (origins[i] - feet[i]).norm();
        }
        let tool_in_flange = frames.frames[joints]
            .inverse_transform_point(&Point3::from(frames.tool_point))
            .coords;
        Self {
            joints,
            origins,
            feet,
            d_m,
            arc_m,
            tool_in_flange,
        }
    }

    /// The summed lengths of the links' offsets, m.
    pub(super) fn length_m(&self) -> f64 {
        self.arc_m[self.joints]
    }

    /// How far along the skeleton a point of `frame` is (its frame origin's distance), m.
    pub(super) fn arc_of(&self, frame: FrameRef) -> f64 {
        match frame {
            FrameRef::Dh(i) => self.arc_m[i],
            FrameRef::Tool => self.arc_m[self.joints] + self.tool_in_flange.norm(),
        }
    }
}
