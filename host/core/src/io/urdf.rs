//! URDF (the ROS robot description) of an arm's rigid geometry: what
//! `lrmcal export --urdf` writes for robot_state_publisher, RViz and MoveIt.
//!
//! The chain uses the ROS-Industrial names (REP 199): `base_link` (DH frame
//! 0, the root: the robot stands in its own base frame) with `base` beside
//! it → `link_1` … `link_6` (revolute joints named as in the arm file) →
//! `flange` → `tool0` → `tool_point` (the tool frame, whose origin is the
//! measured point), and optionally `payload`. With [`UrdfOptions::world`]
//! the root is `world`, the frame lrmcal measured in, with the base placed
//! in it.
//!
//! Each link carries its mass and centre of mass from the arm file, with the
//! inertia of a uniform sphere as thick as the link's bodies (lrmcal's model
//! needs no inertia tensors, so it has none to give), and the arm's
//! collision bodies as its visual and collision geometry: a capsule as a
//! cylinder with a sphere at each end, a box as a box, each on the link it
//! moves with (placed at the zero pose).
//!
//! Standard DH turns joint i before the link's own offsets,
//! `T(i-1,i) = Rz(q_i + θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`, while URDF turns a
//! joint after its fixed origin. So `link_i` is DH frame i-1 turned by `q_i`
//! about its z axis, `joint_1`'s origin is the identity, and `joint_{i+1}`'s
//! origin is the rest of DH link i, `Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`: exactly
//! `xyz = (a cos θ, a sin θ, d)`, `rpy = (α, 0, θ)`. A link with Hayati's twist
//! `β_i` (calibrated where two joint axes are parallel) turns by `Ry(β_i)`
//! after `Rx(α_i)`: the same `xyz`, and `rpy` that of `Rz(θ) Rx(α) Ry(β)`.
//! Link 6's rest leads to DH frame 6, where `flange` and `tool0` sit.
//!
//! Compliances, servo curves and play have no place in a URDF; the file's
//! header says so, and what that means on the board.

use std::path::Path;

use model::{Arm, Frame, PerJoint};
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};

use crate::collision::{BodySet, Shape};
use crate::error::Error;
use crate::io::atomic;

/// Radius of the sphere whose inertia a link with no body gets, m.
const DEFAULT_INERTIA_RADIUS_M: f64 = 0.02;

/// Radius of the sphere whose inertia the payload gets, m.
const PAYLOAD_INERTIA_RADIUS_M: f64 = 0.01;

/// What the file says besides the arm's geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct UrdfOptions {
    /// `<robot name>`.
    pub robot_name: String,
    /// Where the arm came from, one line each (source file, model option, calibration id).
    pub provenance: Vec<String>,
    /// Effort limit of every joint, N·m (lrmcal does not know it; URDF requires one).
    pub effort_nm: f64,
    /// Velocity limit of every joint, rad/s.
    pub velocity_rad_s: f64,
    /// The joints' names, base to tip (the arm file's).
    pub joint_names: Vec<String>,
    /// The arm's bodies, placed on it: the links' visual and collision
    /// geometry, and how thick each link is.
    pub bodies: Option<BodySet>,
    /// Root the tree at `world`, the frame lrmcal measured in, with the
    /// base placed in it; otherwise `base_link` is the root.
    pub world: bool,
    /// A payload at the tool, kg: a `payload` link at its centre of mass.
    pub payload_kg: Option<f64>,
}

/// Writes the URDF of `arm` to `path`, whole or not at all.
pub fn write(path: &Path, arm: &Arm<f64>, options: &UrdfOptions) -> Result<(), Error> {
    let text = render(arm, options);
    atomic::write(path, |w| w.write_all(text.as_bytes()))
}

