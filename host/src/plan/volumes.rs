//! The arm's bodies as capsules hung on the model's frames, and the two
//! collision tests on them: against the ground plane and against each other.
//!
//! A capsule is the set of points within `radius` of a segment between two
//! frame origins of the chain (or the tool point), so it follows the arm
//! wherever the model puts the frames. Capsules next to each other in the
//! list share a joint and always touch; only the others are tested.

use std::fmt;

use model::ChainFrames;
use nalgebra::Vector3;
use serde::Serialize;

use super::segment::segment_distance;

/// A point of the chain a capsule ends at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Anchor {
    /// The origin of DH frame `i` (0 = base, 6 = flange).
    Frame(usize),
    /// The tool point (the tracker target's centre).
    Tool,
}

impl Anchor {
    /// Where the anchor is, world frame, m.
    pub fn position(self, frames: &ChainFrames<f64>) -> Vector3<f64> {
        match self {
            Self::Frame(i) => frames.frames[i].translation.vector,
            Self::Tool => frames.tool_point(),
        }
    }
}

/// One body of the arm as a capsule.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Capsule {
    /// Name used in reports.
    pub name: &'static str,
    /// One end of the axis.
    pub from: Anchor,
    /// The other end of the axis.
    pub to: Anchor,
    /// Radius around the axis, m.
    pub radius_m: f64,
    /// Whether the ground test applies (not to the part standing on it).
    pub above_ground: bool,
}

/// The bodies of an elbow arm with a spherical wrist laid out like the bundled
/// one (shoulder at frame 1, elbow at frames 2/3, wrist at frames 4/5), base
/// to tip. Radii are those of printed links around hobby servos.
pub fn elbow_arm_bodies() -> Vec<Capsule> {
    use Anchor::{Frame, Tool};
    let capsule = |name, from, to, radius_m, above_ground| Capsule {
        name,
        from,
        to,
        radius_m,
        above_ground,
    };
    vec![
        capsule("base", Frame(0), Frame(1), 0.04, false),
        capsule("upper arm", Frame(1), Frame(2), 0.025, true),
        capsule("forearm", Frame(3), Frame(4), 0.025, true),
        capsule("hand", Frame(5), Frame(6), 0.025, true),
        capsule("target", Frame(6), Tool, 0.015, true),
    ]
}

/// What a pose's bodies hit first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Contact {
    /// A body comes closer to the ground than the clearance.
    Ground {
        /// The body.
        body: &'static str,
    },
    /// Two bodies that do not share a joint come closer than the clearance.
    SelfCollision {
        /// The body nearer the base.
        a: &'static str,
        /// The body nearer the tip.
        b: &'static str,
    },
}

impl fmt::Display for Contact {
    /// `forearm too close to the ground`, `upper arm too close to hand`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Ground { body } => write!(f, "{body} too close to the ground"),
            Self::SelfCollision { a, b } => write!(f, "{a} too close to {b}"),
        }
    }
}

/// The first body (base to tip) that comes within `clearance_m` of the ground
/// plane `z = ground_z_m`, if any.
pub fn ground_contact(
    bodies: &[Capsule],
    frames: &ChainFrames<f64>,
    ground_z_m: f64,
    clearance_m: f64,
) -> Option<Contact> {
    bodies.iter().filter(|b| b.above_ground).find_map(|b| {
        // A segment's lowest point is one of its ends.
        let low = b.from.position(frames).z.min(b.to.position(frames).z) - b.radius_m;
        (low < ground_z_m + clearance_m).then_some(Contact::Ground { body: b.name })
    })
}

/// The first pair of non-adjacent bodies (in list order) whose surfaces come
/// within `clearance_m` of each other, if any.
pub fn self_contact(
    bodies: &[Capsule],
    frames: &ChainFrames<f64>,
    clearance_m: f64,
) -> Option<Contact> {
    let ends: Vec<_> = bodies
        .iter()
        .map(|b| (b.from.position(frames), b.to.position(frames)))
        .collect();
    for i in 0..bodies.len() {
        for j in i + 2..bodies.len() {
            let gap = segment_distance(&ends[i].0, &ends[i].1, &ends[j].0, &ends[j].1)
                - bodies[i].radius_m
                - bodies[j].radius_m;
            if gap < clearance_m {
                return Some(Contact::SelfCollision {
                    a: bodies[i].name,
                    b: bodies[j].name,
                });
            }
        }
    }
    None
}
