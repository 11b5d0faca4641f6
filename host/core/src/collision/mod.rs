//! The arm's collision bodies: as an arm file describes them ([`spec`]) and
//! placed on the links of an arm ([`volumes`]), where the planner and the
//! inverse kinematics measure distances between them.

mod body;
mod placing;
mod skeleton;
pub mod spec;
pub mod volumes;

pub use body::{Anchor, Body, Shape};
pub use spec::{
    BodySpec, CollisionSpec, Floor, FrameRef, PointSpec, ShapeSpec, SpecError, SpecPlace,
};
pub use volumes::{BodySet, Contact, SKELETON_RADIUS_PER_LENGTH};
