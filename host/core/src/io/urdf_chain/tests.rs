//! The DH chain against the URDF, each side's forward kinematics written
//! here from scratch: the URDF's from its origins and axes (Rodrigues), the
//! chain's from the DH convention, neither through the reader's code.

use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Matrix3, Matrix4, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

type M4 = Matrix4<f64>;

// ---- Rigid motions, written out ----

fn rot_x(t: f64) -> Matrix3<f64> {
    let (s, c) = t.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

fn rot_y(t: f64) -> Matrix3<f64> {
    let (s, c) = t.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

fn rot_z(t: f64) -> Matrix3<f64> {
    let (s, c) = t.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// A turn by `angle` about the unit `axis`: `I + sin K + (1 − cos) K²`.
fn rodrigues(axis: Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let k = axis.cross_matrix();
    Matrix3::identity() + k * angle.sin() + k * k * (1.0 - angle.cos())
}

fn homogeneous(r: Matrix3<f64>, p: [f64; 3]) -> M4 {
    let mut m = M4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    m[(0, 3)] = p[0];
    m[(1, 3)] = p[1];
    m[(2, 3)] = p[2];
    m
}

/// `Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll)`.
fn xyz_rpy(xyz: [f64; 3], [roll, pitch, yaw]: [f64; 3]) -> M4 {
    homogeneous(rot_z(yaw) * rot_y(pitch) * rot_x(roll), xyz)
}

fn point(m: &M4, p: [f64; 3]) -> Vector3<f64> {
    (m * nalgebra::Vector4::new(p[0], p[1], p[2], 1.0)).xyz()
}

fn max_abs(m: &M4) -> f64 {
    m.iter().fold(0.0, |acc, v| acc.max(v.abs()))
}

// ---- The URDF's forward kinematics ----

/// The frame of `link` in `base`'s frame with each joint at `q[name]` (0 for
/// joints not in `q`): the product of the joints' origins and motions.
fn urdf_pose(robot: &urdf_rs::Robot, base: &str, link: &str, q: &HashMap<String, f64>) -> M4 {
    let mut pose = M4::identity();
    let mut at = link.to_owned();
    while at != base {
        let joint = robot
            .joints
            .iter()
            .find(|j| j.child.link == at)
            .unwrap_or_else(|| panic!("link `{at}` has no parent on the way to `{base}`"));
        let value = q.get(&joint.name).copied().unwrap_or(0.0);
        let axis = Vector3::from(joint.axis.xyz.0);
        let motion = match joint.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                homogeneous(rodrigues(axis.normalize(), value), [0.0; 3])
            }
            urdf_rs::JointType::Prismatic => {
                homogeneous(Matrix3::identity(), (axis.normalize() * value).into())
            }
            urdf_rs::JointType::Fixed => M4::identity(),
            ref other => panic!("no motion for {other:?}"),
        };
        pose = xyz_rpy(joint.origin.xyz.0, joint.origin.rpy.0) * motion * pose;
        at = joint.parent.link.clone();
    }
    pose
}

/// Whether `link` is `ancestor` or below it.
fn is_below(robot: &urdf_rs::Robot, link: &str, ancestor: &str) -> bool {
    let mut at = link.to_owned();
    loop {
        if at == ancestor {
            return true;
        }
        match robot.joints.iter().find(|j| j.child.link == at) {
            Some(j) => at = j.parent.link.clone(),
            None => return false,
        }
    }
}

// ---- The DH chain's forward kinematics ----

fn frame(f: &FrameXyzRpy) -> M4 {
    xyz_rpy(f.xyz, f.rpy)
}

/// DH frames 0..=n in the base link's frame at `q`.
fn dh_frames(chain: &DhChain, q: &[f64]) -> Vec<M4> {
    assert_eq!(q.len(), chain.joints.len());
    let mut t = frame(&chain.base);
    let mut frames = vec![t];
    for (j, &qi) in chain.joints.iter().zip(q) {
        let (angle, offset) = match j.kind {
            JointKind::Revolute => (qi + j.theta, j.d),
            JointKind::Prismatic => (j.theta, qi + j.d),
        };
        t = t
            * homogeneous(rot_z(angle), [0.0; 3])
            * homogeneous(Matrix3::identity(), [0.0, 0.0, offset])
            * homogeneous(Matrix3::identity(), [j.a, 0.0, 0.0])
            * homogeneous(rot_x(j.alpha), [0.0; 3]);
        frames.push(t);
    }
    frames
}

fn dh_tip(chain: &DhChain, q: &[f64]) -> M4 {
    dh_frames(chain, q).last().unwrap() * frame(&chain.tool)
}

// ---- Checks ----

/// A random q: revolute joints in [−π, π], prismatic ones in [−0.5, 0.5] m.
fn random_q(chain: &DhChain, rng: &mut ChaCha8Rng) -> Vec<f64> {
    chain
        .joints
        .iter()
        .map(|j| match j.kind {
            JointKind::Revolute => rng.random_range(-PI..PI),
            JointKind::Prismatic => rng.random_range(-0.5..0.5),
        })
        .collect()
}

fn named(chain: &DhChain, q: &[f64]) -> HashMap<String, f64> {
    chain
        .joints
        .iter()
        .zip(q)
        .map(|(j, &v)| (j.name.clone(), v))
        .collect()
}

/// The largest difference between the URDF's and the DH chain's tip frame
/// (position in m and rotation entries) over q = 0 and `samples` random q.
fn fk_error(text: &str, chain: &DhChain, base: &str, tip: &str, samples: usize) -> f64 {
    let robot = urdf_rs::read_from_string(text).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(samples as u64);
    let mut worst: f64 = 0.0;
    for k in 0..=samples {
        let q = if k == 0 {
            vec![0.0; chain.joints.len()]
        } else {
            random_q(chain, &mut rng)
        };
        let urdf = urdf_pose(&robot, base, tip, &named(chain, &q));
        worst = worst.max(max_abs(&(urdf - dh_tip(chain, &q))));
    }
    worst
}

/// Reads the chain and checks its forward kinematics against the URDF's to 1e-12.
fn read_exact(text: &str, base: &str, tip: &str) -> DhChain {
    let chain = parse(text, base, tip).unwrap_or_else(|e| panic!("{e}"));
    let error = fk_error(text, &chain, base, tip, 300);
    assert!(error < 1e-12, "FK differs by {error:e}: {chain:#?}");
    chain
}

/// Checks the masses: the total below the base link is kept, each DH link's
/// centre of mass is the URDF's for the links `bodies[i]` names (links not
/// named: the base), and the whole arm's centre of mass is the URDF's at
/// random q.
fn check_masses(text: &str, chain: &DhChain, base: &str, bodies: &[&[&str]]) {
    let robot = urdf_rs::read_from_string(text).unwrap();
    let below: Vec<&urdf_rs::Link> = robot
        .links
        .iter()
        .filter(|l| is_below(&robot, &l.name, base))
        .collect();
    let total: f64 = below.iter().map(|l| l.inertial.mass.value).sum();
    let dh_total = chain.base_mass + chain.joints.iter().map(|j| j.mass).sum::<f64>();
    assert!(
        (total - dh_total).abs() < 1e-12,
        "{total} kg != {dh_total} kg"
    );
    assert_eq!(bodies.len(), chain.joints.len());
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..50 {
        let q = random_q(chain, &mut rng);
        let names = named(chain, &q);
        let frames = dh_frames(chain, &q);
        let mut urdf_moment = Vector3::zeros();
        let mut dh_moment = point(&frames[0], chain.base_com) * chain.base_mass;
        for link in &below {
            let com = point(
                &urdf_pose(&robot, base, &link.name, &names),
                link.inertial.origin.xyz.0,
            );
            urdf_moment += com * link.inertial.mass.value;
        }
        for (i, (joint, links)) in chain.joints.iter().zip(bodies).enumerate() {
            let mut mass = 0.0;
            let mut moment = Vector3::zeros();
            for name in *links {
                let link = robot.links.iter().find(|l| l.name == *name).unwrap();
                let pose = urdf_pose(&robot, base, name, &names);
                mass += link.inertial.mass.value;
                moment += point(&pose, link.inertial.origin.xyz.0) * link.inertial.mass.value;
            }
            assert!(
                (mass - joint.mass).abs() < 1e-12,
                "link {}: {mass} kg != {} kg",
                i + 1,
                joint.mass
            );
            let dh_com = point(&frames[i + 1], joint.com);
            if mass > 0.0 {
                let error = (moment / mass - dh_com).norm();
                assert!(
                    error < 1e-12,
                    "link {}: centre of mass off by {error:e} m",
                    i + 1
                );
            } else {
                assert_eq!(joint.com, [0.0; 3]);
            }
            dh_moment += dh_com * joint.mass;
        }
        let error = (urdf_moment - dh_moment).norm() / total;
        assert!(error < 1e-12, "centre of mass off by {error:e} m");
    }
}

// ---- Writing URDFs ----

/// A number of a joint table: a decimal, or ±pi, ±pi/2.
fn number(token: &str) -> f64 {
    match token {
        "pi" => PI,
        "-pi" => -PI,
        "pi/2" => FRAC_PI_2,
        "-pi/2" => -FRAC_PI_2,
        _ => token
            .parse()
            .unwrap_or_else(|_| panic!("not a number: {token}")),
    }
}

fn triple(field: &str) -> [f64; 3] {
    let v: Vec<f64> = field.split_whitespace().map(number).collect();
    v.try_into()
        .unwrap_or_else(|_| panic!("not three numbers: {field}"))
}

/// A link; with a mass, its `<inertial>` (the inertia tensor is not read).
fn link_element(name: &str, mass: Option<(f64, [f64; 3])>) -> String {
    match mass {
        None => format!("  <link name=\"{name}\"/>\n"),
        Some((mass, [x, y, z])) => format!(
            "  <link name=\"{name}\">\n    <inertial>\n      <origin xyz=\"{x:?} {y:?} {z:?}\" rpy=\"0.3 0.2 0.1\"/>\n      \
             <mass value=\"{mass:?}\"/>\n      <inertia ixx=\"1e-4\" ixy=\"0\" ixz=\"0\" iyy=\"1e-4\" iyz=\"0\" izz=\"1e-4\"/>\n    \
             </inertial>\n  </link>\n"
        ),
    }
}

/// A URDF from a joint table, one joint a row:
/// `name type parent child | x y z | roll pitch yaw | axis x y z` (axis `-`:
/// none, URDF's default `1 0 0`). Links are those the joints name, in order,
/// with the masses (kg) and centres of mass given.
fn urdf_with(rows: &[&str], masses: &[(&str, f64, [f64; 3])]) -> String {
    let mut links: Vec<&str> = Vec::new();
    let mut joints = String::new();
    for row in rows {
        let fields: Vec<&str> = row.split('|').collect();
        let [head, xyz, rpy, axis] = fields[..] else {
            panic!("expected four fields: {row}");
        };
        let [name, kind, parent, child] = head.split_whitespace().collect::<Vec<_>>()[..] else {
            panic!("expected name, type, parent, child: {row}");
        };
        for link in [parent, child] {
            if !links.contains(&link) {
                links.push(link);
            }
        }
        let ([x, y, z], [r, p, w]) = (triple(xyz), triple(rpy));
        let axis = match axis.trim() {
            "-" => String::new(),
            axis => {
                let [a, b, c] = triple(axis);
                format!("\n    <axis xyz=\"{a:?} {b:?} {c:?}\"/>")
            }
        };
        let limit = match kind {
            "revolute" => {
                "\n    <limit lower=\"-2.5\" upper=\"2.6\" effort=\"10\" velocity=\"1\"/>"
            }
            "prismatic" => {
                "\n    <limit lower=\"-0.4\" upper=\"0.3\" effort=\"10\" velocity=\"1\"/>"
            }
            _ => "",
        };
        joints += &format!(
            "  <joint name=\"{name}\" type=\"{kind}\">\n    <origin xyz=\"{x:?} {y:?} {z:?}\" rpy=\"{r:?} {p:?} {w:?}\"/>\n    \
             <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>{axis}{limit}\n  </joint>\n"
        );
    }
    let links: String = links
        .iter()
        .map(|l| {
            let mass = masses.iter().find(|m| m.0 == *l).map(|m| (m.1, m.2));
            link_element(l, mass)
        })
        .collect();
    format!("<?xml version=\"1.0\"?>\n<robot name=\"test_arm\">\n{links}{joints}</robot>\n")
}

fn urdf(rows: &[&str]) -> String {
    urdf_with(rows, &[])
}

/// A UR5-like arm (laid out as ur_description has it): axes 2, 3, 4 parallel.
fn ur_like() -> String {
    urdf(&[
        "shoulder_pan  revolute   base_link shoulder  | 0 0 0.089159     | 0 0 0    | 0 0 1",
        "shoulder_lift revolute   shoulder  upper_arm | 0 0.13585 0      | 0 pi/2 0 | 0 1 0",
        "elbow         revolute   upper_arm forearm   | 0 -0.1197 0.425  | 0 0 0    | 0 1 0",
        "wrist_1       revolute   forearm   wrist_1   | 0 0 0.39225      | 0 pi/2 0 | 0 1 0",
        "wrist_2       revolute   wrist_1   wrist_2   | 0 0.093 0        | 0 0 0    | 0 0 1",
        "wrist_3       continuous wrist_2   wrist_3   | 0 0 0.09465      | 0 0 0    | 0 1 0",
        "tool          fixed      wrist_3   tool0     | 0 0.0823 0       | -pi/2 0 0 | -",
    ])
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

// ---- Geometry ----

#[test]
fn parallel_axes_of_a_ur_like_arm_give_its_classical_dh() {
    let chain = read_exact(&ur_like(), "base_link", "tool0");
    let names: Vec<&str> = chain.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "shoulder_pan",
            "shoulder_lift",
            "elbow",
            "wrist_1",
            "wrist_2",
            "wrist_3"
        ]
    );
    assert!(chain.joints.iter().all(|j| j.kind == JointKind::Revolute));
    // Joint 1 is the base link's z axis: frame 0 is the base link's frame.
    assert_eq!(
        chain.base,
        FrameXyzRpy {
            xyz: [0.0; 3],
            rpy: [0.0; 3]
        }
    );
    let j = &chain.joints;
    // The UR5's DH table: d1, a2, a3, d4, d5 (d2 = d3 = 0 by the
    // parallel-axes rule, which puts the shoulder and elbow offsets in d4).
    assert!(close(j[0].d, 0.089159) && j[0].a == 0.0 && close(j[0].alpha, FRAC_PI_2));
    assert!(close(j[1].a.abs(), 0.425) && j[1].d == 0.0);
    assert!(close(j[2].a.abs(), 0.39225) && j[2].d == 0.0);
    assert!(close(j[3].d.abs(), 0.10915) && j[3].a == 0.0);
    assert!(close(j[4].d.abs(), 0.09465) && j[4].a == 0.0);
    // Axes 2-3 and 3-4 are parallel, the others not.
    let parallel: Vec<bool> = j.iter().map(|j| j.parallel_deviation.is_some()).collect();
    assert_eq!(parallel, [false, true, true, false, false, false]);
    assert!(j[1].parallel_deviation.unwrap() < 1e-15);
    for joint in &j[1..3] {
        assert!(joint.alpha == 0.0 || joint.alpha == PI);
    }
    // The last link is the identity; the flange offset is in the tool.
    assert_eq!([j[5].theta, j[5].d, j[5].a, j[5].alpha], [0.0; 4]);
    assert!(close(Vector3::from(chain.tool.xyz).norm(), 0.0823));
    assert_eq!(j[0].limits, Some([-2.5, 2.6]));
    assert_eq!(j[5].limits, None, "continuous");
    assert_eq!(chain.robot, "test_arm");
}

