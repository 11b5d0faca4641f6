//! `lrmcal export --urdf` run as a user runs it. The written URDF is read back
//! with an independent parser (urdf-rs) and evaluated by composing its joint
//! origins and turns; its `tool_point` must be where `lrmcal predict` puts the
//! tool point of the same rigid arm, to 1e-6 mm, for the bundled arm and for a
//! calibrated arm with an error in every parameter, in the measurement frame
//! (`--world`) and in the arm's own base frame (the default). What ROS needs
//! of it is there: the arm file's joint names, masses with positive definite
//! inertias, geometry on every link, the payload as a link; a URDF that
//! would stand tilted in ROS is warned about. Bad input is named.

mod common;

use common::lrmcal;
use model::testing::TEST_ARM_JOINTS as JOINTS;

use std::collections::HashSet;
use std::path::Path;
use std::process::Output;

use lrmcal_core::io::calibration_file::SCHEMA_VERSION;
use lrmcal_core::io::{arm_source, predictions};
use model::testing::{ErrorSizes, random_errors};
use model::{Arm, ParamId};
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Runs `lrmcal export --urdf` with `args`; the URDF text (from `--out` if given, else stdout).
fn export(args: &[&str]) -> String {
    let mut all = vec!["export", "--urdf"];
    all.extend_from_slice(args);
    let run = lrmcal(&all);
    assert!(run.status.success(), "{}", stderr(&run));
    match args.iter().position(|a| *a == "--out") {
        Some(i) => std::fs::read_to_string(args[i + 1]).unwrap(),
        None => String::from_utf8(run.stdout).unwrap(),
    }
}

/// A calibration file (the documented JSON format) holding `arm` as identified from `nominal`.
fn calibration_json(nominal: &Arm<f64>, arm: &Arm<f64>, schema_version: u32) -> String {
    let stats = serde_json::json!({
        "count": 3, "mean_m": 1e-4, "median_m": 1e-4, "rms_m": 1e-4, "p95_m": 1e-4, "max_m": 1e-4
    });
    serde_json::json!({
        "schema": "lrmcal-calibration",
        "schema_version": schema_version,
        "option": "elasto-kinematic",
        "nominal": nominal,
        "arm": arm,
        "parameters": [],
        "at_bound": [],
        "removed": [],
        "poses_used": [1, 2, 3],
        "loads_kg": [0.0],
        "fit_residual": stats,
        "validation": null,
    })
    .to_string()
}

/// Where `link` is at joint positions `q` (rad): the URDF's joint origins and
/// turns composed from `link` up to the root, `world` if the file has one,
/// else `base_link`. Joint i is the one whose child is `link_i`.
fn link_pose(robot: &urdf_rs::Robot, link: &str, q: &[f64; JOINTS]) -> Isometry3<f64> {
    let mut pose = Isometry3::identity();
    let mut current = link.to_owned();
    while let Some(joint) = robot.joints.iter().find(|j| j.child.link == current) {
        let (xyz, rpy) = (joint.origin.xyz.0, joint.origin.rpy.0);
        let origin = Isometry3::from_parts(
            Translation3::from(Vector3::from(xyz)),
            UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
        );
        let turn = match joint.joint_type {
            urdf_rs::JointType::Fixed => UnitQuaternion::identity(),
            urdf_rs::JointType::Revolute => {
                let i: usize = joint.child.link["link_".len()..].parse().unwrap();
                let axis = Unit::new_normalize(Vector3::from(joint.axis.xyz.0));
                UnitQuaternion::from_axis_angle(&axis, q[i - 1])
            }
            ref other => panic!("joint `{}` is {other:?}", joint.name),
        };
        pose = origin * turn * pose;
        current = joint.parent.link.clone();
    }
    let root = if robot.links.iter().any(|l| l.name == "world") {
        "world"
    } else {
        "base_link"
    };
    assert_eq!(current, root, "the chain from `{link}` ends elsewhere");
    pose
}

