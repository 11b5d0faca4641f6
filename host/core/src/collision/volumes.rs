//! The arm's bodies placed on the model's frames, which pairs of them are
//! tested, and the two collision tests: against the floor and against each other.
//!
//! A body is fixed to one link: its shapes hang on DH frames (a point of
//! frame `i` moves with link `i`), so it follows the arm wherever the model
//! puts the frames. Without a body list the arm's skeleton is used: a capsule
//! along each link's `d` and `a` offsets and one from the flange to the tool
//! point, as thick as [`SKELETON_RADIUS_PER_LENGTH`] of the arm's length.
//!
//! Two bodies are tested against each other unless they sit on the same or
//! neighbouring links (a joint joins them), or the skeleton between them is
//! no longer than their two radii (the joints between them meet, as at an
//! elbow or a spherical wrist, so they touch in every pose), or the arm file
//! lists the pair under `ignore`.

use std::fmt;

use model::{Arm, ChainFrames, PerJoint};
use nalgebra::{Isometry3, IsometryMatrix3, Point3, UnitQuaternion, Vector3};
use parry3d_f64::shape::{Capsule, Cuboid};
use serde::Serialize;

use super::body::{Anchor, Body, Shape};
use super::placing::{non_negative, place};
use super::skeleton::Skeleton;
use super::spec::{CollisionSpec, FrameRef, SpecError, SpecPlace};

/// Radius of the skeleton's capsules per metre of arm (the summed lengths of
/// the links' `d` and `a` offsets).
///
/// Arms of one kind keep their proportions across sizes: a link must be
/// thick in proportion to its length to carry its own weight and the
/// payload's at the same deflection. A twentieth gives 25 mm on the bundled
/// 0.49 m arm (printed links around hobby servos) and 84 mm on a UR10-like
/// 1.68 m arm (its shoulder and elbow housings); the tool capsule is half as
/// thick, being a tracker target or a gripper rather than a structural link.
pub const SKELETON_RADIUS_PER_LENGTH: f64 = 0.05;

/// The arm's bodies and the pairs of them the self-collision test checks.
#[derive(Clone, Debug, PartialEq)]
pub struct BodySet {
    bodies: Vec<Body>,
    pairs: Vec<[usize; 2]>,
}

/// What a pose's bodies hit first.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub enum Contact {
    /// A body comes closer to the floor than the clearance.
    Ground {
        /// The body.
        body: String,
    },
    /// Two bodies that are tested against each other come closer than the clearance.
    SelfCollision {
        /// The body earlier in the list.
        a: String,
        /// The body later in the list.
        b: String,
    },
}

impl fmt::Display for Contact {
    /// `link 4 too close to the ground`, `link 2 too close to tool`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Ground { body } => write!(f, "{body} too close to the ground"),
            Self::SelfCollision { a, b } => write!(f, "{a} too close to {b}"),
        }
    }
}

/// Segments shorter than this are no body (a link without that offset), m.
const NO_LENGTH_M: f64 = 1e-9;

