//! A serial chain of a URDF robot description, from a base link to a tip
//! link, as standard Denavit–Hartenberg parameters with the masses of its
//! links: what `--arm robot.urdf --base-link L --tip-link L` reads.
//!
//! The result, [`DhChain`], is plain data of its own, independent of the
//! model's arm type: the caller converts it (and checks the joint count it
//! supports; this reader takes any number of moving joints from one up).
//!
//! # The conventions
//!
//! Lengths in m, angles in rad, masses in kg. Each DH link turns (or slides)
//! before its offsets, `T(i-1,i) = Rz(q_i + θ_i) Tz(d_i) Tx(a_i) Rx(α_i)` for a
//! revolute joint and `Rz(θ_i) Tz(q_i + d_i) Tx(a_i) Rx(α_i)` for a prismatic
//! one, and the chain is `base · T(0,1) ⋯ T(n-1,n) · tool`, with frames written
//! `Trans(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll)` ([`FrameXyzRpy`], the same
//! convention as URDF's `<origin>` and lrmcal's arm file). For every joint
//! vector q, this product equals the URDF's pose of the tip link's frame in
//! the base link's frame: `q_i` has the URDF's meaning (a turn by `q_i` about
//! the joint's `<axis>`, or a slide by `q_i` along it), so joint angles,
//! their signs and the limits carry over unchanged.
//!
//! - **Joints.** `revolute`, `continuous` and `prismatic` joints between the
//!   base and the tip are the chain's joints; `fixed` joints are folded into
//!   the transforms around them; `floating`, `planar` and `spherical` joints
//!   there are an error, and so is a chain joint that mimics another (it
//!   does not move on its own). An `<axis>` may be any non-zero vector
//!   (default `1 0 0`, as URDF has it); it is normalised, so a prismatic
//!   joint's `q` is a length along the unit axis.
//! - **Frames.** `z(i-1)` lies on joint i's axis, pointing along the URDF's
//!   axis. Frame 0's origin is the point of joint 1's axis nearest to the
//!   base link's origin, and its x axis the base link's x axis made normal to
//!   `z0` (its y axis when x lies within 0.06° of `z0`), so an arm whose first
//!   axis is the base link's z axis has a base frame without rotation. For `i < n`, `x_i`
//!   is `z(i-1) × z_i`, normalised: `α_i` lies in (0, π) and `a_i` is the
//!   signed distance between the axes (0 where they intersect). The last
//!   link is the identity at q = 0 (`θ_n = d_n = a_n = α_n = 0`): frame n is
//!   frame n-1 turned by `q_n` (slid by `q_n`), and [`DhChain::tool`] holds
//!   the rest, from there to the tip link's frame.
//! - **Parallel axes.** Where joint i+1's axis is parallel to joint i's, the
//!   common normal is not unique: the one through frame i-1's origin is taken,
//!   so `d_i = 0`, `α_i` is 0 or π and `a_i ≥ 0` is the distance between the
//!   axes; where they also coincide, `a_i = θ_i = 0`. Axes within
//!   [`PARALLEL_TOLERANCE_RAD`] of parallel count as parallel: URDFs write
//!   π/2 as `1.5708` and π as `3.14159` or `3.1416` (off by up to 7.4e-6
//!   rad), and the exact common normal of such nearly parallel axes lies
//!   kilometres away, which no calibration can use. The DH chain then turns
//!   joint i+1 about an axis that differs from the URDF's by that small angle
//!   ([`DhJoint::parallel_deviation`] says by how much); it is exact at q = 0
//!   and wherever the URDF's axes are exactly parallel.
//! - **Masses.** DH link i carries every URDF link that moves with joint i up
//!   to joint i+1: the chain link after joint i, the chain links after it
//!   through fixed joints, and every link hanging from those off the chain,
//!   through fixed joints or moving ones. Moving joints off the chain (a
//!   gripper's jaws, a second arm on the base) are taken as rigid at their
//!   zero position ([`DhChain::frozen_joints`] names them): their links'
//!   masses count where they are at q = 0. So link n carries all that hangs
//!   beyond joint n, including what lies beyond the tip link. What hangs
//!   from the base link besides the arm (the links up to joint 1, and any
//!   other branch) is [`DhChain::base_mass`]. Links above the base link are
//!   not counted. Centres of mass are given in DH
//!   frame i; inertia tensors are not read (lrmcal's model has none).
//! - **Limits.** A revolute or prismatic joint's `<limit lower upper>` are
//!   copied (rad or m); `continuous` joints have none, and so has a joint
//!   whose limits are equal (`urdf-rs` reads a missing `<limit>` of a URDF
//!   1.0 file as `0 0`, and CAD exporters write `0 0` for "none") or infinite
//!   (URDF 1.2 without them).
//! - **Rounding.** "Equals" is to rounding (below 1e-14 m in the tests).
//!   Values that are rounding of 0 are written as 0: DH lengths below
//!   1e-12 m (axes closer than that intersect or coincide), angles and the
//!   base's and tool's numbers below 1e-14.
//!
//! Errors are [`InputError`]s (with the file, [`Error::Parse`]) naming the
//! link or joint and what was expected, at the line of its element when
//! that can be found. Numbers that are not finite, negative masses, zero
//! axes and reversed limits are refused where they are used: on the chain,
//! and for masses and origins below the base link. `urdf-rs` reads a vector
//! attribute by its words that are numbers (`0 x 0 0` reads as `0 0 0`),
//! and ignores elements it does not know.

