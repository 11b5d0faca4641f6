//! The collision description as the arm file gives it (`[collision]` and
//! `[[body]]`): bodies named by the frames they hang on, before they are
//! placed on an arm. [`super::BodySet::for_arm`] turns it into bodies.

use std::fmt;
use std::str::FromStr;

use model::MAX_JOINTS;

/// A frame of the arm a body is fixed to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameRef {
    /// DH frame `i`: 0 is the base frame (`base` or `j0`), n the flange (`jn`).
    Dh(usize),
    /// The tool frame (`tool`): frame n moved by the arm's `[tool]` offset.
    Tool,
}

impl FrameRef {
    /// The DH frame the reference moves with on an arm of `joints` joints
    /// (the tool frame moves with the last frame).
    pub fn dh_index(self, joints: usize) -> usize {
        match self {
            Self::Dh(i) => i,
            Self::Tool => joints,
        }
    }
}

impl FromStr for FrameRef {
    type Err = String;

    /// `base`, `j0` … `j10` or `tool` (whether the arm has the frame is
    /// checked where the body is placed on it).
    fn from_str(name: &str) -> Result<Self, String> {
        let dh = |digits: &str| digits.parse::<usize>().ok().filter(|&i| i <= MAX_JOINTS);
        match name {
            "base" => Ok(Self::Dh(0)),
            "tool" => Ok(Self::Tool),
            _ => name
                .strip_prefix('j')
                .and_then(dh)
                .map(Self::Dh)
                .ok_or_else(|| {
                    format!(
                        "expected a frame name (base, j0 … j{MAX_JOINTS} or tool), found `{name}`"
                    )
                }),
        }
    }
}

impl fmt::Display for FrameRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Dh(0) => f.write_str("base"),
            Self::Dh(i) => write!(f, "j{i}"),
            Self::Tool => f.write_str("tool"),
        }
    }
}

/// A point fixed to a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSpec {
    /// The frame.
    pub frame: FrameRef,
    /// The point in that frame, m (zero: the frame's origin).
    pub xyz_m: [f64; 3],
}

impl PointSpec {
    /// A frame's origin.
    pub fn origin(frame: FrameRef) -> Self {
        Self {
            frame,
            xyz_m: [0.0; 3],
        }
    }

    /// The links the point is fixed to, as an inclusive range of link
    /// numbers (link `i` is moved by joint `i`, link 0 is the base).
    ///
    /// A point of DH frame `i` moves with link `i`; if it lies on the frame's
    /// z axis it lies on joint `i + 1`'s axis, which that joint turns about,
    /// so it moves with link `i + 1` as well.
    /// On an arm of `joints` joints.
    pub fn links(&self, joints: usize) -> [usize; 2] {
        let i = self.frame.dh_index(joints);
        let on_axis = self.frame != FrameRef::Tool && self.xyz_m[0] == 0.0 && self.xyz_m[1] == 0.0;
        if on_axis && i < joints {
            [i, i + 1]
        } else {
            [i, i]
        }
    }
}

/// The shape of a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShapeSpec {
    /// The points within `radius_m` of the segment `from`–`to`.
    Capsule {
        /// One end of the axis.
        from: PointSpec,
        /// The other end.
        to: PointSpec,
        /// Radius around the axis, m.
        radius_m: f64,
    },
    /// A box whose edges run along the axes of `frame`.
    Box {
        /// The frame the box is fixed to.
        frame: FrameRef,
        /// The corner with the smallest coordinates, m.
        min_m: [f64; 3],
        /// The corner with the largest coordinates, m.
        max_m: [f64; 3],
    },
}

/// One body as the arm file describes it (`[[body]]`).
#[derive(Clone, Debug, PartialEq)]
pub struct BodySpec {
    /// Name used in reports and in `ignore`.
    pub name: String,
    /// Its shape.
    pub shape: ShapeSpec,
    /// Whether the floor test applies; `None`: unless the body moves only
    /// with the base or joint 1 (on a level base its height never changes).
    pub floor: Option<bool>,
}