/// The URDF text of `arm`'s rigid geometry. The joint limits must be ordered
/// (`lower < upper`) and every number finite, as the arm readers ensure.
pub fn render(arm: &Arm<f64>, options: &UrdfOptions) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?>\n");
    out += &header(options);
    out += &format!("<robot name=\"{}\">\n", attribute(&options.robot_name));
    let zero = arm
        .chain()
        .frames(&PerJoint::splat(arm.joints.len(), 0.0), 0.0);
    let geometry = Geometry::of(options.bodies.as_ref(), &zero);
    if options.world {
        out += "  <link name=\"world\"/>\n";
        out += &fixed_joint("world", "base_link", &origin_of_frame(&arm.base));
    }
    out += &link("base_link", None, &geometry.elements[0]);
    out += "  <link name=\"base\"/>\n";
    out += &fixed_joint("base_link", "base", &Origin::identity());
    let mut parent = String::from("base_link");
    // Joint 1 turns DH frame 0 itself; every later joint first carries the
    // rest of the link before it.
    let mut origin = Origin::identity();
    for (i, joint) in arm.joints.iter().enumerate() {
        let link_name = format!("link_{}", i + 1);
        // The centre of mass is given in DH frame i, which sits at the rest of
        // link i from this link's frame.
        let rest = Origin::dh_rest(joint.theta, joint.d, joint.a, joint.alpha, joint.beta);
        let com = rest.isometry() * Point3::from(joint.com);
        let mass = (joint.mass > 0.0).then(|| Inertial {
            mass_kg: joint.mass,
            com_m: com.coords.into(),
            radius_m: geometry.thickness_m[i + 1].unwrap_or(DEFAULT_INERTIA_RADIUS_M),
        });
        out += &link(&link_name, mass.as_ref(), &geometry.elements[i + 1]);
        // A prismatic joint slides along z before the rest of its link,
        // which commutes with the rest's turn `Rz(θ)`: the same origins.
        let kind = match joint.kind {
            model::JointKind::Revolute => "revolute",
            model::JointKind::Prismatic => "prismatic",
        };
        out += &format!(
            "  <joint name=\"{}\" type=\"{kind}\">\n    <parent link=\"{parent}\"/>\n    \
             <child link=\"{link_name}\"/>\n    {}\n    <axis xyz=\"0 0 1\"/>\n    \
             <limit lower=\"{}\" upper=\"{}\" effort=\"{}\" velocity=\"{}\"/>\n  </joint>\n",
            attribute(&options.joint_names[i]),
            origin.element(),
            number(joint.limits[0]),
            number(joint.limits[1]),
            number(options.effort_nm),
            number(options.velocity_rad_s),
        );
        origin = rest;
        parent = link_name;
    }
    // `origin` now holds link 6's rest: DH frame 6, turned so that x points
    // out of the flange (along z6) as REP 199 has it for `flange`.
    let dh6 = origin.rotation();
    let out_of_flange = Rotation3::from_euler_angles(0.0, -std::f64::consts::FRAC_PI_2, 0.0);
    let flange = Origin {
        xyz: origin.xyz,
        rpy: rpy(&(dh6 * out_of_flange)),
    };
    out += "  <link name=\"flange\"/>\n";
    out += &fixed_joint(&parent, "flange", &flange);
    out += "  <link name=\"tool0\"/>\n";
    let back_to_dh6 = Origin {
        xyz: [0.0; 3],
        rpy: [0.0, std::f64::consts::FRAC_PI_2, 0.0],
    };
    out += &fixed_joint("flange", "tool0", &back_to_dh6);
    out += "  <link name=\"tool_point\"/>\n";
    out += &fixed_joint("tool0", "tool_point", &origin_of_frame(&arm.tool));
    if let Some(kg) = options.payload_kg {
        let payload = Inertial {
            mass_kg: kg,
            com_m: [0.0; 3],
            radius_m: PAYLOAD_INERTIA_RADIUS_M,
        };
        out += &link("payload", Some(&payload), "");
        let at_com = Origin {
            xyz: arm.payload_com,
            rpy: [0.0; 3],
        };
        out += &fixed_joint("tool_point", "payload", &at_com);
    }
    out += "</robot>\n";
    out
}

