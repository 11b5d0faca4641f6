//! The URDF's tree of links and joints, checked, and the serial chain from
//! the base link to the tip link within it.

use std::collections::{HashMap, HashSet};

use nalgebra::Vector3;
use urdf_rs::{Joint, JointType, Link, Robot};

use super::dh::AxisLine;
use super::frames::{self, Pose};
use super::{JointKind, Source};
use crate::error::InputError;

/// The links and joints of a URDF, indexed, each link with at most one parent.
pub(super) struct Tree<'a> {
    robot: &'a Robot,
    source: &'a Source<'a>,
    /// Link name -> index in `robot.links`.
    links: HashMap<&'a str, usize>,
    /// For each link, the joint whose child it is.
    parent: Vec<Option<usize>>,
    /// For each link, the joints whose parent it is, in file order.
    children: Vec<Vec<usize>>,
    /// For each joint, its parent and child links.
    ends: Vec<(usize, usize)>,
}

/// The joints from the base link to the tip link.
pub(super) struct Chain {
    /// The base link.
    pub base: usize,
    /// The tip link.
    pub tip: usize,
    /// The moving joints, base to tip (at least one).
    pub moving: Vec<Moving>,
}

/// A moving joint of the chain.
pub(super) struct Moving {
    /// Index in the URDF's joints.
    pub joint: usize,
    /// Revolute (and continuous) or prismatic.
    pub kind: JointKind,
    /// The limits of `q`, if it has usable ones.
    pub limits: Option<[f64; 2]>,
    /// The unit axis in the joint's frame.
    pub axis: Vector3<f64>,
}

/// Where every link below the base link lies at q = 0, every joint off the
/// chain at 0 too.
pub(super) struct Placed {
    /// For each link, its frame in the base link's frame; `None` for links
    /// not below the base link.
    poses: Vec<Option<Pose>>,
    /// The links below the base link (and itself, first), each after its parent.
    pub order: Vec<usize>,
}

impl Placed {
    /// The frame of a link below the base link, in the base link's frame.
    pub fn pose(&self, link: usize) -> Pose {
        self.poses[link].expect("only links below the base link are asked for")
    }
}

impl<'a> Tree<'a> {
    /// Indexes the robot's links and joints, refusing repeated names, joints
    /// between links that do not exist and links with two parents.
    pub fn new(robot: &'a Robot, source: &'a Source<'a>) -> Result<Self, InputError> {
        let mut links = HashMap::new();
        for (i, link) in robot.links.iter().enumerate() {
            if links.insert(link.name.as_str(), i).is_some() {
                return Err(source.link_error(
                    &link.name,
                    format!(
                        "link `{}` is defined twice; expected each link name once",
                        link.name
                    ),
                ));
            }
        }
        let mut joint_names = HashSet::new();
        let mut parent = vec![None; robot.links.len()];
        let mut children = vec![Vec::new(); robot.links.len()];
        let mut ends = Vec::with_capacity(robot.joints.len());
        for (j, joint) in robot.joints.iter().enumerate() {
            if !joint_names.insert(joint.name.as_str()) {
                return Err(source.joint_error(
                    &joint.name,
                    format!(
                        "joint `{}` is defined twice; expected each joint name once",
                        joint.name
                    ),
                ));
            }
            let end = |role: &str, name: &str| {
                links.get(name).copied().ok_or_else(|| {
                    source.joint_error(
                        &joint.name,
                        format!(
                            "joint `{}` has the {role} link `{name}`, which the file does not define",
                            joint.name
                        ),
                    )
                })
            };
            let (from, to) = (
                end("parent", &joint.parent.link)?,
                end("child", &joint.child.link)?,
            );
            if let Some(other) = parent[to] {
                let other: &Joint = &robot.joints[other];
                return Err(source.joint_error(
                    &joint.name,
                    format!(
                        "link `{}` is the child of both joint `{}` and joint `{}`; expected one parent per link",
                        joint.child.link, other.name, joint.name
                    ),
                ));
            }
            parent[to] = Some(j);
            children[from].push(j);
            ends.push((from, to));
        }
        Ok(Self {
            robot,
            source,
            links,
            parent,
            children,
            ends,
        })
    }