/// A PUMA-like arm with a shoulder offset and a spherical wrist: axes 4, 5,
/// 6 meet in one point.
#[test]
fn intersecting_axes_of_a_spherical_wrist_have_no_length() {
    let text = urdf(&[
        "j1     revolute base l1     | 0 0 0.4     | 0 0 0    | 0 0 1",
        "j2     revolute l1   l2     | 0.025 0 0   | 0 0 0    | 0 1 0",
        "j3     revolute l2   l3     | 0 0 0.455   | 0 0 0    | 0 1 0",
        "j4     revolute l3   l4     | 0 0 0.035   | 0 0 0    | 1 0 0",
        "j5     revolute l4   l5     | 0.42 0 0    | 0 0 0    | 0 1 0",
        "j6     revolute l5   l6     | 0 0 0       | 0 0 0    | 1 0 0",
        "flange fixed    l6   flange | 0.08 0 0    | 0 pi/2 0 | -",
    ]);
    let chain = read_exact(&text, "base", "flange");
    let j = &chain.joints;
    assert!(close(j[0].a.abs(), 0.025), "shoulder offset");
    assert!(close(j[1].a.abs(), 0.455) && j[1].parallel_deviation.is_some());
    assert!(close(j[2].a.abs(), 0.035));
    assert!(close(j[3].d.abs(), 0.42));
    // The wrist: 4 and 5 meet, 5 and 6 meet.
    assert_eq!((j[3].a, j[4].a, j[4].d), (0.0, 0.0, 0.0));
    for joint in &j[3..5] {
        assert!(close(joint.alpha, FRAC_PI_2), "{}", joint.alpha);
    }
}