/// The XML comment at the top: provenance, frames, joint convention and what
/// the file cannot hold.
fn header(options: &UrdfOptions) -> String {
    let mut text = format!(
        "Rigid geometry of an arm, written by `lrmcal export` (lrmcal {}).\n",
        env!("CARGO_PKG_VERSION")
    );
    for line in &options.provenance {
        text += line;
        text.push('\n');
    }
    text += &format!(
        "
Frames (ROS-Industrial names, REP 199):
  world       (with `export --world`) the frame lrmcal measured in; world-base_link places the base
  base_link   DH frame 0 of the arm, the root otherwise
  base        the same frame, as REP 199 names the controller's base
  link_i      DH frame i-1 turned by joint_i about its z axis
  flange      at DH frame 6, x along joint 6's axis (out of the flange)
  tool0       DH frame 6 itself: z along joint 6's axis, the all-zero tool
  tool_point  the arm's tool frame: its origin is the point lrmcal measures and predicts
Joint positions are lrmcal's commanded joint angles in radians (q1_deg..q6_deg of its
pose files, converted): position 0 is q = 0 (the DH theta offsets are in the origins),
so the same angles put tool_point where `lrmcal predict` puts the tool point of a
rigid arm without play whose servo curves are the nominal ones. Limits are the arm's;
effort ({} N m) and velocity ({} rad/s) are not calibrated, but chosen when exporting.

What URDF cannot hold, so this file leaves out:
  - the joint and base compliances: the arm's sag under gravity and payload
    (`lrmcal predict` with a load gives the sagging tool point);
  - the servo curves (commanded angle -> pulse width): a calibrated curve moves where
    each command really takes its joint;
  - the play in each joint's drive (backlash): a joint stands half of it short of or
    beyond its command, the way it arrived;
  - the links' inertia tensors: lrmcal's model needs masses and centres of mass,
    written here, but no inertias; each link gets a uniform sphere's, as thick as
    its collision bodies (Gazebo and dynamics need some; do not trust them).
Visual and collision geometry are the arm file's collision bodies (the skeleton of
capsules when it has none), as lrmcal plans with them.
On the board, `lrmcal compensation elastic` cancels the sag: the tool point then goes
where this file puts tool_point. With `compensation off` it sags below it; with
`compensation full` the arm follows its nominal arm: export that one instead.
",
        number(options.effort_nm),
        number(options.velocity_rad_s),
    );
    let body: String = text
        .lines()
        .map(|line| {
            if line.is_empty() {
                "\n".to_owned()
            } else {
                format!("  {}\n", comment(line))
            }
        })
        .collect();
    format!("<!--\n{body}-->\n")
}

/// A link's mass, centre of mass in its frame, m, and the radius of the
/// uniform sphere whose inertia it gets.
struct Inertial {
    mass_kg: f64,
    com_m: [f64; 3],
    radius_m: f64,
}

/// A `<link>` with its inertial, if any, and its geometry elements.
fn link(name: &str, inertial: Option<&Inertial>, geometry: &str) -> String {
    let mut body = String::new();
    if let Some(i) = inertial {
        let moment = 0.4 * i.mass_kg * i.radius_m * i.radius_m;
        body += &format!(
            "    <inertial>\n      <origin xyz=\"{}\" rpy=\"0 0 0\"/>\n      <mass value=\"{}\"/>\n      \
             <inertia ixx=\"{m}\" ixy=\"0\" ixz=\"0\" iyy=\"{m}\" iyz=\"0\" izz=\"{m}\"/>\n    </inertial>\n",
            i.com_m.map(number).join(" "),
            number(i.mass_kg),
            m = number(moment),
        );
    }
    body += geometry;
    if body.is_empty() {
        format!("  <link name=\"{name}\"/>\n")
    } else {
        format!("  <link name=\"{name}\">\n{body}  </link>\n")
    }
}

/// The arm's bodies as URDF geometry, per link (0: `base_link`, i: `link_i`).
struct Geometry {
    /// The `<visual>` and `<collision>` elements of each link.
    elements: Vec<String>,
    /// How thick each link's bodies are, m: the largest capsule radius or
    /// smallest box half-size; `None` for a link without a body.
    thickness_m: Vec<Option<f64>>,
}

