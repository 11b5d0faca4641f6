//! Tests of `plan`.

use super::*;
use crate::sim::test_support::bundled_arm;
use lrmcal_core::collision::{Body, BodySpec, FrameRef, PointSpec, Shape, ShapeSpec};
use model::testing::TEST_ARM_JOINTS as JOINTS;

fn deg(q: [f64; JOINTS]) -> [f64; JOINTS] {
    q.map(f64::to_radians)
}

/// The self-collision test of the default settings (no floor).
fn contact(arm: &Arm<f64>, q: [f64; JOINTS]) -> Option<Contact> {
    let config = PlanConfig {
        ground_z_m: None,
        ..PlanConfig::default()
    };
    config.contact(&arm.chain().frames(&deg(q), 0.0))
}

fn names(set: &BodySet) -> Vec<&str> {
    set.bodies().iter().map(|b| b.name.as_str()).collect()
}

fn pair_names(set: &BodySet) -> Vec<[&str; 2]> {
    let name = |i: usize| set.bodies()[i].name.as_str();
    set.tested_pairs()
        .iter()
        .map(|&[i, j]| [name(i), name(j)])
        .collect()
}

fn capsule(name: &str, from: &str, to: &str, radius_m: f64) -> BodySpec {
    BodySpec {
        name: name.into(),
        shape: ShapeSpec::Capsule {
            from: PointSpec::origin(from.parse().unwrap()),
            to: PointSpec::origin(to.parse().unwrap()),
            radius_m,
        },
        floor: None,
    }
}

/// The bodies the planner had built in for the bundled arm, as an arm file would list them.
fn bundled_bodies() -> Vec<BodySpec> {
    vec![
        capsule("base", "base", "j1", 0.04),
        capsule("upper arm", "j1", "j2", 0.025),
        capsule("forearm", "j3", "j4", 0.025),
        capsule("hand", "j5", "j6", 0.025),
        capsule("target", "j6", "tool", 0.015),
    ]
}

/// The bundled arm with other proportions: lengths scaled by 0.8-1.3
/// and the hand's length moved from `d6` into the tool offset, so the
/// tool capsule starts at the wrist centre.
fn other_elbow_arm() -> Arm<f64> {
    let mut arm = bundled_arm();
    let j = &mut arm.joints;
    j[0].d *= 1.2;
    j[1].a *= 1.3;
    j[3].d *= 0.8;
    arm.tool.xyz[2] += j[5].d * 1.1;
    j[5].d = 0.0;
    arm
}

/// The yardstick: segments between consecutive frame origins
/// (and on to the tool point), no radius, 4 cm from the floor and
/// between segments that do not share an end.
fn skeleton_yardstick_kept(arm: &Arm<f64>) -> usize {
    use parry3d_f64::shape::Segment;
    let chain = arm.chain();
    let id = nalgebra::Isometry3::identity();
    Levels::paper()
        .grid(6)
        .filter(|pose| {
            let f = chain.frames(&pose.q, 0.0);
            let mut points: Vec<_> = f.frames.iter().map(|fr| fr.translation.vector).collect();
            points.push(f.tool_point);
            points.dedup_by(|a, b| (*a - *b).norm() < 1e-9);
            let segment = |k: usize| Segment::new(points[k].into(), points[k + 1].into());
            let n = points.len() - 1;
            points[1..].iter().all(|p| p.z >= 0.04)
                && (0..n).all(|a| {
                    (a + 2..n).all(|b| {
                        parry3d_f64::query::distance(&id, &segment(a), &id, &segment(b))
                            .is_ok_and(|d| d >= 0.04)
                    })
                })
        })
        .count()
}