/// Where the floor is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Floor {
    /// The plane `z = z_m` of the world frame, which points up.
    At {
        /// Height, m.
        z_m: f64,
    },
    /// No floor test (an arm mounted at a table edge or on a wall).
    Off,
}

impl Floor {
    /// The floor's height, `None` without a floor.
    pub fn z_m(self) -> Option<f64> {
        match self {
            Self::At { z_m } => Some(z_m),
            Self::Off => None,
        }
    }
}

impl Default for Floor {
    /// The world's `z = 0` plane: the base stands on it when it sits at the origin.
    fn default() -> Self {
        Self::At { z_m: 0.0 }
    }
}

/// The arm file's collision description: `[collision]` and the `[[body]]` tables.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CollisionSpec {
    /// Smallest gap between two bodies or a body and the floor, m; `None`:
    /// [`super::DEFAULT_CLEARANCE_M`].
    pub clearance_m: Option<f64>,
    /// The floor.
    pub floor: Floor,
    /// Radius of the capsules of the skeleton used when `bodies` is empty;
    /// `None`: [`super::SKELETON_RADIUS_PER_LENGTH`] of the arm's length.
    pub skeleton_radius_m: Option<f64>,
    /// The bodies; empty: the skeleton (see [`super::BodySet::skeleton`]).
    pub bodies: Vec<BodySpec>,
    /// Pairs of body names never tested against each other, besides those
    /// that always touch.
    pub ignore: Vec<[String; 2]>,
}

/// Which part of a [`CollisionSpec`] is wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecPlace {
    /// A key of body `index` (0-based), e.g. `capsule.radius`.
    Body {
        /// Position in [`CollisionSpec::bodies`].
        index: usize,
        /// The key within the body.
        key: &'static str,
    },
    /// A key of `[collision]`, e.g. `clearance`.
    Collision {
        /// The key.
        key: &'static str,
    },
    /// Pair `index` (0-based) of `ignore`.
    Ignore {
        /// Position in [`CollisionSpec::ignore`].
        index: usize,
    },
}

impl fmt::Display for SpecPlace {
    /// The key path as in the arm file, positions counted from 1: `body[2].capsule.radius`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Body { index, key } => write!(f, "body[{}].{key}", index + 1),
            Self::Collision { key } => write!(f, "collision.{key}"),
            Self::Ignore { index } => write!(f, "collision.ignore[{}]", index + 1),
        }
    }
}

/// A collision description that cannot be used, and where.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{place}`: {message}")]
pub struct SpecError {
    /// The key.
    pub place: SpecPlace,
    /// What is wrong and what was expected.
    pub message: String,
}

impl SpecError {
    pub(super) fn new(place: SpecPlace, message: impl Into<String>) -> Self {
        Self {
            place,
            message: message.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_names_round_trip_and_bad_ones_are_named() {
        for name in ["base", "j1", "j6", "tool"] {
            assert_eq!(name.parse::<FrameRef>().unwrap().to_string(), name);
        }
        assert_eq!("j0".parse::<FrameRef>(), Ok(FrameRef::Dh(0)));
        for bad in ["j11", "J1", "flange", "j", "j-1"] {
            let e = bad.parse::<FrameRef>().unwrap_err();
            assert!(e.contains(bad) && e.contains("j0 … j10"), "{e}");
        }
    }

    #[test]
    fn points_on_a_frames_z_axis_move_with_two_links() {
        let p = |frame, xyz_m| PointSpec { frame, xyz_m };
        assert_eq!(PointSpec::origin(FrameRef::Dh(0)).links(6), [0, 1]);
        assert_eq!(p(FrameRef::Dh(2), [0.0, 0.0, 0.1]).links(6), [2, 3]);
        assert_eq!(p(FrameRef::Dh(2), [0.01, 0.0, 0.1]).links(6), [2, 2]);
        assert_eq!(PointSpec::origin(FrameRef::Dh(6)).links(6), [6, 6]);
        assert_eq!(PointSpec::origin(FrameRef::Tool).links(6), [6, 6]);
    }
}