impl Geometry {
    /// The elements of `bodies` (none without them), each on the link it
    /// moves with, placed with the arm's frames `zero` at the zero pose.
    fn of(bodies: Option<&BodySet>, zero: &model::ChainFrames<f64>) -> Self {
        let mut geometry = Self {
            elements: vec![String::new(); zero.frames.len()],
            thickness_m: vec![None; zero.frames.len()],
        };
        // Link i's frame at the zero pose: DH frame i-1 (turned by q_i = 0).
        let link_frame = |k: usize| zero.frames[k.saturating_sub(1)];
        for body in bodies.map(BodySet::bodies).unwrap_or_default() {
            let k = body.links[0];
            let to_link = link_frame(k).inverse();
            let at = |frame: usize, p: &Vector3<f64>| {
                (to_link * zero.frames[frame] * Point3::from(*p)).coords
            };
            for shape in &body.shapes {
                let pieces = match shape {
                    Shape::Capsule { from, to, radius_m } => capsule(
                        at(from.frame, &from.offset_m),
                        at(to.frame, &to.offset_m),
                        *radius_m,
                    ),
                    Shape::Box {
                        frame,
                        placement,
                        half_extents_m,
                    } => {
                        let place = to_link * zero.frames[*frame] * placement;
                        let size = (half_extents_m * 2.0).map(number);
                        let piece = (
                            Origin::of(&place),
                            format!("<box size=\"{}\"/>", size.as_slice().join(" ")),
                        );
                        vec![piece]
                    }
                };
                for (origin, shape) in pieces {
                    for element in ["visual", "collision"] {
                        geometry.elements[k] += &format!(
                            "    <{element}>\n      {}\n      <geometry>{shape}</geometry>\n    </{element}>\n",
                            origin.element()
                        );
                    }
                }
            }
            let thickness = body.thickness_m();
            let t = &mut geometry.thickness_m[k];
            *t = Some(t.map_or(thickness, |t| t.max(thickness)));
        }
        geometry
    }
}

/// A capsule from `a` to `b` (link frame, m) as a cylinder along it and a
/// sphere at each end: the origin and geometry of each piece.
fn capsule(a: Vector3<f64>, b: Vector3<f64>, radius_m: f64) -> Vec<(Origin, String)> {
    let sphere = |c: Vector3<f64>| {
        (
            Origin {
                xyz: c.into(),
                rpy: [0.0; 3],
            },
            format!("<sphere radius=\"{}\"/>", number(radius_m)),
        )
    };
    let axis = b - a;
    let length = axis.norm();
    if length < 1e-9 {
        return vec![sphere(a)];
    }
    // The cylinder's z axis along the capsule's.
    let turn = Rotation3::rotation_between(&Vector3::z(), &axis)
        .unwrap_or_else(|| Rotation3::from_euler_angles(std::f64::consts::PI, 0.0, 0.0));
    let middle = Origin {
        xyz: ((a + b) / 2.0).into(),
        rpy: rpy(&turn),
    };
    vec![
        (
            middle,
            format!(
                "<cylinder radius=\"{}\" length=\"{}\"/>",
                number(radius_m),
                number(length)
            ),
        ),
        sphere(a),
        sphere(b),
    ]
}

/// How far, rad, gravity in the root frame of the URDF (`world` when
/// `world`, else the base frame) is from its -z axis: ROS takes gravity
/// along -z, so a URDF whose root is tilted from it stands tilted.
pub fn gravity_off_down_rad(arm: &Arm<f64>, world: bool) -> f64 {
    let g = arm.gravity_vector();
    let g = if world {
        g
    } else {
        arm.base.isometry().rotation.inverse() * g
    };
    if g.norm() == 0.0 {
        return 0.0;
    }
    g.angle(&-Vector3::z())
}