impl BodySet {
    /// The skeleton of the arm whose frames (in any pose) are `frames`: for
    /// each link `i` a body `link i` of up to two capsules, along `d_i` and
    /// along `a_i` (none if both are zero), and a body `tool` from the flange
    /// to the tool point, half as thick. `radius_m` overrides the links'
    /// radius ([`SKELETON_RADIUS_PER_LENGTH`] of the arm's length).
    ///
    /// Link 1 turns about joint 1's axis only, so it is not tested against
    /// the floor.
    pub fn skeleton(frames: &ChainFrames<f64>, radius_m: Option<f64>) -> Self {
        let s = Skeleton::of(frames);
        let radius_m = radius_m.unwrap_or(SKELETON_RADIUS_PER_LENGTH * s.length_m());
        let anchor = |frame, offset_m| Anchor { frame, offset_m };
        let mut bodies = Vec::new();
        let n = s.joints;
        for i in 1..=n {
            let origin = anchor(i - 1, Vector3::zeros());
            let foot = anchor(i - 1, Vector3::new(0.0, 0.0, s.d_m[i]));
            let end = anchor(i, Vector3::zeros());
            let mut shapes = Vec::new();
            if s.d_m[i].abs() > NO_LENGTH_M {
                shapes.push(Shape::Capsule {
                    from: origin,
                    to: foot,
                    radius_m,
                });
            }
            if (s.origins[i] - s.feet[i]).norm() > NO_LENGTH_M {
                shapes.push(Shape::Capsule {
                    from: foot,
                    to: end,
                    radius_m,
                });
            }
            if !shapes.is_empty() {
                bodies.push(Body {
                    name: format!("link {i}"),
                    shapes,
                    links: [i, i],
                    span_m: [s.arc_m[i - 1], s.arc_m[i]],
                    floor: i >= 2,
                });
            }
        }
        if s.tool_in_flange.norm() > NO_LENGTH_M {
            bodies.push(Body {
                name: "tool".into(),
                shapes: vec![Shape::Capsule {
                    from: anchor(n, Vector3::zeros()),
                    to: anchor(n, s.tool_in_flange),
                    radius_m: radius_m / 2.0,
                }],
                links: [n, n],
                span_m: [s.arc_m[n], s.arc_of(FrameRef::Tool)],
                floor: true,
            });
        }
        let pairs = tested_pairs(&bodies, &[]);
        Self { bodies, pairs }
    }

    /// The bodies of `spec` placed on `arm` (its skeleton when `spec` lists
    /// none), and the pairs to test.
    pub fn for_arm(arm: &Arm<f64>, spec: &CollisionSpec) -> Result<Self, SpecError> {
        let frames = arm
            .chain()
            .frames(&PerJoint::splat(arm.joints.len(), 0.0), 0.0);
        let mut set = if spec.bodies.is_empty() {
            if let Some(r) = spec.skeleton_radius_m {
                non_negative(r, SpecPlace::Collision { key: "radius" })?;
            }
            Self::skeleton(&frames, spec.skeleton_radius_m)
        } else {
            if spec.skeleton_radius_m.is_some() {
                return Err(SpecError::new(
                    SpecPlace::Collision { key: "radius" },
                    "`radius` sizes the skeleton used without [[body]] tables; give each body its own size instead",
                ));
            }
            let tool = arm.tool.isometry();
            let skeleton = Skeleton::of(&frames);
            let mut bodies = Vec::with_capacity(spec.bodies.len());
            for (index, b) in spec.bodies.iter().enumerate() {
                if let Some(first) = spec.bodies[..index].iter().position(|o| o.name == b.name) {
                    return Err(SpecError::new(
                        SpecPlace::Body { index, key: "name" },
                        format!(
                            "expected a name no other body has, found `{}` (also body[{}])",
                            b.name,
                            first + 1
                        ),
                    ));
                }
                bodies.push(place(index, b, &tool, &skeleton)?);
            }
            Self {
                bodies,
                pairs: Vec::new(),
            }
        };
        let mut ignored = Vec::with_capacity(spec.ignore.len());
        for (index, [a, b]) in spec.ignore.iter().enumerate() {
            let find = |name: &String| {
                set.bodies
                    .iter()
                    .position(|body| &body.name == name)
                    .ok_or_else(|| {
                        SpecError::new(
                            SpecPlace::Ignore { index },
                            format!(
                                "expected the names of two bodies ({}), found `{name}`",
                                set.names().join(", ")
                            ),
                        )
                    })
            };
            let (i, j) = (find(a)?, find(b)?);
            if i == j {
                return Err(SpecError::new(
                    SpecPlace::Ignore { index },
                    format!("expected two different bodies, found `{a}` twice"),
                ));
            }
            ignored.push([i.min(j), i.max(j)]);
        }
        set.pairs = tested_pairs(&set.bodies, &ignored);
        Ok(set)
    }

    /// The bodies, in the order of the arm file (base to tip for the skeleton).
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// The pairs the self-collision test checks, as positions in [`BodySet::bodies`].
    pub fn tested_pairs(&self) -> &[[usize; 2]] {
        &self.pairs
    }