/// A SCARA: two vertical revolute joints, a quill sliding down (axis −z) and
/// a roll on the quill's own axis; and a gantry of two prismatic joints across
/// each other.
#[test]
fn prismatic_joints_slide_along_their_axes() {
    let text = urdf(&[
        "j1    revolute  base  l1    | 0 0 0.3    | 0 0 0  | 0 0 1",
        "j2    revolute  l1    l2    | 0.35 0 0   | 0 0 0  | 0 0 1",
        "quill prismatic l2    quill | 0.3 0 0    | 0 0 0  | 0 0 -1",
        "roll  revolute  quill hand  | 0 0 -0.05  | 0 0 0  | 0 0 -1",
        "tcp   fixed     hand  tcp   | 0 0 0.1    | pi 0 0 | -",
    ]);
    let chain = read_exact(&text, "base", "tcp");
    let kinds: Vec<JointKind> = chain.joints.iter().map(|j| j.kind).collect();
    use JointKind::{Prismatic, Revolute};
    assert_eq!(kinds, [Revolute, Revolute, Prismatic, Revolute]);
    assert_eq!(chain.joints[2].limits, Some([-0.4, 0.3]));
    // j2 (up) and the quill (down): parallel, opposite, 0.3 m apart.
    assert_eq!(chain.joints[1].alpha, PI);
    assert!(close(chain.joints[1].a, 0.3));
    // The quill and the roll share one axis: no length, no offset, no twist.
    let quill = &chain.joints[2];
    assert_eq!((quill.a, quill.d, quill.alpha), (0.0, 0.0, 0.0));
    assert!(close(chain.joints[0].a, 0.35));

    let text = urdf(&[
        "x   prismatic  frame      carriage_x | 0.1 0.2 0.5    | 0 0 0   | 1 0 0",
        "y   prismatic  carriage_x carriage_y | 0 0.05 0.1     | 0 0 0   | 0 -1 0",
        "c   continuous carriage_y head       | 0.02 0 -0.2    | 0 0.3 0 | 0 0 1",
        "tip fixed      head       tip        | 0 0.01 -0.15   | 0 0 0   | -",
    ]);
    read_exact(&text, "frame", "tip");
}