/// The URDF has the documented links and joints, joint limits exactly the arm's.
fn check_structure(robot: &urdf_rs::Robot, arm: &Arm<f64>) {
    let links: HashSet<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
    let expected = [
        "world",
        "base_link",
        "base",
        "link_1",
        "link_2",
        "link_3",
        "link_4",
        "link_5",
        "link_6",
        "flange",
        "tool0",
        "tool_point",
    ];
    assert_eq!(links, expected.into_iter().collect());
    let parents = [
        "base_link",
        "link_1",
        "link_2",
        "link_3",
        "link_4",
        "link_5",
    ];
    for (i, joint) in arm.joints.iter().enumerate() {
        let child = format!("link_{}", i + 1);
        let j = robot.joints.iter().find(|j| j.child.link == child).unwrap();
        assert_eq!(j.joint_type, urdf_rs::JointType::Revolute);
        assert_eq!(j.axis.xyz.0, [0.0, 0.0, 1.0]);
        assert_eq!([j.limit.lower, j.limit.upper], joint.limits, "{child}");
        assert_eq!(j.parent.link, parents[i]);
    }
    let fixed = robot
        .joints
        .iter()
        .filter(|j| j.joint_type == urdf_rs::JointType::Fixed)
        .count();
    assert_eq!(
        fixed, 5,
        "world-base_link, base_link-base, link_6-flange, flange-tool0, tool0-tool_point"
    );
}

/// `count` random joint vectors within `arm`'s limits, in degrees.
fn random_poses_deg(arm: &Arm<f64>, count: usize, seed: u64) -> Vec<[f64; JOINTS]> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            std::array::from_fn(|i| {
                let [lo, hi] = arm.joints[i].limits;
                rng.random_range(lo.to_degrees()..=hi.to_degrees())
            })
        })
        .collect()
}

/// Writes the poses as a pose list (degrees, every digit) and returns its path.
fn pose_list(dir: &Path, poses: &[[f64; JOINTS]]) -> std::path::PathBuf {
    let mut text = String::from("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n");
    for (id, q) in poses.iter().enumerate() {
        let cells: Vec<String> = q.iter().map(|x| format!("{x:?}")).collect();
        text += &format!("{id},{}\n", cells.join(","));
    }
    let path = dir.join("poses.csv");
    std::fs::write(&path, text).unwrap();
    path
}

