//! A body of the arm: convex shapes anchored on the DH frames of the link
//! it moves with.

use model::ChainFrames;
use nalgebra::{IsometryMatrix3, Point3, Vector3};

/// A point fixed to a DH frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    /// The DH frame, 0 (base) to 6 (flange).
    pub frame: usize,
    /// The point in that frame, m.
    pub offset_m: Vector3<f64>,
}

impl Anchor {
    /// Where the anchor is, world frame, m.
    pub fn position(&self, frames: &ChainFrames<f64>) -> Vector3<f64> {
        (frames.frames[self.frame] * Point3::from(self.offset_m)).coords
    }
}

/// One convex piece of a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The points within `radius_m` of the segment `from`–`to`.
    Capsule {
        /// One end of the axis.
        from: Anchor,
        /// The other end.
        to: Anchor,
        /// Radius, m.
        radius_m: f64,
    },
    /// A box fixed to a DH frame.
    Box {
        /// The DH frame.
        frame: usize,
        /// The box's centre and axes in that frame.
        placement: IsometryMatrix3<f64>,
        /// Half its size along its own axes, m.
        half_extents_m: Vector3<f64>,
    },
}

impl Shape {
    /// How far the shape reaches from its core: a capsule's radius, a box's
    /// smallest half-size.
    pub(super) fn thickness_m(&self) -> f64 {
        match self {
            Self::Capsule { radius_m, .. } => *radius_m,
            Self::Box { half_extents_m, .. } => half_extents_m.min(),
        }
    }

    /// Whether every size is a finite number >= 0.
    pub(super) fn sizes_valid(&self) -> bool {
        let ok = |x: f64| x.is_finite() && x >= 0.0;
        match self {
            Self::Capsule { radius_m, .. } => ok(*radius_m),
            Self::Box { half_extents_m, .. } => half_extents_m.iter().all(|&h| ok(h)),
        }
    }
}

/// One body of the arm, fixed to one link.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Name used in reports.
    pub name: String,
    /// Its convex pieces.
    pub shapes: Vec<Shape>,
    /// The links it moves with, an inclusive range (two when it lies on the
    /// axis of the joint between them).
    pub links: [usize; 2],
    /// Where it starts and ends along the skeleton, m from the base origin:
    /// how much arm lies between two bodies.
    pub span_m: [f64; 2],
    /// Whether the floor test applies.
    pub floor: bool,
}

impl Body {
    /// How far its thickest shape reaches from its core, m.
    pub fn thickness_m(&self) -> f64 {
        self.shapes
            .iter()
            .map(Shape::thickness_m)
            .fold(0.0, f64::max)
    }
}