#[test]
fn bundled_arm_keeps_about_half_of_the_paper_grid() {
    let report = candidates(&bundled_arm(), &PlanConfig::default()).unwrap();
    assert_eq!(report.grid_size, 729);
    assert_eq!(report.kept.len(), 405);
    assert_eq!(report.kept.len() + report.dropped.len(), 729);
    let counts = report.counts();
    assert_eq!(
        counts,
        DropCounts {
            joint_limits: 0,
            ground: 324,
            self_collision: 0,
            camera: 0
        }
    );
    // The home pose (arm straight up) survives; ids are grid ids in grid order.
    assert!(
        report
            .kept
            .iter()
            .any(|p| p.id == 364 && p.q == [0.0; JOINTS])
    );
    assert!(report.kept.windows(2).all(|w| w[0].id < w[1].id));
    // Shoulder down, elbow straight: the forearm reaches the ground.
    let low = report
        .dropped
        .iter()
        .find(|d| d.pose.q == deg([0.0, 100.0, 0.0, 0.0, 0.0, 0.0]))
        .unwrap();
    assert_eq!(
        low.reason,
        DropReason::Collision(Contact::Ground {
            body: "link 4".into()
        })
    );
    let text = report.to_string();
    assert!(
        text.starts_with("405 of 729 grid poses kept, 324 dropped"),
        "{text}"
    );
    assert!(
        text.contains("324  link 4 too close to the ground"),
        "{text}"
    );
    // The arm file's description without bodies is the same skeleton.
    let config = PlanConfig::for_arm(&bundled_arm(), &CollisionSpec::default()).unwrap();
    assert_eq!(candidates(&bundled_arm(), &config).unwrap(), report);
}

#[test]
fn the_bundled_skeleton_is_the_arm_the_planner_had_built_in() {
    let arm = bundled_arm();
    let skeleton = BodySet::skeleton(&arm.chain().frames(&[0.0; JOINTS], 0.0), None);
    // Links 3 and 5 have no length: no bodies.
    assert_eq!(
        names(&skeleton),
        ["link 1", "link 2", "link 4", "link 6", "tool"]
    );
    let radius = |b: &Body| match b.shapes[0] {
        Shape::Capsule { radius_m, .. } => radius_m,
        Shape::Box { .. } => panic!("a box in the skeleton"),
    };
    // A twentieth of 0.49 m of links; the tool half that.
    let b = skeleton.bodies();
    assert!((radius(&b[1]) - 0.0245).abs() < 1e-12);
    assert!((radius(&b[4]) - 0.01225).abs() < 1e-12);
    assert_eq!(
        b.iter().map(|b| b.floor).collect::<Vec<_>>(),
        [false, true, true, true, true]
    );
    // The upper arm and forearm meet at the elbow, forearm and hand at the
    // wrist: never tested. The tool starts 6 cm past the wrist: tested.
    let expected = [
        ["link 1", "link 4"],
        ["link 1", "link 6"],
        ["link 1", "tool"],
        ["link 2", "link 6"],
        ["link 2", "tool"],
        ["link 4", "tool"],
    ];
    assert_eq!(pair_names(&skeleton), expected);
    // The old built-in bodies, written as an arm file would, pair up the same way and keep the same poses.
    let spec = CollisionSpec {
        bodies: bundled_bodies(),
        ..CollisionSpec::default()
    };
    let listed = BodySet::for_arm(&arm, &spec).unwrap();
    let renamed: Vec<[&str; 2]> = pair_names(&listed)
        .iter()
        .map(|p| {
            p.map(|n| match n {
                "base" => "link 1",
                "upper arm" => "link 2",
                "forearm" => "link 4",
                "hand" => "link 6",
                _ => "tool",
            })
        })
        .collect();
    assert_eq!(renamed, expected);
    let config = PlanConfig::for_arm(&arm, &spec).unwrap();
    let report = candidates(&arm, &config).unwrap();
    assert_eq!(report.kept.len(), 405);
    assert!(
        report
            .to_string()
            .contains("324  forearm too close to the ground")
    );
}

#[test]
fn an_elbow_arm_of_other_proportions_keeps_what_a_skeleton_test_keeps() {
    let arm = other_elbow_arm();
    let report = candidates(&arm, &PlanConfig::default()).unwrap();
    let yardstick = skeleton_yardstick_kept(&arm);
    let kept = report.kept.len();
    // Built-in fixed-frame volumes kept none of this arm's poses: their
    // "target" began at frame 6, here the wrist centre, on the forearm.
    assert!(kept > 729 / 2, "{report}");
    let ratio = kept as f64 / yardstick as f64;
    assert!(
        (0.85..=1.2).contains(&ratio),
        "{kept} vs {yardstick}\n{report}"
    );
    // The tool meets the forearm at the wrist centre: that pair is not tested.
    let skeleton = BodySet::skeleton(&arm.chain().frames(&[0.0; JOINTS], 0.0), None);
    assert_eq!(names(&skeleton), ["link 1", "link 2", "link 4", "tool"]);
    assert!(!pair_names(&skeleton).contains(&["link 4", "tool"]));
    // And on the bundled arm the two tests agree exactly.
    assert_eq!(skeleton_yardstick_kept(&bundled_arm()), 405);
}