/// `lrmcal predict --arm ARM` for the poses, at no load, m.
fn predict(dir: &Path, arm: &str, poses: &Path) -> Vec<Vector3<f64>> {
    let out = dir.join("predicted.csv");
    let run = lrmcal(&[
        "predict",
        "--arm",
        arm,
        "--poses",
        s(poses),
        "--out",
        s(&out),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    predictions::read(&out)
        .unwrap()
        .into_iter()
        .map(|p| p.position)
        .collect()
}

/// Compares the URDF's tool_point with predict's tool point (to 1e-6 mm) and
/// its frames with the model's DH frames; returns the largest distances from
/// predict's file and from the model in memory, mm.
fn check_against_predict(
    urdf_text: &str,
    arm: &Arm<f64>,
    poses_deg: &[[f64; JOINTS]],
    predicted: &[Vector3<f64>],
) -> (f64, f64) {
    let robot = urdf_rs::read_from_string(urdf_text).unwrap();
    check_structure(&robot, arm);
    let chain = arm.chain();
    let (mut worst_mm, mut worst_model_mm) = (0.0f64, 0.0f64);
    for (q_deg, p) in poses_deg.iter().zip(predicted) {
        // The pose list reader's own conversion.
        let q = q_deg.map(f64::to_radians);
        let tool_point = link_pose(&robot, "tool_point", &q).translation.vector;
        let mm = (tool_point - p).norm() * 1000.0;
        worst_mm = worst_mm.max(mm);
        assert!(mm <= 1e-6, "{mm:e} mm at {q_deg:?}");
        // In memory, without the file's 1e-6 mm resolution.
        let model_mm = (tool_point - chain.rigid_tool_point(&q)).norm() * 1000.0;
        worst_model_mm = worst_model_mm.max(model_mm);
        assert!(
            model_mm < 1e-9,
            "{model_mm:e} mm from the model at {q_deg:?}"
        );

        // The frames the file's header promises, against the model's DH frames.
        let dh = chain.frames(&q, 0.0).frames;
        for i in 1..=JOINTS {
            let link = link_pose(&robot, &format!("link_{i}"), &q);
            let frame = &dh[i - 1];
            assert!((link.translation.vector - frame.translation.vector).norm() < 1e-12);
            let z = link.rotation * Vector3::z();
            assert!(
                (z - frame.rotation * Vector3::z()).norm() < 1e-12,
                "link_{i}"
            );
        }
        let tool0 = link_pose(&robot, "tool0", &q).to_homogeneous();
        assert!((tool0 - dh[JOINTS].to_homogeneous()).abs().max() < 1e-12);
        let flange = link_pose(&robot, "flange", &q);
        assert!((flange.translation.vector - dh[JOINTS].translation.vector).norm() < 1e-12);
        let out = dh[JOINTS].rotation * Vector3::z();
        assert!((flange.rotation * Vector3::x() - out).norm() < 1e-12);
    }
    (worst_mm, worst_model_mm)
}

#[test]
fn bundled_arm_urdf_puts_the_tool_where_predict_does() {
    let dir = tempfile::tempdir().unwrap();
    let arm = arm_source::bundled("lrm").unwrap().arm;
    assert!(arm.chain().is_rigid(), "the comparison needs a rigid arm");
    let poses = random_poses_deg(&arm, 300, 1);
    let list = pose_list(dir.path(), &poses);
    // The bundled arm, written to standard output, in the measurement frame.
    let text = export(&["--world"]);
    let predicted = predict(dir.path(), "lrm", &list);
    let (file, memory) = check_against_predict(&text, &arm, &poses, &predicted);
    eprintln!(
        "bundled arm, {} poses: worst distance {file:e} mm from predict, {memory:e} mm from the model",
        poses.len()
    );
    assert!(text.contains("<robot name=\"lrm-like\">"));
    assert!(text.contains("bundled arm `lrm`"), "{text}");
}

/// The bundled arm with an error in each of the 43 parameters: DH, base and
/// tool offsets of a few mm and degrees, and compliances.
fn calibrated_arm() -> (Arm<f64>, Arm<f64>) {
    let nominal = arm_source::bundled("lrm").unwrap().arm;
    let sizes = ErrorSizes {
        length_m: 5e-3,
        angle_rad: 0.05,
        compliance: 0.02..0.1,
    };
    let errors = random_errors(&mut StdRng::seed_from_u64(7), &sizes);
    let ids: Vec<ParamId> = ParamId::all(6).collect();
    (nominal, nominal.with_errors(&ids, &errors))
}

#[test]
fn calibrated_arm_urdf_puts_the_tool_where_predict_does_without_sag() {
    let dir = tempfile::tempdir().unwrap();
    let (nominal, calibrated) = calibrated_arm();
    let mut rigid = calibrated;
    rigid.base_compliance = 0.0;
    for joint in &mut rigid.joints {
        joint.compliance = 0.0;
    }
    let (cal, rigid_cal) = (dir.path().join("cal.json"), dir.path().join("rigid.json"));
    std::fs::write(
        &cal,
        calibration_json(&nominal, &calibrated, SCHEMA_VERSION),
    )
    .unwrap();
    std::fs::write(
        &rigid_cal,
        calibration_json(&nominal, &rigid, SCHEMA_VERSION),
    )
    .unwrap();

    let out = dir.path().join("cal.urdf");
    let text = export(&[
        "--calibration",
        s(&cal),
        "--out",
        s(&out),
        "--name",
        "my arm",
        "--world",
    ]);
    let poses = random_poses_deg(&calibrated, 300, 2);
    let list = pose_list(dir.path(), &poses);
    let predicted = predict(dir.path(), s(&rigid_cal), &list);
    let (file, memory) = check_against_predict(&text, &rigid, &poses, &predicted);
    eprintln!(
        "calibrated arm, {} poses: worst distance {file:e} mm from predict, {memory:e} mm from the model",
        poses.len()
    );

    // The compliances are not in the file: the compliant arm sags away from it.
    let sagging = predict(dir.path(), s(&cal), &list);
    let robot = urdf_rs::read_from_string(&text).unwrap();
    assert_eq!(robot.name, "my arm");
    let sag_mm = poses
        .iter()
        .zip(&sagging)
        .map(|(q, p)| {
            let q = q.map(f64::to_radians);
            (link_pose(&robot, "tool_point", &q).translation.vector - p).norm() * 1000.0
        })
        .fold(0.0, f64::max);
    assert!(sag_mm > 1.0, "largest sag {sag_mm} mm");

    // The header says where the arm came from and what the file lacks.
    let header = &text[..text.find("<robot").unwrap()];
    for needle in [
        "cal.json",
        "elasto-kinematic model",
        concat!("lrmcal ", env!("CARGO_PKG_VERSION")),
        "compliances",
        "servo curves",
        "position 0 is q = 0",
    ] {
        assert!(header.contains(needle), "`{needle}` missing from\n{header}");
    }
    let id = |header: &str| {
        let at = header.find("Calibration id ").expect("an id") + "Calibration id ".len();
        let id = header[at..at + 8].to_owned();
        assert!(id.chars().all(|c| c.is_ascii_hexdigit()), "{id}");
        id
    };
    // Another calibration has another id.
    let rigid_text = export(&["--calibration", s(&rigid_cal)]);
    assert_ne!(id(header), id(&rigid_text));

    // A calibration file given as --arm is exported the same way.
    assert_eq!(
        export(&["--arm", s(&cal), "--name", "my arm", "--world"]),
        text
    );
}

#[test]
fn bad_input_is_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("arm.urdf");
    let fails = |args: &[&str], code: i32| {
        let run = lrmcal(args);
        assert_eq!(run.status.code(), Some(code), "{args:?}: {}", stderr(&run));
        assert!(!out.exists(), "{args:?} wrote the output");
        stderr(&run)
    };

    let absent = dir.path().join("absent.json");
    let msg = fails(
        &[
            "export",
            "--urdf",
            "--calibration",
            s(&absent),
            "--out",
            s(&out),
        ],
        4,
    );
    assert!(msg.contains("absent.json"), "{msg}");

    let (nominal, calibrated) = calibrated_arm();
    let old = dir.path().join("old.json");
    std::fs::write(&old, calibration_json(&nominal, &calibrated, 99)).unwrap();
    let msg = fails(
        &[
            "export",
            "--urdf",
            "--calibration",
            s(&old),
            "--out",
            s(&out),
        ],
        3,
    );
    assert!(
        msg.contains("old.json") && msg.contains("schema_version") && msg.contains("99"),
        "{msg}"
    );

    let mut inverted = calibrated;
    inverted.joints[2].limits = [0.5, -0.5];
    let bad = dir.path().join("limits.json");
    std::fs::write(&bad, calibration_json(&nominal, &inverted, SCHEMA_VERSION)).unwrap();
    let msg = fails(&["export", "--urdf", "--arm", s(&bad), "--out", s(&out)], 3);
    assert!(
        msg.contains("limits.json") && msg.contains("joint 3"),
        "{msg}"
    );

    // Usage errors: no format, a payload below zero, a limit that is no speed.
    let msg = fails(&["export", "--out", s(&out)], 2);
    assert!(msg.contains("--urdf"), "{msg}");
    fails(
        &["export", "--urdf", "--payload-kg=-1", "--out", s(&out)],
        2,
    );
    fails(
        &[
            "export",
            "--urdf",
            "--velocity-rad-s",
            "0",
            "--out",
            s(&out),
        ],
        2,
    );
}

/// `--arm` with `--calibration` gives the joint names and bodies of the
/// arm the calibration is of: the bundled arm by name or a copy of its file
/// are taken, also when registration moved the nominal base and found the
/// tool; an edited copy is refused, naming both files and the field.
#[test]
fn the_arm_named_beside_a_calibration_must_be_its_nominal_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (mut nominal, calibrated) = calibrated_arm();
    nominal.base.xyz = [1.2, 0.04, -0.3];
    nominal.tool.xyz = [0.018, 0.002, 0.056];
    let cal = dir.path().join("cal.json");
    std::fs::write(
        &cal,
        calibration_json(&nominal, &calibrated, SCHEMA_VERSION),
    )
    .unwrap();
    let bundled = include_str!("../core/arms/lrm.toml");
    let copy = dir.path().join("copy.toml");
    std::fs::write(&copy, bundled).unwrap();
    let out = dir.path().join("arm.urdf");

    let by_name = export(&["--calibration", s(&cal), "--arm", "lrm"]);
    let by_copy = export(&["--calibration", s(&cal), "--arm", s(&copy)]);
    for text in [&by_name, &by_copy] {
        // The arm file's joint names and name, the calibration's geometry.
        assert!(
            text.contains("<joint name=\"shoulder\" type=\"revolute\">"),
            "{text}"
        );
        assert!(text.contains("<robot name=\"lrm-like\">"), "{text}");
    }

    // Joint 2's upper arm made 5 cm shorter.
    let edited = dir.path().join("edited.toml");
    let shorter = bundled.replacen("a = 0.17\n", "a = 0.12\n", 1);
    assert_ne!(shorter, bundled);
    std::fs::write(&edited, shorter).unwrap();
    let args = [
        "export",
        "--urdf",
        "--calibration",
        s(&cal),
        "--arm",
        s(&edited),
        "--out",
        s(&out),
    ];
    let run = lrmcal(&args);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    assert_eq!(
        stderr(&run).trim_end(),
        format!(
            "error: failed to use calibration `{}`: its nominal arm is not `{}`: joint 2's a \
             differs: 120 mm in `{}`, 170 mm in the calibration's nominal arm; pass --arm the arm \
             description it was identified from",
            cal.display(),
            edited.display(),
            edited.display()
        )
    );
    assert!(!out.exists());

    // Another calibration given as --arm stands for its nominal arm.
    let other = dir.path().join("other.json");
    let mut other_nominal = calibrated_arm().0;
    other_nominal.joints[3].mass = 0.3;
    std::fs::write(
        &other,
        calibration_json(&other_nominal, &calibrated, SCHEMA_VERSION),
    )
    .unwrap();
    let run = lrmcal(&[
        "export",
        "--urdf",
        "--calibration",
        s(&cal),
        "--arm",
        s(&other),
    ]);
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("joint 4's mass differs: 0.3 kg in calibration `"),
        "{}",
        stderr(&run)
    );
}