/// Axes along their frames' negative directions, along x, and along no
/// frame axis at all (one written unnormalised), each turning by its own sign.
#[test]
fn negative_and_oblique_axes_keep_the_sign_of_q() {
    let text = urdf(&[
        "j1  revolute   base a   | 0.01 -0.02 0.2  | 0.1 0 0       | 0 0 -1",
        "j2  revolute   a    b   | 0 0.1 0.05      | 0 0 0         | 0 -1 0",
        "j3  revolute   b    c   | 0.3 0 0         | 0 0 0.4       | -1 0 0",
        "j4  revolute   c    d   | 0.05 0.2 -0.1   | 0.2 -0.7 1.1  | 0.6 0 -0.8",
        "j5  continuous d    e   | 0 0 0.12        | 0 0 0         | 1 1 1",
        "tip fixed      e    tip | 0.03 0 0.07     | 0.5 0.5 0.5   | -",
    ]);
    let chain = read_exact(&text, "base", "tip");
    // Joint 1 turns about the base's −z, tilted by 0.1 rad about x: so does z0.
    let base = frame(&chain.base);
    let z0 = Vector3::new(base[(0, 2)], base[(1, 2)], base[(2, 2)]);
    assert!((z0 - Vector3::new(0.0, 0.1f64.sin(), -0.1f64.cos())).norm() < 1e-15);
    // With no <axis>, URDF's default x axis: both joints turn about x, 0.2 m apart.
    let text = urdf(&[
        "j1 revolute base a   | 0 0 0.1 | 0 0 0 | -",
        "j2 revolute a    tip | 0 0.2 0 | 0 0 0 | -",
    ]);
    let chain = read_exact(&text, "base", "tip");
    assert!(close(chain.joints[0].a, 0.2));
    assert!(chain.joints[0].parallel_deviation.unwrap() < 1e-15);
}

/// Fixed joints before the first moving joint, between moving joints and
/// two at the tip fold into the transforms around them.
#[test]
fn fixed_joints_fold_into_the_chain() {
    let text = urdf(&[
        "mount   fixed     world    pedestal | 0.5 -0.2 0.7    | 0 0 0.9      | -",
        "j1      revolute  pedestal l1       | 0 0 0.1         | 0.05 0 0     | 0 0 1",
        "bracket fixed     l1       bracket  | 0.1 0 0.2       | pi/2 0.3 0   | -",
        "j2      revolute  bracket  l2       | 0 0.05 0        | 0 0 0        | 0 0 1",
        "j3      prismatic l2       l3       | 0.2 0 0         | 0 -0.4 0     | 1 0 0",
        "flange  fixed     l3       flange   | 0 0 0.05        | 0 pi/2 0     | -",
        "tool    fixed     flange   tool     | 0.01 0.02 0.03  | 0.1 0.2 0.3  | -",
        "tcp     fixed     tool     tcp      | 0 0 0.12        | pi 0 0       | -",
    ]);
    let chain = read_exact(&text, "world", "tcp");
    assert_eq!(chain.joints.len(), 3);
    // The same arm from a link below the world, and to links short of the tip.
    read_exact(&text, "pedestal", "flange");
    read_exact(&text, "pedestal", "l3");
    assert_eq!(read_exact(&text, "bracket", "l3").joints.len(), 2);
}

#[test]
fn a_single_joint_chain_holds_all_in_base_and_tool() {
    let text = urdf(&[
        "only revolute base arm | 0.1 0.2 0.3    | 0.3 -0.2 0.1  | 0 1 0",
        "tip  fixed    arm  tip | 0.2 -0.1 0.05  | 1 0.5 -0.3    | -",
    ]);
    for tip in ["arm", "tip"] {
        let chain = read_exact(&text, "base", tip);
        assert_eq!(chain.joints.len(), 1);
        let j = &chain.joints[0];
        assert_eq!([j.theta, j.d, j.a, j.alpha], [0.0; 4]);
    }
}