#[test]
fn every_kept_pose_is_clear_of_ground_and_itself() {
    let arm = bundled_arm();
    let config = PlanConfig::default();
    let chain = arm.chain();
    let bodies = BodySet::skeleton(&chain.frames(&[0.0; JOINTS], 0.0), None);
    for pose in candidates(&arm, &config).unwrap().kept {
        let frames = chain.frames(&pose.q, 0.0);
        assert_eq!(bodies.self_contact(&frames, config.clearance_m), None);
        for b in bodies.bodies().iter().filter(|b| b.floor) {
            for shape in &b.shapes {
                let Shape::Capsule { from, to, radius_m } = shape else {
                    panic!("a box in the skeleton")
                };
                for end in [from, to] {
                    assert!(
                        end.position(&frames).z - radius_m >= 0.01,
                        "pose {}",
                        pose.id
                    );
                }
            }
        }
    }
}

#[test]
fn folded_poses_collide_and_the_home_pose_does_not() {
    let arm = bundled_arm();
    assert_eq!(contact(&arm, [0.0; JOINTS]), None);
    // Elbow folded right back: the wrist comes down onto the shoulder and the hand into the base.
    for elbow in [170.0, -170.0] {
        assert!(
            matches!(
                contact(&arm, [0.0, 0.0, elbow, 0.0, 0.0, 0.0]),
                Some(Contact::SelfCollision { .. })
            ),
            "elbow {elbow}"
        );
    }
    // Elbow folded to 150°, wrist bent back towards the upper arm.
    let c = contact(&arm, [0.0, 0.0, 150.0, 0.0, 90.0, 0.0])
        .or(contact(&arm, [0.0, 0.0, 150.0, 0.0, -90.0, 0.0]));
    assert!(matches!(c, Some(Contact::SelfCollision { .. })), "{c:?}");
    // A wide clearance makes a pose that is fine at 10 mm collide.
    let frames = arm
        .chain()
        .frames(&deg([0.0, 0.0, 100.0, 0.0, 100.0, 0.0]), 0.0);
    let bodies = BodySet::skeleton(&frames, None);
    assert_eq!(bodies.self_contact(&frames, 0.01), None);
    assert!(bodies.self_contact(&frames, 0.08).is_some());
}

#[test]
fn self_collision_counts_when_the_limits_allow_folding() {
    let mut arm = bundled_arm();
    for j in &mut arm.joints {
        j.limits = [-3.0, 3.0];
    }
    let config = PlanConfig {
        levels: "-170,0,170".parse().unwrap(),
        ground_z_m: None,
        ..PlanConfig::default()
    };
    let report = candidates(&arm, &config).unwrap();
    let counts = report.counts();
    assert_eq!(counts.ground, 0);
    assert_eq!(counts.joint_limits, 0);
    assert!(counts.self_collision > 100, "{counts:?}");
    assert!(report.dropped.iter().all(|d| matches!(
        d.reason,
        DropReason::Collision(Contact::SelfCollision { .. })
    )));
}

#[test]
fn joint_limits_are_tested_first_and_name_the_joint() {
    let mut arm = bundled_arm();
    arm.joints[2].limits = [-1.0, 1.0];
    let report = candidates(&arm, &PlanConfig::default()).unwrap();
    // q3 at ±100° is out: two thirds of the grid, whatever else they hit.
    assert_eq!(report.counts().joint_limits, 486);
    assert!(
        report
            .dropped
            .iter()
            .all(|d| d.reason != DropReason::JointLimits { joint: 1 })
    );
    assert!(
        report
            .dropped
            .iter()
            .any(|d| d.reason == DropReason::JointLimits { joint: 3 })
    );
    // Limits are inclusive: a level exactly on the limit is kept.
    arm.joints[2].limits = [-100f64.to_radians(), 100f64.to_radians()];
    assert_eq!(
        candidates(&arm, &PlanConfig::default())
            .unwrap()
            .counts()
            .joint_limits,
        0
    );
}