/// A fixed joint `parent-child`.
fn fixed_joint(parent: &str, child: &str, origin: &Origin) -> String {
    format!(
        "  <joint name=\"{parent}-{child}\" type=\"fixed\">\n    <parent link=\"{parent}\"/>\n    \
         <child link=\"{child}\"/>\n    {}\n  </joint>\n",
        origin.element()
    )
}

/// A joint's `<origin>`: translation, m, then URDF's fixed-axis roll, pitch,
/// yaw, rad (`R = Rz(yaw) Ry(pitch) Rx(roll)`, the convention of [`Frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Origin {
    xyz: [f64; 3],
    rpy: [f64; 3],
}

impl Origin {
    fn identity() -> Self {
        Self {
            xyz: [0.0; 3],
            rpy: [0.0; 3],
        }
    }

    /// `Rz(θ) Tz(d) Tx(a) Rx(α) Ry(β)`: the part of a link after its joint's
    /// turn. A DH link (`β = 0`) has exactly `rpy = (α, 0, θ)`.
    fn dh_rest(theta: f64, d: f64, a: f64, alpha: f64, beta: f64) -> Self {
        let (s, c) = theta.sin_cos();
        let rpy = if beta == 0.0 {
            [alpha, 0.0, theta]
        } else {
            rpy(&(Rotation3::from_euler_angles(alpha, 0.0, theta)
                * Rotation3::from_euler_angles(0.0, beta, 0.0)))
        };
        Self {
            xyz: [a * c, a * s, d],
            rpy,
        }
    }

    /// The placement `iso` as an origin.
    fn of(iso: &IsometryMatrix3<f64>) -> Self {
        Self {
            xyz: iso.translation.vector.into(),
            rpy: rpy(&iso.rotation),
        }
    }

    fn isometry(&self) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(Translation3::from(Vector3::from(self.xyz)), self.rotation())
    }

    fn rotation(&self) -> Rotation3<f64> {
        let [roll, pitch, yaw] = self.rpy;
        Rotation3::from_euler_angles(roll, pitch, yaw)
    }

    fn element(&self) -> String {
        let v = |v: [f64; 3]| v.map(number).join(" ");
        format!("<origin xyz=\"{}\" rpy=\"{}\"/>", v(self.xyz), v(self.rpy))
    }
}

/// A [`Frame`] as an origin: both use `Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll)`.
fn origin_of_frame(frame: &Frame<f64>) -> Origin {
    Origin {
        xyz: frame.xyz,
        rpy: frame.rpy,
    }
}

/// Roll, pitch, yaw of `r` (`r = Rz(yaw) Ry(pitch) Rx(roll)`), accurate to
/// rounding for every rotation.
///
/// The textbook `pitch = -asin(r20)` loses half the digits near ±90° of pitch
/// (1e-8 rad, 1e-6 mm at the tool), which is where `flange` sits whenever
/// joint 6 has no twist. Here yaw comes from the first column, and roll and
/// pitch from `Rz(yaw)ᵀ r = Ry(pitch) Rx(roll)`, whose entries are all well
/// scaled; at exactly ±90° any yaw fits and the other two follow from it.
fn rpy(r: &Rotation3<f64>) -> [f64; 3] {
    let m: &Matrix3<f64> = r.matrix();
    let yaw = m[(1, 0)].atan2(m[(0, 0)]);
    let rest = Rotation3::from_euler_angles(0.0, 0.0, -yaw) * r;
    let p = rest.matrix();
    let pitch = (-p[(2, 0)]).atan2(p[(0, 0)]);
    let roll = (-p[(1, 2)]).atan2(p[(1, 1)]);
    [roll, pitch, yaw]
}

/// The shortest decimal that reads back as the same `f64` (at most 17
/// significant digits), so the file holds the very numbers of the arm; never
/// `-0` (adding 0 turns -0 into 0 and leaves every other number alone).
fn number(x: f64) -> String {
    format!("{:?}", x + 0.0)
}