use std::path::Path;

use crate::error::{Error, InputError, Location, Problem};
use crate::io::read_text;

mod chain;
mod dh;
mod frames;
mod inertia;
#[cfg(test)]
mod tests;

/// Consecutive joint axes closer than this to parallel (or antiparallel)
/// are taken as parallel, rad. See the module's conventions.
pub const PARALLEL_TOLERANCE_RAD: f64 = 1e-5;

/// A rigid frame: `Trans(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameXyzRpy {
    /// Translation, m.
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw (about the fixed x, y, z axes), rad.
    pub rpy: [f64; 3],
}

/// How a chain joint moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Turns by `q` (rad) about `z(i-1)`: a URDF `revolute` or `continuous` joint.
    Revolute,
    /// Slides by `q` (m) along `z(i-1)`: a URDF `prismatic` joint.
    Prismatic,
}

/// One moving joint of the chain and the link it carries, standard DH.
#[derive(Clone, Debug, PartialEq)]
pub struct DhJoint {
    /// The URDF joint's name.
    pub name: String,
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// DH joint-angle offset about `z(i-1)`, rad.
    pub theta: f64,
    /// DH offset along `z(i-1)`, m.
    pub d: f64,
    /// DH length along `x_i`, m (signed).
    pub a: f64,
    /// DH twist about `x_i`, rad.
    pub alpha: f64,
    /// The URDF's `[lower, upper]` limits of `q` (rad, or m for a prismatic
    /// joint); `None` for a continuous joint or one without usable limits.
    pub limits: Option<[f64; 2]>,
    /// Mass of DH link i: all that moves with this joint up to the next, kg.
    pub mass: f64,
    /// Its centre of mass in DH frame i, m (zeros if it has no mass).
    pub com: [f64; 3],
    /// `Some(angle)` when the next joint's axis was taken as parallel to this
    /// one's (so `d_i = 0`): the angle by which the URDF's axes depart from
    /// exactly parallel, rad (below [`PARALLEL_TOLERANCE_RAD`]; rounding, as
    /// 1e-16, where the file has them exactly parallel).
    /// `None` when they are not parallel, and for the last joint.
    pub parallel_deviation: Option<f64>,
}

/// A URDF serial chain as standard DH: see the module's conventions.
#[derive(Clone, Debug, PartialEq)]
pub struct DhChain {
    /// The URDF's `<robot name>`.
    pub robot: String,
    /// The base link's frame → DH frame 0.
    pub base: FrameXyzRpy,
    /// The moving joints, base to tip.
    pub joints: Vec<DhJoint>,
    /// DH frame n → the tip link's frame.
    pub tool: FrameXyzRpy,
    /// Mass of what hangs from the base link besides the arm (the links up
    /// to joint 1, other branches), kg: lrmcal's model has no use for it.
    pub base_mass: f64,
    /// Their centre of mass in DH frame 0, m (zeros if they have no mass).
    pub base_com: [f64; 3],
    /// The moving joints off the chain hanging from the base link or a chain
    /// link, whose links' masses were counted as rigid at q = 0, in file order.
    pub frozen_joints: Vec<String>,
}

/// Reads the chain from `base_link` to `tip_link` of a URDF file.
pub fn read(path: &Path, base_link: &str, tip_link: &str) -> Result<DhChain, Error> {
    let text = read_text(path)?;
    parse(&text, base_link, tip_link).map_err(|e| e.in_file(path))
}