#[test]
fn help_teaches() {
    let sub = String::from_utf8(lrmcal(&["export", "--help"]).stdout).unwrap();
    for needle in ["--urdf", "--calibration", "Examples:", "tool0", "radians"] {
        assert!(sub.contains(needle), "`{needle}` missing from\n{sub}");
    }
}

/// What ROS tools need of the file, on the default export: the robot in its
/// own base frame, the arm file's joint names, masses and centres of mass
/// with positive definite inertias, geometry, the payload as a link.
#[test]
fn the_default_urdf_stands_in_its_base_frame_with_names_masses_and_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let description = arm_source::bundled("lrm").unwrap();
    let arm = description.arm;
    let text = export(&["--payload-kg", "0.0663"]);
    let robot = urdf_rs::read_from_string(&text).unwrap();
    assert_eq!(robot.name, description.name);
    assert!(robot.links.iter().all(|l| l.name != "world"));

    // The tool point in the base frame: predict's, carried into it.
    let poses = random_poses_deg(&arm, 50, 3);
    let list = pose_list(dir.path(), &poses);
    let base = arm.base.isometry();
    for (q_deg, p) in poses.iter().zip(predict(dir.path(), "lrm", &list)) {
        let q = q_deg.map(f64::to_radians);
        let in_base = base.inverse_transform_point(&p.into()).coords;
        let urdf = link_pose(&robot, "tool_point", &q).translation.vector;
        assert!((urdf - in_base).norm() < 1e-9, "{q_deg:?}");
    }

    // Joint names are the arm file's, in chain order.
    for (i, name) in description.joint_names.iter().enumerate() {
        let j = robot.joints.iter().find(|j| &j.name == name).unwrap();
        assert_eq!(j.child.link, format!("link_{}", i + 1));
    }
    // Every link with a mass carries it, the payload too; inertias are
    // positive definite and every link has geometry.
    let masses: f64 = robot.links.iter().map(|l| l.inertial.mass.value).sum();
    let expected: f64 = arm.joints.iter().map(|j| j.mass).sum::<f64>() + 0.0663;
    assert!((masses - expected).abs() < 1e-12, "{masses} vs {expected}");
    for link in &robot.links {
        let i = &link.inertial.inertia;
        let tensor = nalgebra::Matrix3::new(
            i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz,
        );
        if link.inertial.mass.value > 0.0 {
            assert!(tensor.cholesky().is_some(), "{}: {tensor}", link.name);
        }
    }
    // Every body of the arm is on the link it moves with.
    let bodies = lrmcal_core::collision::BodySet::for_arm(&arm, &description.collision).unwrap();
    for body in bodies.bodies() {
        let name = match body.links[0] {
            0 => "base_link".to_owned(),
            k => format!("link_{k}"),
        };
        let link = robot.links.iter().find(|l| l.name == name).unwrap();
        assert!(
            !link.visual.is_empty() && link.visual.len() == link.collision.len(),
            "{}: {name}",
            body.name
        );
    }
    for i in 1..=JOINTS {
        let link = robot
            .links
            .iter()
            .find(|l| l.name == format!("link_{i}"))
            .unwrap();
        // Link i's centre of mass is the arm file's, in DH frame i.
        let q = [0.0; JOINTS];
        let com =
            link_pose(&robot, &link.name, &q) * nalgebra::Point3::from(link.inertial.origin.xyz.0);
        let frames = arm.chain().frames(&q, 0.0).frames;
        let want = base.inverse() * frames[i] * nalgebra::Point3::from(arm.joints[i - 1].com);
        assert!((com - want).norm() < 1e-12, "link_{i}");
    }
    let payload = robot
        .joints
        .iter()
        .find(|j| j.child.link == "payload")
        .unwrap();
    assert_eq!(payload.parent.link, "tool_point");
    assert_eq!(payload.origin.xyz.0, arm.payload_com);
}

/// A calibration registered in a Y-up tracker frame: in its base frame the
/// arm stands upright; rooted at the tracker's frame (`--world`) it would
/// lie on its side in ROS's Z-up world, and the export says so.
#[test]
fn a_urdf_that_would_stand_tilted_in_ros_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let nominal = arm_source::bundled("lrm").unwrap().arm;
    let mut y_up = nominal;
    y_up.base.rpy = [-std::f64::consts::FRAC_PI_2, 0.0, 0.0];
    y_up.gravity = [0.0, -9.81, 0.0];
    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, calibration_json(&nominal, &y_up, SCHEMA_VERSION)).unwrap();
    let run = lrmcal(&["export", "--urdf", "--calibration", s(&cal)]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(!stderr(&run).contains("warning"), "{}", stderr(&run));
    let run = lrmcal(&["export", "--urdf", "--calibration", s(&cal), "--world"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let text = stderr(&run);
    assert!(
        text.contains("warning: gravity") && text.contains("90.0° off the -z axis of world"),
        "{text}"
    );
}