    fn names(&self) -> Vec<&str> {
        self.bodies.iter().map(|b| b.name.as_str()).collect()
    }

    /// The first body whose size is negative or not finite.
    pub fn invalid_size(&self) -> Option<&Body> {
        self.bodies
            .iter()
            .find(|b| !b.shapes.iter().all(Shape::sizes_valid))
    }

    /// The first body (in list order) that comes within `clearance_m` of
    /// the floor `z = floor_z_m`, if any.
    pub fn floor_contact(
        &self,
        frames: &ChainFrames<f64>,
        floor_z_m: f64,
        clearance_m: f64,
    ) -> Option<Contact> {
        self.bodies.iter().filter(|b| b.floor).find_map(|b| {
            let low = b
                .shapes
                .iter()
                .map(|s| lowest_z(s, frames))
                .fold(f64::INFINITY, f64::min);
            (low < floor_z_m + clearance_m).then(|| Contact::Ground {
                body: b.name.clone(),
            })
        })
    }

    /// The first tested pair whose surfaces come within `clearance_m` of each other, if any.
    pub fn self_contact(&self, frames: &ChainFrames<f64>, clearance_m: f64) -> Option<Contact> {
        let placed: Vec<Vec<Placed>> = self
            .bodies
            .iter()
            .map(|b| b.shapes.iter().map(|s| Placed::new(s, frames)).collect())
            .collect();
        self.pairs.iter().find_map(|&[i, j]| {
            let gap = placed[i]
                .iter()
                .flat_map(|a| placed[j].iter().map(move |b| a.distance(b)))
                .fold(f64::INFINITY, f64::min);
            (gap < clearance_m).then(|| Contact::SelfCollision {
                a: self.bodies[i].name.clone(),
                b: self.bodies[j].name.clone(),
            })
        })
    }
}

/// The pairs worth testing: not on the same or neighbouring links, not
/// joined by less skeleton than their radii, not `ignored`.
fn tested_pairs(bodies: &[Body], ignored: &[[usize; 2]]) -> Vec<[usize; 2]> {
    let mut pairs = Vec::new();
    for (i, a) in bodies.iter().enumerate() {
        for (j, b) in bodies.iter().enumerate().skip(i + 1) {
            let link_gap = (b.links[0] as isize - a.links[1] as isize)
                .max(a.links[0] as isize - b.links[1] as isize);
            let arm_between_m = (b.span_m[0] - a.span_m[1]).max(a.span_m[0] - b.span_m[1]);
            let joined = arm_between_m <= a.thickness_m() + b.thickness_m();
            if link_gap >= 2 && !joined && !ignored.contains(&[i, j]) {
                pairs.push([i, j]);
            }
        }
    }
    pairs
}

/// The lowest world z of a shape in this pose, m.
fn lowest_z(shape: &Shape, frames: &ChainFrames<f64>) -> f64 {
    match shape {
        Shape::Capsule {
            from, to, radius_m, ..
        } => from.position(frames).z.min(to.position(frames).z) - radius_m,
        Shape::Box {
            frame,
            placement,
            half_extents_m,
        } => {
            let world = box_in_world(*frame, placement, frames);
            // The corner lowest in z sits half a size down along each axis's z component.
            let r = world.rotation.matrix();
            let reach: f64 = (0..3).map(|k| r[(2, k)].abs() * half_extents_m[k]).sum();
            world.translation.vector.z - reach
        }
    }
}

/// Where a box fixed to DH frame `frame` by `placement` is in this pose.
fn box_in_world(
    frame: usize,
    placement: &IsometryMatrix3<f64>,
    frames: &ChainFrames<f64>,
) -> IsometryMatrix3<f64> {
    frames.frames[frame] * placement
}

/// A shape placed in the world for parry's distance query.
enum Placed {
    /// A capsule in world coordinates.
    Capsule(Capsule),
    /// A box and where it is.
    Box(Isometry3<f64>, Cuboid),
}