/// The base and tip links of `text`'s chain: as given, else the file's one
/// root link and the one link without children below the base (the error
/// lists the choices where there are several).
pub fn chain_ends(
    text: &str,
    base_link: Option<&str>,
    tip_link: Option<&str>,
) -> Result<(String, String), InputError> {
    let robot = urdf_rs::read_from_string(text).map_err(|e| {
        InputError::new(
            Location::default(),
            Problem::Syntax {
                message: format!("expected a URDF robot description: {e}"),
            },
        )
    })?;
    let source = Source { text };
    chain::Tree::new(&robot, &source)?.ends_or_defaults(base_link, tip_link)
}

/// Reads the chain from `base_link` to `tip_link` of a URDF's text.
pub fn parse(text: &str, base_link: &str, tip_link: &str) -> Result<DhChain, InputError> {
    let syntax =
        |message: String| InputError::new(Location::default(), Problem::Syntax { message });
    if text.contains("<xacro:") {
        return Err(syntax(
            "expected a URDF robot description, found a xacro file (it has <xacro:…> elements): \
             expand it first, e.g. `xacro robot.urdf.xacro > robot.urdf`"
                .to_owned(),
        ));
    }
    let robot = urdf_rs::read_from_string(text)
        .map_err(|e| syntax(format!("expected a URDF robot description: {e}")))?;
    let source = Source { text };
    let tree = chain::Tree::new(&robot, &source)?;
    let chain = tree.select(base_link, tip_link)?;
    let placed = tree.place(chain.base)?;
    let axes = chain.axes(&tree, &placed);
    let geometry = dh::convert(&axes, &placed.pose(chain.tip));
    let masses = inertia::masses(&tree, &chain, &placed, &geometry.frames)?;
    let joints = chain
        .moving
        .iter()
        .zip(&geometry.links)
        .zip(&masses.links)
        .map(|((moving, link), body)| DhJoint {
            name: tree.joint(moving.joint).name.clone(),
            kind: moving.kind,
            theta: link.theta,
            d: link.d,
            a: link.a,
            alpha: link.alpha,
            limits: moving.limits,
            mass: body.mass,
            com: body.com,
            parallel_deviation: link.parallel_deviation,
        })
        .collect();
    Ok(DhChain {
        robot: robot.name.clone(),
        base: geometry.base,
        joints,
        tool: geometry.tool,
        base_mass: masses.base.mass,
        base_com: masses.base.com,
        frozen_joints: masses.frozen,
    })
}

/// The URDF's text, to find the line of the element an error is about.
struct Source<'t> {
    text: &'t str,
}

impl Source<'_> {
    /// A problem with the link `name`, at its `<link>` element's line if found.
    fn link_error(&self, name: &str, message: String) -> InputError {
        self.error(self.line_of("link", name), message)
    }

    /// A problem with the joint `name`, at its `<joint>` element's line if found.
    fn joint_error(&self, name: &str, message: String) -> InputError {
        self.error(self.line_of("joint", name), message)
    }

    fn error(&self, line: Option<u64>, message: String) -> InputError {
        InputError::new(Location { line, field: None }, Problem::Invalid { message })
    }

    /// The 1-based line of the first `<tag name="name" …>` outside comments.
    /// A `<joint>` must also have a `type`: a transmission's `<joint name>`
    /// refers to a joint, it does not define one.
    fn line_of(&self, tag: &str, name: &str) -> Option<u64> {
        let text = self.text;
        let mut from = 0;
        while let Some(found) = text[from..].find('<') {
            let at = from + found;
            let rest = &text[at..];
            if rest.starts_with("<!--") {
                from = at + rest.find("-->")? + 3;
                continue;
            }
            from = at + 1;
            let Some(after) = rest[1..].strip_prefix(tag) else {
                continue;
            };
            if !after.starts_with(char::is_whitespace) {
                continue;
            }
            let attributes = &after[..after.find('>').unwrap_or(after.len())];
            if attribute(attributes, "name") == Some(name)
                && (tag != "joint" || attribute(attributes, "type").is_some())
            {
                return Some(text[..at].matches('\n').count() as u64 + 1);
            }
        }
        None
    }
}

/// The value of `key="…"` (or `'…'`) among an element's attributes.
fn attribute<'a>(attributes: &'a str, key: &str) -> Option<&'a str> {
    let mut rest = attributes;
    while let Some(found) = rest.find(key) {
        let before = rest[..found].chars().next_back();
        let after = rest[found + key.len()..].trim_start();
        rest = &rest[found + key.len()..];
        if !before.is_some_and(char::is_whitespace) {
            continue;
        }
        let Some(value) = after.strip_prefix('=').map(str::trim_start) else {
            continue;
        };
        let quote = value.chars().next()?;
        if quote != '"' && quote != '\'' {
            return None;
        }
        return value[1..].find(quote).map(|end| &value[1..1 + end]);
    }
    None
}