#[test]
fn the_ground_plane_moves_and_switches_off() {
    let arm = bundled_arm();
    let plan = |ground_z_m| {
        candidates(
            &arm,
            &PlanConfig {
                ground_z_m,
                ..PlanConfig::default()
            },
        )
        .unwrap()
    };
    let kept = |ground_z_m| plan(ground_z_m).kept.len();
    // Without the ground, poses that reached below it into the base show up as self-collisions.
    let counts = plan(None).counts();
    assert_eq!(counts.ground, 0);
    assert!(counts.self_collision > 0);
    assert_eq!(kept(None), 729 - counts.self_collision);
    assert!(kept(Some(0.1)) < 405);
    assert!(kept(Some(-0.2)) > 405);
    // The arm file's floor is the same setting.
    let spec = |floor| CollisionSpec {
        floor,
        ..CollisionSpec::default()
    };
    for (floor, z) in [(Floor::Off, None), (Floor::At { z_m: 0.1 }, Some(0.1))] {
        let config = PlanConfig::for_arm(&arm, &spec(floor)).unwrap();
        assert_eq!(candidates(&arm, &config).unwrap().kept.len(), kept(z));
    }
}

#[test]
fn finer_grids_are_filtered_too() {
    let config = PlanConfig {
        levels: Levels::even(4).unwrap(),
        ..PlanConfig::default()
    };
    let report = candidates(&bundled_arm(), &config).unwrap();
    assert_eq!(report.grid_size, 4096);
    assert_eq!(report.kept.len() + report.dropped.len(), 4096);
    assert!(
        report.kept.len() > 1000 && report.dropped.len() > 1000,
        "{}",
        report
    );
}

#[test]
fn boxes_and_tool_frame_points_sit_where_the_file_puts_them() {
    let mut arm = bundled_arm();
    // A tool frame turned a quarter turn about x: its y axis is frame 6's z.
    arm.tool.rpy = [std::f64::consts::FRAC_PI_2, 0.0, 0.0];
    let spec = CollisionSpec {
        bodies: vec![
            // A 20 x 20 x 2 cm plate under the base frame.
            BodySpec {
                name: "plate".into(),
                shape: ShapeSpec::Box {
                    frame: FrameRef::Dh(0),
                    min_m: [-0.1, -0.1, -0.02],
                    max_m: [0.1, 0.1, 0.0],
                },
                floor: None,
            },
            capsule("upper arm", "j1", "j2", 0.025),
            // A 4 cm cube gripper 3 cm along the tool frame's y axis.
            BodySpec {
                name: "gripper".into(),
                shape: ShapeSpec::Box {
                    frame: FrameRef::Tool,
                    min_m: [-0.02, 0.01, -0.02],
                    max_m: [0.02, 0.05, 0.02],
                },
                floor: None,
            },
        ],
        ..CollisionSpec::default()
    };
    let set = BodySet::for_arm(&arm, &spec).unwrap();
    // The plate is fixed to the base: no floor test; the gripper is.
    assert_eq!(
        set.bodies().iter().map(|b| b.floor).collect::<Vec<_>>(),
        [false, true, true]
    );
    // The upper arm can swing down onto the plate: two links apart, tested.
    assert_eq!(
        pair_names(&set),
        [
            ["plate", "upper arm"],
            ["plate", "gripper"],
            ["upper arm", "gripper"]
        ]
    );
    let chain = arm.chain();
    // Home pose: the gripper's centre is 3 cm above the tool point (frame 6's z points up).
    let frames = chain.frames(&[0.0; JOINTS], 0.0);
    let Shape::Box {
        frame, placement, ..
    } = set.bodies()[2].shapes[0]
    else {
        panic!("the gripper is a box")
    };
    let centre = (frames.frames[frame] * placement).translation.vector;
    assert!((centre - (frames.tool_point + nalgebra::Vector3::new(0.0, 0.0, 0.03))).norm() < 1e-12);
    assert_eq!(set.floor_contact(&frames, 0.0, 0.01), None);
    assert_eq!(set.self_contact(&frames, 0.01), None);
    // The gripper's low face is 2 cm below its centre (the tool frame's
    // z is horizontal here): a floor up to the clearance below it touches.
    let gripper = CollisionSpec {
        bodies: vec![spec.bodies[2].clone()],
        ..CollisionSpec::default()
    };
    let gripper = BodySet::for_arm(&arm, &gripper).unwrap();
    let low = centre.z - 0.02;
    assert_eq!(gripper.floor_contact(&frames, low - 0.011, 0.01), None);
    assert!(gripper.floor_contact(&frames, low - 0.009, 0.01).is_some());
}

#[test]
fn ignored_pairs_are_not_tested() {
    let arm = bundled_arm();
    let ignore = |pairs: &[[&str; 2]]| CollisionSpec {
        ignore: pairs.iter().map(|p| p.map(String::from)).collect(),
        ..CollisionSpec::default()
    };
    let set = BodySet::for_arm(&arm, &ignore(&[["tool", "link 1"]])).unwrap();
    assert_eq!(pair_names(&set).len(), 5);
    assert!(!pair_names(&set).contains(&["link 1", "tool"]));
    // Ignoring a pair that is not tested anyway changes nothing.
    let set = BodySet::for_arm(&arm, &ignore(&[["link 2", "link 4"]])).unwrap();
    assert_eq!(pair_names(&set).len(), 6);
}