impl Placed {
    fn new(shape: &Shape, frames: &ChainFrames<f64>) -> Self {
        match shape {
            Shape::Capsule { from, to, radius_m } => Self::Capsule(Capsule::new(
                Point3::from(from.position(frames)),
                Point3::from(to.position(frames)),
                *radius_m,
            )),
            Shape::Box {
                frame,
                placement,
                half_extents_m,
            } => {
                let world = box_in_world(*frame, placement, frames);
                let pose = Isometry3::from_parts(
                    world.translation,
                    UnitQuaternion::from_rotation_matrix(&world.rotation),
                );
                Self::Box(pose, Cuboid::new(*half_extents_m))
            }
        }
    }

    /// Where the shape is and what it is, as parry takes them.
    fn parts(&self) -> (Isometry3<f64>, &dyn parry3d_f64::shape::Shape) {
        match self {
            Self::Capsule(c) => (Isometry3::identity(), c),
            Self::Box(pose, b) => (*pose, b),
        }
    }

    /// Distance between the surfaces, m (0 when they overlap).
    fn distance(&self, other: &Self) -> f64 {
        let ((pa, sa), (pb, sb)) = (self.parts(), other.parts());
        // Capsules and boxes are convex, which parry always handles; were a
        // pair ever unsupported, counting it as touching keeps the test safe.
        parry3d_f64::query::distance(&pa, sa, &pb, sb).unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Distance from a point to a box (centre pose and half sizes), by clamping in the box's frame.
    fn point_to_box(p: &Vector3<f64>, pose: &Isometry3<f64>, half: &Vector3<f64>) -> f64 {
        let local = pose.inverse_transform_point(&Point3::from(*p)).coords;
        let outside = local.abs() - half;
        outside.map(|x| x.max(0.0)).norm()
    }

    fn random_pose(rng: &mut ChaCha8Rng) -> Isometry3<f64> {
        let mut v = || {
            Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
        };
        let (t, axis) = (v() * 0.3, v());
        Isometry3::from_parts(
            t.into(),
            UnitQuaternion::from_rotation_matrix(&Rotation3::new(axis)),
        )
    }

    #[test]
    fn distances_to_boxes_match_a_sampled_surface() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let half = Vector3::new(0.1, 0.05, 0.02);
        for _ in 0..20 {
            let (box_pose, other_pose) = (random_pose(&mut rng), random_pose(&mut rng));
            let a = Placed::Box(box_pose, Cuboid::new(half));
            // A capsule: the nearest of many axis points, less the radius.
            let (p, q) = (
                other_pose * Point3::new(-0.1, 0.0, 0.0),
                other_pose * Point3::new(0.1, 0.0, 0.0),
            );
            let capsule = Placed::Capsule(Capsule::new(p, q, 0.01));
            let sampled = (0..=2000)
                .map(|k| {
                    point_to_box(
                        &(p.coords + (q - p) * (k as f64 / 2000.0)),
                        &box_pose,
                        &half,
                    )
                })
                .fold(f64::INFINITY, f64::min);
            let d = a.distance(&capsule);
            assert!(
                (d - (sampled - 0.01).max(0.0)).abs() < 1e-4,
                "{d} vs {sampled}"
            );
            // A second box: the nearest of its surface points on a fine grid.
            let b_half = Vector3::new(0.03, 0.04, 0.05);
            let b = Placed::Box(other_pose, Cuboid::new(b_half));
            let n = 40;
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=n {
                    for k in 0..=n {
                        let on_face = [i, j, k].iter().any(|&c| c == 0 || c == n);
                        if !on_face {
                            continue;
                        }
                        let f = |c: usize, h: f64| (2.0 * c as f64 / n as f64 - 1.0) * h;
                        let local = Point3::new(f(i, b_half.x), f(j, b_half.y), f(k, b_half.z));
                        sampled = sampled.min(point_to_box(
                            &(other_pose * local).coords,
                            &box_pose,
                            &half,
                        ));
                    }
                }
            }
            let d = a.distance(&b);
            // Grid steps are at most 2.5 mm: the sampled minimum is above the
            // true one by less than half a step's diagonal.
            assert!(
                d <= sampled + 1e-9 && d >= sampled - 2.5e-3,
                "{d} vs {sampled}"
            );
        }
    }
}