/// A random URDF chain: `moving` moving joints with fixed ones among them;
/// axes along frame axes (either sign) or anywhere (unnormalised); origins
/// at zero, along a frame axis or anywhere; rotations of none, quarter turns
/// or any; every link with a random mass. Returns the URDF and its tip link.
fn random_chain(rng: &mut ChaCha8Rng, moving: usize) -> (String, String) {
    let mut rows = Vec::new();
    let mut masses = vec![("base".to_owned(), 1.0, [0.01, 0.0, 0.02])];
    let mut count = 0;
    let quarter = |rng: &mut ChaCha8Rng| f64::from(rng.random_range(-2..=2)) * FRAC_PI_2;
    let mut n = 0;
    while count < moving {
        n += 1;
        let kind = match rng.random_range(0..10) {
            0 | 1 => "fixed",
            2 => "continuous",
            3 | 4 => "prismatic",
            _ => "revolute",
        };
        if kind != "fixed" {
            count += 1;
        }
        let xyz = match rng.random_range(0..3) {
            0 => [0.0; 3],
            1 => {
                let mut v = [0.0; 3];
                v[rng.random_range(0..3)] = rng.random_range(-0.3..0.3);
                v
            }
            _ => [(); 3].map(|_| rng.random_range(-0.3..0.3)),
        };
        let rpy = match rng.random_range(0..3) {
            0 => [0.0; 3],
            1 => [(); 3].map(|_| quarter(rng)),
            _ => [(); 3].map(|_| rng.random_range(-PI..PI)),
        };
        let axis = if rng.random_bool(0.6) {
            let mut a = [0.0; 3];
            a[rng.random_range(0..3)] = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            a
        } else {
            [(); 3].map(|_| rng.random_range(-1.0..1.0))
        };
        let parent = if n == 1 {
            "base".to_owned()
        } else {
            format!("link{}", n - 1)
        };
        let f = |v: [f64; 3]| format!("{:?} {:?} {:?}", v[0], v[1], v[2]);
        rows.push(format!(
            "j{n} {kind} {parent} link{n} | {} | {} | {}",
            f(xyz),
            f(rpy),
            f(axis)
        ));
        let com = [(); 3].map(|_| rng.random_range(-0.1..0.1));
        masses.push((format!("link{n}"), rng.random_range(0.0..2.0), com));
    }
    let rows: Vec<&str> = rows.iter().map(String::as_str).collect();
    let masses: Vec<(&str, f64, [f64; 3])> = masses
        .iter()
        .map(|(l, m, c)| (l.as_str(), *m, *c))
        .collect();
    (urdf_with(&rows, &masses), format!("link{n}"))
}

#[test]
fn a_ten_joint_chain_matches_the_urdf() {
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let (text, tip) = random_chain(&mut rng, 10);
    let chain = read_exact(&text, "base", &tip);
    assert_eq!(chain.joints.len(), 10);
}

#[test]
fn random_chains_match_the_urdf_and_keep_their_masses() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let mut parallel = 0;
    for moving in (1..=10).cycle().take(60) {
        let (text, tip) = random_chain(&mut rng, moving);
        let chain = read_exact(&text, "base", &tip);
        assert_eq!(chain.joints.len(), moving);
        parallel += chain
            .joints
            .iter()
            .filter(|j| j.parallel_deviation.is_some())
            .count();
        // Each DH link carries the links from its joint's child up to the
        // next moving joint.
        let robot = urdf_rs::read_from_string(&text).unwrap();
        let mut bodies: Vec<Vec<&str>> = vec![Vec::new(); moving];
        let mut body = None;
        for j in &robot.joints {
            if j.joint_type != urdf_rs::JointType::Fixed {
                body = Some(body.map_or(0, |b| b + 1));
            }
            if let Some(b) = body {
                bodies[b].push(&j.child.link);
            }
        }
        let bodies: Vec<&[&str]> = bodies.iter().map(Vec::as_slice).collect();
        check_masses(&text, &chain, "base", &bodies);
    }
    assert!(
        parallel > 10,
        "the chains should hold parallel axes too: {parallel}"
    );
}