/// `text` as an XML attribute value between double quotes.
fn attribute(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `text` made safe inside an XML comment, which may not contain `--` (a
/// file name may): every other dash of a run becomes a hyphen (U+2010),
/// which reads the same.
fn comment(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut after_dash = false;
    for c in text.chars() {
        if c == '-' && after_dash {
            out.push('\u{2010}');
            after_dash = false;
        } else {
            out.push(c);
            after_dash = c == '-';
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    fn assert_same_rotation(a: &Rotation3<f64>, b: &Rotation3<f64>) {
        let diff = (a.matrix() - b.matrix()).abs().max();
        assert!(diff < 1e-15, "{diff:e}: {a} vs {b}");
    }

    #[test]
    fn rpy_rebuilds_every_rotation_to_rounding() {
        let mut rng = StdRng::seed_from_u64(3);
        let half_pi = std::f64::consts::FRAC_PI_2;
        for _ in 0..2000 {
            let [roll, yaw] = [(); 2].map(|_| rng.random_range(-3.1..3.1));
            // Half of the pitches within 1e-3..1e-17 rad of ±90°, where asin fails.
            let pitch = if rng.random_bool(0.5) {
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                sign * (half_pi - 10f64.powf(rng.random_range(-17.0..-3.0)))
            } else {
                rng.random_range(-1.5..1.5)
            };
            let r = Rotation3::from_euler_angles(roll, pitch, yaw);
            let [r2, p2, y2] = rpy(&r);
            assert_same_rotation(&Rotation3::from_euler_angles(r2, p2, y2), &r);
        }
        // Exactly at ±90° (as rounding gives it) and the identity.
        for r in [
            Rotation3::from_euler_angles(0.0, -half_pi, 0.0),
            Rotation3::from_euler_angles(0.3, half_pi, -1.2),
            Rotation3::identity(),
        ] {
            let [r2, p2, y2] = rpy(&r);
            assert_same_rotation(&Rotation3::from_euler_angles(r2, p2, y2), &r);
        }
    }

    /// The options of a test export: no provenance, bodies or payload,
    /// effort 1 N·m and velocity 1.5 rad/s.
    fn test_options(
        robot_name: &str,
        joint_names: impl Iterator<Item = String>,
        world: bool,
    ) -> UrdfOptions {
        UrdfOptions {
            robot_name: robot_name.into(),
            provenance: Vec::new(),
            effort_nm: 1.0,
            velocity_rad_s: 1.5,
            joint_names: joint_names.collect(),
            bodies: None,
            world,
            payload_kg: None,
        }
    }

    #[test]
    fn dh_rest_is_the_dh_product() {
        let (theta, d, a, alpha) = (0.4, 0.07, -0.12, 1.1);
        let origin = Origin::dh_rest(theta, d, a, alpha, 0.0);
        assert_eq!(origin.rpy, [alpha, 0.0, theta]);
        let rz = Rotation3::from_euler_angles(0.0, 0.0, theta);
        let rx = Rotation3::from_euler_angles(alpha, 0.0, 0.0);
        let translation = rz * nalgebra::Vector3::new(a, 0.0, d);
        assert!((nalgebra::Vector3::from(origin.xyz) - translation).norm() < 1e-16);
        assert_same_rotation(&origin.rotation(), &(rz * rx));
        // With Hayati's twist, turned by Ry(beta) after Rx(alpha); alpha 0 and
        // pi as where twists are calibrated.
        for alpha in [0.0, std::f64::consts::PI, 1.1] {
            let beta = 1.7e-3;
            let origin = Origin::dh_rest(theta, d, a, alpha, beta);
            let ry = Rotation3::from_euler_angles(0.0, beta, 0.0);
            let rx = Rotation3::from_euler_angles(alpha, 0.0, 0.0);
            assert!((nalgebra::Vector3::from(origin.xyz) - translation).norm() < 1e-16);
            assert_same_rotation(&origin.rotation(), &(rz * rx * ry));
        }
    }

    /// The exported chain's forward kinematics (origins and joint turns read
    /// back from the text) against the model's, on an arm whose links 2 and
    /// 3 carry Hayati's twist: the twist must not be dropped.
    #[test]
    fn the_urdf_keeps_the_twist_of_parallel_axes() {
        let mut arm = model::testing::rigid_lrm_like_arm();
        arm.joints[1].beta = 1.7e-3;
        arm.joints[2].beta = -6.3e-4;
        let n = arm.joints.len();
        let options = test_options("twisted", (1..=n).map(|i| format!("joint_{i}")), true);
        let robot = urdf_rs::read_from_string(&render(&arm, &options)).unwrap();
        let origin = |child: &str| {
            let j = robot.joints.iter().find(|j| j.child.link == child).unwrap();
            Origin {
                xyz: j.origin.xyz.0,
                rpy: j.origin.rpy.0,
            }
            .isometry()
        };
        let mut rng = StdRng::seed_from_u64(7);
        for _ in 0..50 {
            let q: Vec<f64> = (0..n).map(|_| rng.random_range(-1.8..1.8)).collect();
            let mut pose = origin("base_link");
            for (i, qi) in q.iter().enumerate() {
                let turn = Rotation3::from_euler_angles(0.0, 0.0, *qi);
                let turn = IsometryMatrix3::from_parts(Translation3::identity(), turn);
                pose = pose * origin(&format!("link_{}", i + 1)) * turn;
            }
            pose = pose * origin("flange") * origin("tool0") * origin("tool_point");
            let model_tool = arm.chain().frames(&q, 0.0).tool_point();
            let miss = (pose.translation.vector - model_tool).norm();
            assert!(miss < 1e-12, "tool point {miss:e} m from the model's");
        }
    }

    /// An arm with a lift and Hayati's twists, exported and read back by
    /// the URDF chain reader, puts its tool point where the model does.
    #[test]
    fn a_lift_and_twists_read_back_as_the_same_chain() {
        use model::testing::{LIFT_ARM_JOINTS, lift_arm, random_lift_q};
        let arm = lift_arm::<f64>();
        let options = test_options("lift", (0..LIFT_ARM_JOINTS).map(|i| format!("j{i}")), false);
        let text = render(&arm, &options);
        let read =
            crate::io::arm_urdf::parse(&text, Some("base_link"), Some("tool_point")).unwrap();
        assert_eq!(read.arm.joints[0].kind, model::JointKind::Prismatic);
        let (ours, theirs) = (arm.chain(), read.arm.chain());
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(9);
        for _ in 0..50 {
            let q: [f64; LIFT_ARM_JOINTS] = random_lift_q(&mut rng);
            let d = ours.rigid_tool_point(&q) - theirs.rigid_tool_point(&q);
            assert!(d.norm() < 1e-12, "{q:?}: {d}");
        }
    }

    #[test]
    fn numbers_read_back_exactly() {
        for x in [
            0.09,
            std::f64::consts::FRAC_PI_2,
            -1e-17,
            1.0 / 3.0,
            123456.789,
            0.0,
        ] {
            assert_eq!(number(x).parse::<f64>(), Ok(x));
        }
        assert_eq!(number(-0.0), "0.0");
    }

    #[test]
    fn names_and_comments_cannot_break_the_xml() {
        assert_eq!(attribute("a<b>&\"c\""), "a&lt;b&gt;&amp;&quot;c&quot;");
        assert_eq!(
            comment("cal--old---x.json"),
            "cal-\u{2010}old-\u{2010}-x.json"
        );
        assert!(!comment("a-- --b-----").contains("--"));
        let options = UrdfOptions {
            provenance: vec!["calibration `cal--v2.json`-".into()],
            ..test_options(
                "arm \"<2>\" & co",
                (0..6).map(|i| format!("j{i} <&>")),
                true,
            )
        };
        let text = render(
            &crate::io::arm_source::bundled("lrm").unwrap().arm,
            &options,
        );
        let robot = urdf_rs::read_from_string(&text).unwrap();
        assert_eq!(robot.name, options.robot_name);
        let header = &text[text.find("<!--").unwrap() + 4..text.find("-->").unwrap()];
        assert!(!header.contains("--"), "{header}");
        assert!(header.contains("cal-\u{2010}v2.json"), "{header}");
    }
}