    /// A URDF joint.
    pub fn joint(&self, joint: usize) -> &'a Joint {
        &self.robot.joints[joint]
    }

    /// A URDF link.
    pub fn link(&self, link: usize) -> &'a Link {
        &self.robot.links[link]
    }

    /// The source text's error about a link.
    pub fn link_error(&self, link: usize, message: String) -> InputError {
        self.source.link_error(&self.link(link).name, message)
    }

    /// A joint's parent and child links.
    pub fn ends(&self, joint: usize) -> (usize, usize) {
        self.ends[joint]
    }

    /// The joint whose child `link` is, if any.
    pub fn parent_joint(&self, link: usize) -> Option<usize> {
        self.parent[link]
    }

    /// The base and tip links of the chain when the user names them or not:
    /// the base defaults to the file's one root link, the tip to the one
    /// link below the base that has no children. Where there are several,
    /// the error lists them.
    pub fn ends_or_defaults(
        &self,
        base: Option<&str>,
        tip: Option<&str>,
    ) -> Result<(String, String), InputError> {
        let name = |link: usize| self.link(link).name.clone();
        let list = |links: &[usize]| {
            links
                .iter()
                .map(|&l| format!("`{}`", self.link(l).name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let base = match base {
            Some(b) => self.find_link(b, "base")?,
            None => {
                let roots: Vec<usize> = (0..self.robot.links.len())
                    .filter(|&l| self.parent[l].is_none())
                    .collect();
                match roots[..] {
                    [root] => root,
                    _ => {
                        return Err(self.source.error(
                            None,
                            format!(
                                "expected one root link to start the chain at, found {} ({}): \
                                 name the base link (--base-link)",
                                roots.len(),
                                list(&roots)
                            ),
                        ));
                    }
                }
            }
        };
        if let Some(t) = tip {
            return Ok((name(base), name(self.find_link(t, "tip")?)));
        }
        let mut leaves = Vec::new();
        let mut stack = vec![base];
        while let Some(link) = stack.pop() {
            if self.children[link].is_empty() {
                leaves.push(link);
            }
            stack.extend(self.children[link].iter().map(|&j| self.ends[j].1));
            if leaves.len() + stack.len() > self.robot.links.len() {
                break;
            }
        }
        leaves.sort_unstable();
        match leaves[..] {
            [leaf] if leaf != base => Ok((name(base), name(leaf))),
            _ => Err(self.source.error(
                None,
                format!(
                    "expected one chain below the base link `{}`, found the ends {}: name the \
                     tip link, the one whose origin is the measured point's frame (--tip-link)",
                    name(base),
                    list(&leaves)
                ),
            )),
        }
    }

    /// The chain from `base` down to `tip`, its joints checked.
    pub fn select(&self, base: &str, tip: &str) -> Result<Chain, InputError> {
        let base_index = self.find_link(base, "base")?;
        let tip_index = self.find_link(tip, "tip")?;
        if base_index == tip_index {
            return Err(self.source.link_error(
                base,
                format!(
                    "the base and tip links are both `{base}`; expected a tip link below the base link"
                ),
            ));
        }
        let Some(up) = self.path_up(tip_index, base_index)? else {
            return Err(self.not_below(base, base_index, tip, tip_index));
        };
        let mut moving = Vec::new();
        for &j in up.iter().rev() {
            if let Some(m) = self.moving(j, base, tip)? {
                moving.push(m);
            }
        }
        if moving.is_empty() {
            return Err(self.source.link_error(
                tip,
                format!(
                    "the joints from link `{base}` to link `{tip}` are all fixed; expected at least one revolute, continuous or prismatic joint"
                ),
            ));
        }
        Ok(Chain {
            base: base_index,
            tip: tip_index,
            moving,
        })
    }

    /// The link named `name`, or an error naming the closest names there are.
    fn find_link(&self, name: &str, role: &str) -> Result<usize, InputError> {
        if let Some(&link) = self.links.get(name) {
            return Ok(link);
        }
        let count = self.robot.links.len();
        let message = if count == 0 {
            format!("no link named `{name}` for the {role} link: the file defines no <link>")
        } else {
            let mut names: Vec<&str> = self.robot.links.iter().map(|l| l.name.as_str()).collect();
            names.sort_by(|a, b| {
                let score = |n: &str| strsim::normalized_damerau_levenshtein(n, name);
                score(b).total_cmp(&score(a)).then(a.cmp(b))
            });
            let closest: Vec<String> = names.iter().take(3).map(|n| format!("`{n}`")).collect();
            format!(
                "no link named `{name}` for the {role} link; the closest of the file's {count} links: {}",
                closest.join(", ")
            )
        };
        Err(self.source.error(None, message))
    }

    /// The joints from `from` up to `to` (tip first), or `None` if `to` is not above `from`.
    fn path_up(&self, from: usize, to: usize) -> Result<Option<Vec<usize>>, InputError> {
        let mut joints = Vec::new();
        let mut link = from;
        while link != to {
            let Some(j) = self.parent[link] else {
                return Ok(None);
            };
            if joints.len() == self.robot.joints.len() {
                return Err(self.source.joint_error(
                    &self.robot.joints[j].name,
                    format!(
                        "joint `{}` is on a loop of links; expected a tree",
                        self.robot.joints[j].name
                    ),
                ));
            }
            joints.push(j);
            link = self.ends[j].0;
        }
        Ok(Some(joints))
    }

    /// The error for a tip link that is not below the base link.
    fn not_below(&self, base: &str, base_index: usize, tip: &str, tip_index: usize) -> InputError {
        let mut path = vec![format!("`{tip}`")];
        let mut link = tip_index;
        while let Some(j) = self.parent[link] {
            link = self.ends[j].0;
            if path.len() > self.robot.joints.len() {
                break;
            }
            path.push(format!("`{}`", self.link(link).name));
        }
        let swapped = match self.path_up(base_index, tip_index) {
            Ok(Some(_)) => format!(" (`{base}` is below `{tip}`: are the two swapped?)"),
            _ => String::new(),
        };
        self.source.link_error(
            tip,
            format!(
                "link `{tip}` is not below the base link `{base}`: its parents up to the root are {}{swapped}",
                path.join(" ← ")
            ),
        )
    }

    /// A chain joint checked: `None` if fixed, its kind, limits and axis if moving.
    fn moving(&self, j: usize, base: &str, tip: &str) -> Result<Option<Moving>, InputError> {
        let joint = &self.robot.joints[j];
        let fail = |message: String| Err(self.source.joint_error(&joint.name, message));
        let kind = match joint.joint_type {
            JointType::Fixed => return Ok(None),
            JointType::Revolute | JointType::Continuous => JointKind::Revolute,
            JointType::Prismatic => JointKind::Prismatic,
            JointType::Floating | JointType::Planar | JointType::Spherical => {
                let found = format!("{:?}", joint.joint_type).to_lowercase();
                return fail(format!(
                    "joint `{}` between links `{base}` and `{tip}` is {found}; expected revolute, continuous, prismatic or fixed joints on the chain",
                    joint.name
                ));
            }
        };
        if let Some(mimic) = &joint.mimic {
            return fail(format!(
                "joint `{}` between links `{base}` and `{tip}` mimics joint `{}`; expected chain joints that move on their own",
                joint.name, mimic.joint
            ));
        }
        let axis = Vector3::from(joint.axis.xyz.0);
        let norm = axis.norm();
        if !norm.is_finite() || norm == 0.0 {
            let [x, y, z] = joint.axis.xyz.0;
            return fail(format!(
                "joint `{}`: expected a finite, non-zero <axis xyz>, found `{x} {y} {z}`",
                joint.name
            ));
        }
        let limits = if joint.joint_type == JointType::Continuous {
            None
        } else {
            let (lower, upper) = (joint.limit.lower, joint.limit.upper);
            if lower.is_nan() || upper.is_nan() || lower > upper {
                return fail(format!(
                    "joint `{}`: expected <limit lower=… upper=…> with lower ≤ upper, found lower {lower}, upper {upper}",
                    joint.name
                ));
            }
            (lower < upper && lower.is_finite() && upper.is_finite()).then_some([lower, upper])
        };
        Ok(Some(Moving {
            joint: j,
            kind,
            limits,
            axis: axis / norm,
        }))
    }

    /// Every link below `base` placed at q = 0, each joint's origin checked.
    pub fn place(&self, base: usize) -> Result<Placed, InputError> {
        let mut poses = vec![None; self.robot.links.len()];
        poses[base] = Some(Pose::identity());
        let mut order = vec![base];
        let mut next = 0;
        while let Some(&link) = order.get(next) {
            next += 1;
            let at = poses[link].expect("a link is queued once placed");
            for &j in &self.children[link] {
                let joint = &self.robot.joints[j];
                let child = self.ends[j].1;
                if poses[child].is_some() {
                    return Err(self.source.joint_error(
                        &joint.name,
                        format!(
                            "joint `{}` leads back to link `{}`, on a loop of links; expected a tree",
                            joint.name, joint.child.link
                        ),
                    ));
                }
                let (xyz, rpy) = (joint.origin.xyz.0, joint.origin.rpy.0);
                if xyz.iter().chain(&rpy).any(|v| !v.is_finite()) {
                    return Err(self.source.joint_error(
                        &joint.name,
                        format!(
                            "joint `{}`: expected finite numbers in <origin xyz rpy>, found xyz `{} {} {}`, rpy `{} {} {}`",
                            joint.name, xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
                        ),
                    ));
                }
                poses[child] = Some(at * frames::pose(xyz, rpy));
                order.push(child);
            }
        }
        Ok(Placed { poses, order })
    }
}

impl Chain {
    /// Each moving joint's axis at q = 0 in the base link's frame.
    pub fn axes(&self, tree: &Tree<'_>, placed: &Placed) -> Vec<AxisLine> {
        self.moving
            .iter()
            .map(|m| {
                // At q = 0 the joint's child link lies at the joint's frame.
                let frame = placed.pose(tree.ends[m.joint].1);
                AxisLine {
                    point: frame.translation.vector,
                    direction: frame.rotation * m.axis,
                }
            })
            .collect()
    }
}