/// A frame turned by 1.5708 rad where π/2 was meant, and back, as URDFs
/// write: the axis written in the turned frame misses the next one's
/// parallel by the rounding. Taken as parallel, with the deviation
/// reported, exact at q = 0 and within the deviation's reach elsewhere.
/// Axes 1e-3 rad from parallel stay as they are, exact.
#[test]
#[allow(
    clippy::approx_constant,
    reason = "π/2 rounded as URDFs write it is the point"
)]
fn nearly_parallel_axes_are_parallel_within_the_tolerance() {
    let make = |turn: f64| {
        // j3's axis, −y, is j2's but for the rounding, 0.3 m above it.
        let rows = [
            "j1  revolute base a   | 0 0 0.1    | 0 0 0     | 0 0 1".to_owned(),
            format!("j2  revolute a    b   | 0 0 0.4    | {turn:?} 0 0  | 0 0 1"),
            format!(
                "j3  revolute b    c   | 0 0.3 0    | {:?} 0 0 | 0 -1 0",
                -turn
            ),
            "tip fixed    c    tip | 0.1 0 0.05 | 0 0 0     | -".to_owned(),
        ];
        urdf(&rows.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let text = make(1.5708);
    let chain = parse(&text, "base", "tip").unwrap();
    let deviation = chain.joints[1].parallel_deviation.unwrap();
    assert!(close(deviation, 1.5708 - FRAC_PI_2), "{deviation:e}");
    assert_eq!(chain.joints[1].d, 0.0);
    assert!(
        (chain.joints[1].a - 0.3).abs() < 1e-9,
        "{}",
        chain.joints[1].a
    );
    assert!(fk_error(&text, &chain, "base", "tip", 0) < 1e-12);
    // Elsewhere the tip turns about an axis off by the deviation.
    let error = fk_error(&text, &chain, "base", "tip", 300);
    assert!(error > 1e-9 && error < 4.0 * deviation, "{error:e}");

    let text = make(FRAC_PI_2 + 1e-3);
    let chain = read_exact(&text, "base", "tip");
    assert_eq!(chain.joints[1].parallel_deviation, None);
    // The two axes lie in one plane: they meet, 300 m away.
    assert!(
        (chain.joints[1].d.abs() - 300.0).abs() < 1e-3,
        "{}",
        chain.joints[1].d
    );
    assert_eq!(chain.joints[1].a, 0.0);
}

/// Frame 0 on an axis along the base's x or y, and under any rotation, pitch
/// ±90° and near it included, reads back exactly through roll, pitch, yaw.
#[test]
fn base_frames_at_any_rotation_read_back_exactly() {
    for (axis, rpy) in [
        ("1 0 0", "0 0 0"),
        ("-1 0 0", "0 0 0"),
        ("0 1 0", "0 0 0"),
        ("0 0 1", "0 pi/2 0"),
        ("0 0 1", "0.3 -pi/2 1.2"),
        ("0 0 1", "0.3 1.570796325 1.2"),
        ("0 0 1", "2 1 -3"),
    ] {
        let text = urdf(&[
            &format!("j1 revolute base a   | 0.2 0.1 0.3 | {rpy}   | {axis}"),
            "j2 revolute a    tip | 0.2 0 0     | 0.4 0 0 | 0 0 1",
        ]);
        read_exact(&text, "base", "tip");
    }
}

// ---- Masses ----

/// An arm with masses on the base, on a fixed link before joint 1, on fixed
/// links between joints, on a side branch held by a fixed joint, on a
/// gripper jaw (a moving joint off the chain), beyond the tip, and above
/// the base (not counted).
#[test]
fn each_link_carries_what_moves_with_it() {
    let text = urdf_with(
        &[
            "on_world fixed      world  base    | 1 2 0         | 0 0 0     | -",
            "riser    fixed      base   riser   | 0 0 0.1       | 0 0 0     | -",
            "j1       revolute   riser  l1      | 0 0 0.1       | 0 0 0     | 0 0 1",
            "motor    fixed      l1     motor   | 0 0 0.2       | 0 pi/2 0  | -",
            "j2       revolute   motor  l2      | 0 0 0.05      | 0 0 0     | 0 1 0",
            "cable    fixed      l2     cable   | 0.1 0.05 0    | 0 0 0     | -",
            "j3       revolute   l2     l3      | 0.3 0 0       | 0.2 0 0   | 0 1 0",
            "flange   fixed      l3     flange  | 0 0 0.25      | 0 0 0     | -",
            "jaw      revolute   flange jaw     | 0 0.02 0.03    | 0 0 0     | 1 0 0",
            "camera   fixed      flange camera  | 0.05 0 0      | 0 0 0     | -",
            "turn     continuous world  world_2 | 0 0 0         | 0 0 0     | 0 0 1",
        ],
        &[
            ("world", 50.0, [0.0, 0.0, 0.0]),
            ("base", 2.0, [0.0, 0.0, 0.05]),
            ("riser", 0.5, [0.01, 0.0, 0.1]),
            ("l1", 1.5, [0.0, 0.02, 0.1]),
            ("motor", 0.3, [0.05, 0.0, 0.0]),
            ("l2", 1.0, [0.1, 0.0, 0.0]),
            ("cable", 0.05, [0.0, 0.01, 0.0]),
            ("l3", 0.6, [0.0, 0.0, 0.1]),
            ("flange", 0.1, [0.0, 0.0, 0.01]),
            ("jaw", 0.02, [0.0, 0.03, 0.02]),
            ("camera", 0.08, [0.02, 0.0, 0.0]),
        ],
    );
    for tip in ["flange", "l3"] {
        let chain = read_exact(&text, "base", tip);
        assert_eq!(chain.frozen_joints, ["jaw"]);
        assert!(close(chain.base_mass, 2.5));
        check_masses(
            &text,
            &chain,
            "base",
            &[
                &["l1", "motor"],
                &["l2", "cable"],
                &["l3", "flange", "jaw", "camera"],
            ],
        );
    }
    // From the world, whose other branch turns: that joint is frozen too.
    let chain = parse(&text, "world", "flange").unwrap();
    assert_eq!(chain.frozen_joints, ["jaw", "turn"]);
    assert!(close(chain.base_mass, 52.5));
}

#[test]
fn links_without_mass_give_a_zero_centre() {
    let chain = parse(&ur_like(), "base_link", "tool0").unwrap();
    assert!(
        chain
            .joints
            .iter()
            .all(|j| j.mass == 0.0 && j.com == [0.0; 3])
    );
    assert_eq!((chain.base_mass, chain.base_com), (0.0, [0.0; 3]));
}

// ---- Errors ----

fn error_of(text: &str, base: &str, tip: &str) -> String {
    match parse(text, base, tip) {
        Ok(chain) => panic!("expected an error, read {chain:#?}"),
        Err(e) => e.to_string(),
    }
}

/// `line N: `, N the 1-based line on which `needle` first appears.
fn at_line_of(text: &str, needle: &str) -> String {
    let line = text[..text.find(needle).unwrap()].matches('\n').count() + 1;
    format!("line {line}: ")
}

#[test]
fn a_missing_link_is_named_with_the_closest_there_are() {
    let text = ur_like();
    let message = error_of(&text, "base_lnk", "tool0");
    assert!(
        message.contains("no link named `base_lnk` for the base link"),
        "{message}"
    );
    assert!(
        message.contains("the closest of the file's 8 links: `base_link`"),
        "{message}"
    );
    let message = error_of(&text, "base_link", "tool_0");
    assert!(
        message.contains("no link named `tool_0` for the tip link"),
        "{message}"
    );
    assert!(message.contains("links: `tool0`"), "{message}");
    let message = error_of("<robot name=\"empty\"></robot>", "a", "b");
    assert!(message.contains("the file defines no <link>"), "{message}");
}

#[test]
fn a_tip_not_below_the_base_is_refused() {
    let text = ur_like();
    let message = error_of(&text, "forearm", "shoulder");
    assert!(
        message.starts_with(&at_line_of(&text, "<link name=\"shoulder\"")),
        "{message}"
    );
    assert!(
        message.contains("link `shoulder` is not below the base link `forearm`"),
        "{message}"
    );
    assert!(message.contains("`shoulder` ← `base_link`"), "{message}");
    assert!(message.contains("are the two swapped?"), "{message}");
    // Side by side: neither is below the other.
    let text = urdf(&[
        "l revolute base left  | 0 0 0 | 0 0 0 | -",
        "r revolute base right | 0 0 0 | 0 0 0 | -",
    ]);
    let message = error_of(&text, "left", "right");
    assert!(
        message.contains("`right` ← `base`") && !message.contains("swapped"),
        "{message}"
    );
    let message = error_of(&text, "left", "left");
    assert!(
        message.contains("the base and tip links are both `left`"),
        "{message}"
    );
}

#[test]
fn joints_that_cannot_be_in_a_dh_chain_are_named() {
    for kind in ["floating", "planar"] {
        let text = urdf(&[
            "j1   revolute base a   | 0 0 0 | 0 0 0 | -",
            &format!("free {kind} a b | 0 0 0 | 0 0 0 | -"),
            "j3   revolute b    tip | 0 0 0 | 0 0 0 | -",
        ]);
        let message = error_of(&text, "base", "tip");
        assert!(
            message.starts_with(&at_line_of(&text, "<joint name=\"free\"")),
            "{message}"
        );
        assert!(
            message.contains(&format!(
                "joint `free` between links `base` and `tip` is {kind}"
            )),
            "{message}"
        );
        assert!(
            message.contains("expected revolute, continuous, prismatic or fixed"),
            "{message}"
        );
        // Off the chain it is only a mass.
        assert!(parse(&text, "base", "a").is_ok());
    }
    let text = urdf(&[
        "j1 revolute base a   | 0 0 0 | 0 0 0 | -",
        "j2 revolute a    tip | 0 0 0 | 0 0 0 | -",
    ]);
    let mimic = text.replacen(
        "<child link=\"tip\"/>",
        "<child link=\"tip\"/>\n    <mimic joint=\"j1\" multiplier=\"2\"/>",
        1,
    );
    let message = error_of(&mimic, "base", "tip");
    assert!(
        message.contains("joint `j2` between links `base` and `tip` mimics joint `j1`"),
        "{message}"
    );
    let text = urdf(&[
        "f1 fixed base a   | 0 0 0 | 0 0 0 | -",
        "f2 fixed a    tip | 0 0 0 | 0 0 0 | -",
    ]);
    let message = error_of(&text, "base", "tip");
    assert!(
        message.contains("from link `base` to link `tip` are all fixed"),
        "{message}"
    );
}

#[test]
fn bad_numbers_are_named_by_their_joint_or_link() {
    let text = ur_like();
    let with = |from: &str, to: &str| {
        assert!(text.contains(from), "{from}");
        text.replacen(from, to, 1)
    };
    let zero_axis = with("<axis xyz=\"0.0 1.0 0.0\"/>", "<axis xyz=\"0 0 0\"/>");
    let message = error_of(&zero_axis, "base_link", "tool0");
    assert!(
        message.starts_with(&at_line_of(&zero_axis, "<joint name=\"shoulder_lift\"")),
        "{message}"
    );
    assert!(
        message.contains(
            "joint `shoulder_lift`: expected a finite, non-zero <axis xyz>, found `0 0 0`"
        ),
        "{message}"
    );
    let message = error_of(
        &with("0.0 0.13585 0.0", "0.0 NaN 0.0"),
        "base_link",
        "tool0",
    );
    assert!(
        message.contains("joint `shoulder_lift`: expected finite numbers in <origin xyz rpy>"),
        "{message}"
    );
    let message = error_of(
        &with("lower=\"-2.5\" upper=\"2.6\"", "lower=\"1\" upper=\"-1\""),
        "base_link",
        "tool0",
    );
    assert!(
        message
            .contains("joint `shoulder_pan`: expected <limit lower=… upper=…> with lower ≤ upper"),
        "{message}"
    );
    let negative = urdf_with(
        &["j revolute base arm | 0 0 0 | 0 0 0 | -"],
        &[("base", 1.0, [0.0; 3]), ("arm", -0.5, [0.0; 3])],
    );
    let message = error_of(&negative, "base", "arm");
    assert!(
        message.starts_with(&at_line_of(&negative, "<link name=\"arm\"")),
        "{message}"
    );
    assert!(
        message.contains("link `arm`: expected a finite <mass> ≥ 0"),
        "{message}"
    );
}

#[test]
fn limits_carry_over_unless_the_file_has_none() {
    let text = ur_like();
    let limits = |text: &str| parse(text, "base_link", "tool0").unwrap().joints[0].limits;
    assert_eq!(limits(&text), Some([-2.5, 2.6]));
    let zero = text.replacen("lower=\"-2.5\" upper=\"2.6\"", "lower=\"0\" upper=\"0\"", 1);
    assert_eq!(limits(&zero), None);
    let without = text.replacen(
        "\n    <limit lower=\"-2.5\" upper=\"2.6\" effort=\"10\" velocity=\"1\"/>",
        "",
        1,
    );
    assert_eq!(limits(&without), None);
    // URDF 1.2 reads missing limits as infinite.
    assert_eq!(
        limits(&without.replacen("<robot name", "<robot version=\"1.2\" name", 1)),
        None
    );
}

#[test]
fn a_tree_that_is_not_one_is_refused() {
    let row = "j revolute a b | 0 0 0 | 0 0 0 | -";
    let twice = urdf(&[row]).replacen(
        "<link name=\"a\"/>",
        "<link name=\"a\"/><link name=\"a\"/>",
        1,
    );
    let message = error_of(&twice, "a", "b");
    assert!(message.contains("link `a` is defined twice"), "{message}");
    let missing = urdf(&[row]).replacen("<link name=\"b\"/>", "", 1);
    let message = error_of(&missing, "a", "b");
    assert!(
        message.contains("joint `j` has the child link `b`, which the file does not define"),
        "{message}"
    );
    let two_parents = urdf(&[
        "j1 revolute a c | 0 0 0 | 0 0 0 | -",
        "j2 revolute b c | 0 0 0 | 0 0 0 | -",
    ]);
    let message = error_of(&two_parents, "a", "c");
    assert!(
        message.contains("link `c` is the child of both joint `j1` and joint `j2`"),
        "{message}"
    );
    let looped = urdf(&[
        "j1 revolute a b | 0 0 0 | 0 0 0 | -",
        "j2 revolute b a | 0 0 0 | 0 0 0 | -",
    ]);
    let message = error_of(&looped, "a", "b");
    assert!(message.contains("on a loop of links"), "{message}");
}

#[test]
fn a_malformed_file_is_a_syntax_error_naming_the_file() {
    for text in [
        "<robot name=\"x\"><link name=\"a\"></robot>",
        "<robot name=\"x\"><link name=\"a\"/><joint name=\"j\" type=\"revolute\"/></robot>",
        "<robot name=\"x\"><link name=\"a\"/><joint name=\"j\" type=\"hinge\"><parent link=\"a\"/><child link=\"a\"/></joint></robot>",
        "not xml at all",
    ] {
        let message = error_of(text, "a", "b");
        assert!(
            message.starts_with("expected a URDF robot description: "),
            "{message}"
        );
    }
    let xacro = "<robot name=\"x\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n\
                 <xacro:macro name=\"m\"><link name=\"a\"/></xacro:macro>\n</robot>";
    let message = error_of(xacro, "a", "b");
    assert!(
        message.contains("found a xacro file") && message.contains("expand it first"),
        "{message}"
    );

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.urdf");
    std::fs::write(&path, "<robot name=\"x\"><link name=\"a\"></robot>").unwrap();
    let error = read(&path, "a", "b").unwrap_err();
    assert!(matches!(error, Error::Parse { .. }), "{error:?}");
    let report = error.report();
    assert!(
        report.contains("broken.urdf`: expected a URDF robot description"),
        "{report}"
    );
    let error = read(&dir.path().join("missing.urdf"), "a", "b").unwrap_err();
    assert!(error.is_access(), "{error:?}");
    std::fs::write(&path, ur_like()).unwrap();
    assert_eq!(
        read(&path, "base_link", "tool0").unwrap(),
        parse(&ur_like(), "base_link", "tool0").unwrap()
    );
}

// ---- The SO-101 ----

const SO101: &str = include_str!("../../../arms/so101/so101.urdf");

/// The SO-101's arm: base to the gripper's frame, five revolute joints; the
/// jaw's own joint (`gripper`) hangs off the chain and is frozen.
#[test]
fn the_so101_arm_reads_as_five_revolute_joints() {
    let chain = read_exact(SO101, "base_link", "gripper_frame_link");
    let names: Vec<&str> = chain.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "shoulder_pan",
            "shoulder_lift",
            "elbow_flex",
            "wrist_flex",
            "wrist_roll"
        ]
    );
    assert!(chain.joints.iter().all(|j| j.kind == JointKind::Revolute));
    let limits: Vec<[f64; 2]> = chain.joints.iter().map(|j| j.limits.unwrap()).collect();
    assert_eq!(
        limits,
        [
            [-1.91986, 1.91986],
            [-1.74533, 1.74533],
            [-1.69, 1.69],
            [-1.65806, 1.65806],
            [-2.74385, 2.84121]
        ]
    );
    assert_eq!(chain.frozen_joints, ["gripper"]);
    // Shoulder, elbow and wrist pitch are parallel.
    let parallel: Vec<bool> = chain
        .joints
        .iter()
        .map(|j| j.parallel_deviation.is_some())
        .collect();
    assert_eq!(parallel, [false, true, true, false, false]);
    assert!(close(chain.base_mass, 0.147));
    assert!(close(chain.joints[4].mass, 0.087 + 1e-9 + 0.012));
    check_masses(
        SO101,
        &chain,
        "base_link",
        &[
            &["shoulder_link"],
            &["upper_arm_link"],
            &["lower_arm_link"],
            &["wrist_link"],
            &[
                "gripper_link",
                "gripper_frame_link",
                "moving_jaw_so101_v1_link",
            ],
        ],
    );
}