#[test]
fn bad_descriptions_name_the_key() {
    let arm = bundled_arm();
    let err = |spec: CollisionSpec| BodySet::for_arm(&arm, &spec).unwrap_err().to_string();
    let bodies = |bodies| CollisionSpec {
        bodies,
        ..CollisionSpec::default()
    };
    // A capsule from the shoulder to the wrist would bend with the elbow.
    let e = err(bodies(vec![capsule("arm", "j1", "j4", 0.03)]));
    assert!(
        e.starts_with("`body[1].capsule`:")
            && e.contains("links 1 and 2")
            && e.contains("links 4 and 5"),
        "{e}"
    );
    let e = err(bodies(vec![
        capsule("a", "j1", "j2", 0.03),
        capsule("a", "j3", "j4", 0.03),
    ]));
    assert!(
        e.starts_with("`body[2].name`:") && e.contains("body[1]"),
        "{e}"
    );
    let e = err(bodies(vec![capsule("a", "j1", "j2", -0.03)]));
    assert!(
        e.starts_with("`body[1].capsule.radius`:") && e.contains("-0.03"),
        "{e}"
    );
    let e = err(bodies(vec![BodySpec {
        name: "plate".into(),
        shape: ShapeSpec::Box {
            frame: FrameRef::Dh(0),
            min_m: [0.0, 0.1, 0.0],
            max_m: [0.1, 0.0, 0.1],
        },
        floor: None,
    }]));
    assert!(e.starts_with("`body[1].box`:") && e.contains("on y"), "{e}");
    let e = err(CollisionSpec {
        ignore: vec![["link 1".into(), "link 3".into()]],
        ..CollisionSpec::default()
    });
    assert!(
        e.starts_with("`collision.ignore[1]`:")
            && e.contains("`link 3`")
            && e.contains("link 4, link 6, tool"),
        "{e}"
    );
    let e = err(CollisionSpec {
        skeleton_radius_m: Some(0.02),
        ..bodies(bundled_bodies())
    });
    assert!(e.starts_with("`collision.radius`:"), "{e}");
}

#[test]
fn bad_settings_are_named() {
    let arm = bundled_arm();
    let err = candidates(
        &arm,
        &PlanConfig {
            clearance_m: -0.01,
            ..PlanConfig::default()
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("clearance_m"), "{err}");
    let err = candidates(
        &arm,
        &PlanConfig {
            ground_z_m: Some(f64::NAN),
            ..PlanConfig::default()
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("ground_z_m"), "{err}");
    let bodies = BodySet::skeleton(&arm.chain().frames(&[0.0; JOINTS], 0.0), Some(f64::NAN));
    let err = candidates(
        &arm,
        &PlanConfig {
            bodies: Some(bodies),
            ..PlanConfig::default()
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("`link 1`"), "{err}");
    let mut bad = arm;
    bad.joints[0].d = f64::INFINITY;
    assert_eq!(
        candidates(&bad, &PlanConfig::default()).unwrap_err(),
        PlanError::NominalNotFinite
    );
}

/// The bundled SO-101's grid: its arm file's -90/0/+90° on five joints, 243
/// poses, none past its limits (the paper's ±100° would leave elbow_flex's
/// and wrist_flex's), 117 clear of the table and of each other.
#[test]
fn the_so101_grid_is_its_arm_files_levels_within_its_limits() {
    let loaded = lrmcal_core::io::arm_source::ArmSource::Bundled("so101")
        .load()
        .unwrap();
    let config = PlanConfig::for_loaded(&loaded).unwrap();
    assert_eq!(config.levels.to_string(), "-90,0,90");
    let report = candidates(&loaded.arm, &config).unwrap();
    assert_eq!(report.grid_size, 243);
    let counts = report.counts();
    assert_eq!(counts.joint_limits, 0, "{report}");
    assert_eq!(report.kept.len(), 117, "{report}");
    let paper = PlanConfig {
        levels: Levels::paper(),
        ..config
    };
    let report = candidates(&loaded.arm, &paper).unwrap();
    assert_eq!(report.counts().joint_limits, 216, "{report}");
}