/// The gripper frame in the base link's frame as yourdfpy 0.0.60 computes
/// it from the original file: position (m) and rotation to 1e-9.
#[test]
fn the_so101_agrees_with_yourdfpy() {
    let chain = parse(SO101, "base_link", "gripper_frame_link").unwrap();
    for (q, position, rotation) in YOURDFPY_SO101 {
        let tip = dh_tip(&chain, &q);
        let mut expected = homogeneous(Matrix3::from_row_slice(rotation.as_flattened()), position);
        expected -= tip;
        let error = max_abs(&expected);
        assert!(error < 1e-9, "{q:?}: off by {error:e}");
    }
}

/// (q in rad; position, m; rotation, by rows) of `gripper_frame_link` in
/// `base_link` from yourdfpy 0.0.60 (`URDF.load(…, load_meshes=False)`,
/// `update_cfg`, `get_transform("gripper_frame_link", "base_link")`), on
/// the file as published.
#[allow(clippy::type_complexity)]
const YOURDFPY_SO101: [([f64; 5], [f64; 3], [[f64; 3]; 3]); 5] = [
    (
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [
            0.39136147022015805,
            -9.21206311460634e-06,
            0.22646971024033286,
        ],
        [
            [
                8.665019265737822e-06,
                -1.0300368439284612e-05,
                0.9999999999094099,
            ],
            [
                0.04866292685830077,
                0.9988152579192189,
                9.866499961486485e-06,
            ],
            [
                -0.9988152579303647,
                0.04866292676839898,
                9.15599952875738e-06,
            ],
        ],
    ),
    (
        [0.3, -0.5, 0.8, -1.0, 1.5],
        [
            0.2787922633785476,
            -0.08264978966473698,
            0.29593837145592367,
        ],
        [
            [-0.22004625560064503, 0.6462857691411812, 0.7306807442390466],
            [
                -0.9712205364792263,
                -0.07514917079405366,
                -0.2260160871486139,
            ],
            [
                -0.09116092867637585,
                -0.7593861380974493,
                0.6442223050689123,
            ],
        ],
    ),
    (
        [-1.2, 1.0, -1.4, 0.7, -2.0],
        [0.1829662524819768, 0.389879707330177, 0.1674159647965664],
        [
            [-0.7783792346772618, 0.523730819707004, 0.3461672941111996],
            [0.44842702061245526, 0.07792826553179606, 0.8904158537536505],
            [0.43936200815259047, 0.848311979121028, -0.2955127947684967],
        ],
    ),
    (
        [1.9, 1.7, 1.6, 1.6, 2.8],
        [
            0.027340451220898218,
            -0.024425778827427965,
            0.24828632063462813,
        ],
        [
            [
                -0.06628294662807024,
                -0.9959777135044675,
                -0.0602906724851615,
            ],
            [
                0.98277888651554,
                -0.054720434455987135,
                -0.17649740585125623,
            ],
            [0.1724883509271726, -0.07095116810427182, 0.982452899908725],
        ],
    ),
    (
        [-0.1, 0.2, -0.3, 0.4, -0.5],
        [0.4006437445902924, 0.04007944659580864, 0.18640307014263247],
        [
            [-0.3029486766402573, 0.06817086500340765, 0.9505655329784493],
            [0.4937840338068195, 0.8643374640535938, 0.09538383610899802],
            [-0.8151070035764523, 0.4982704901939203, -0.2955115756151151],
        ],
    ),
];
