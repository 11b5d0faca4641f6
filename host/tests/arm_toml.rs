//! The arm description file: the fixture and the bundled arm parse, writing
//! round-trips, and every kind of bad input gives an error that names the
//! file, the key path and the line, and says what was expected.

use host::error::InputError;
use lrmcal_core::io::arm_source::{self, ArmSource};
use lrmcal_core::io::arm_toml;

const FIXTURE: &str = include_str!("data/arm.toml");

/// Line of `joint[3].mass` in the fixture (joints start at line 18, 12 lines each).
const J3_MASS_LINE: usize = 50;

/// The fixture with its 1-based line `line` replaced by `text`.
fn with_line(line: usize, text: &str) -> String {
    let mut lines: Vec<&str> = FIXTURE.lines().collect();
    lines[line - 1] = text;
    lines.join("\n")
}

fn parse_err(text: &str) -> InputError {
    arm_toml::parse(text).expect_err("the edited fixture must be rejected")
}

/// Asserts the message names the key and the line, and contains each of `words`.
fn assert_names(err: &InputError, key: &str, line: usize, words: &[&str]) {
    let msg = err.to_string();
    assert!(
        msg.contains(&format!("key `{key}`")),
        "no key `{key}` in: {msg}"
    );
    assert!(
        msg.contains(&format!("line {line}")),
        "no line {line} in: {msg}"
    );
    for w in words {
        assert!(msg.contains(w), "no `{w}` in: {msg}");
    }
}

#[test]
fn fixture_parses_into_the_model() {
    let d = arm_toml::parse(FIXTURE).unwrap();
    assert_eq!(d.name, "fixture");
    assert_eq!(d.joint_names[3], "j4");
    assert_eq!(d.arm.joints[1].a, 0.17);
    assert_eq!(d.arm.joints[2].mass, 0.1);
    assert_eq!(d.arm.base_compliance, 0.02);
    assert_eq!(d.arm.tool.xyz, [0.0, 0.0, 0.04]);
    assert_eq!(d.arm.gravity, [0.0, 0.0, -9.80665]);
    assert_eq!(
        d.arm.joints[5].servo.unwrap().pulses_us(),
        [900.0, 1650.0, 2400.0]
    );
}

#[test]
fn bundled_arm_parses_and_is_the_default() {
    let d = arm_source::bundled("lrm").unwrap();
    assert!(d.arm.is_finite());
    assert_eq!(
        arm_source::DEFAULT_ARM.parse::<ArmSource>(),
        Ok(ArmSource::Bundled("lrm"))
    );
    let loaded = ArmSource::Bundled("lrm").load().unwrap();
    assert_eq!(loaded.arm, d.arm);
}

#[test]
fn arm_source_rejects_unknown_kinds_of_file() {
    let err = "calibration.yaml".parse::<ArmSource>().unwrap_err();
    assert!(err.contains(".toml") && err.contains("lrm"), "{err}");
    assert!(arm_source::bundled("nope").is_err());
}

#[test]
fn writing_round_trips() {
    let d = arm_toml::parse(FIXTURE).unwrap();
    let text = arm_toml::to_toml(&d);
    assert_eq!(arm_toml::parse(&text).unwrap(), d);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("arm.toml");
    arm_toml::write(&path, &d).unwrap();
    assert_eq!(arm_toml::read(&path).unwrap(), d);
    // Loaded through --arm as a user would.
    let source: ArmSource = path.to_str().unwrap().parse().unwrap();
    assert_eq!(source.load().unwrap().arm, d.arm);
}

#[test]
fn file_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad_arm.toml");
    std::fs::write(&path, with_line(J3_MASS_LINE, "mass = -0.1")).unwrap();
    let msg = arm_toml::read(&path).unwrap_err().report();
    assert!(msg.contains("bad_arm.toml"), "{msg}");
    assert!(
        msg.contains("joint[3].mass") && msg.contains("line 50"),
        "{msg}"
    );

    let missing = dir.path().join("absent.toml");
    let err = arm_toml::read(&missing).unwrap_err();
    assert!(err.is_access());
    assert!(err.report().contains("absent.toml"));
}

#[test]
fn missing_field_names_the_joint_and_the_key() {
    let err = parse_err(&with_line(J3_MASS_LINE, ""));
    let msg = err.to_string();
    assert!(
        msg.contains("key `joint[3]`") && msg.contains("mass"),
        "{msg}"
    );
    assert!(err.location.line.is_some(), "{msg}");
}

#[test]
fn missing_section_is_reported() {
    let text = FIXTURE.replace("[payload]\ncom = [0.0, 0.0, 0.0]\n", "");
    let msg = parse_err(&text).to_string();
    assert!(msg.contains("payload"), "{msg}");
}

#[test]
fn unknown_key_is_rejected() {
    let err = parse_err(&with_line(J3_MASS_LINE, "mass = 0.1\nmasss = 0.2"));
    let msg = err.to_string();
    assert!(msg.contains("masss") && msg.contains("joint[3]"), "{msg}");
    assert_eq!(err.location.line, Some(51), "{msg}");
}

#[test]
fn any_number_of_joints_up_to_ten_reads_and_more_is_rejected() {
    // Drop the sixth joint (its table starts at line 78): a five-joint arm.
    let text: String = FIXTURE.lines().take(77).collect::<Vec<_>>().join("\n");
    let five = arm_toml::parse(&text).unwrap();
    assert_eq!(five.arm.joints.len(), 5);
    assert_eq!(five.joint_names.len(), 5);
    // Eleven joints: the first joint's table five more times.
    let first_joint: Vec<&str> = FIXTURE.lines().skip(17).take(12).collect();
    let mut text = FIXTURE.to_string();
    for _ in 0..5 {
        text = format!("{text}\n{}\n", first_joint.join("\n"));
    }
    let msg = parse_err(&text).to_string();
    assert!(
        msg.contains("1 to 10 [[joint]]") && msg.contains("found 11"),
        "{msg}"
    );
    assert!(msg.contains("key `joint`"), "{msg}");
    // A prismatic joint says so; anything else is refused with the line.
    // Its compliance is in m/N, bounded as a length (50 mm under the
    // weight it carries): 0.05 m/N is refused, 1e-4 m/N reads.
    let text = FIXTURE.replacen("[[joint]]\n", "[[joint]]\ntype = \"prismatic\"\n", 1);
    let msg = parse_err(&text).to_string();
    assert!(msg.contains("joint[1].compliance"), "{msg}");
    let text = text.replacen("compliance = 0.05", "compliance = 0.0001", 1);
    let lift = arm_toml::parse(&text).unwrap();
    assert_eq!(lift.arm.joints[0].kind, model::JointKind::Prismatic);
    let text = FIXTURE.replacen("[[joint]]\n", "[[joint]]\ntype = \"ball\"\n", 1);
    let msg = parse_err(&text).to_string();
    assert!(msg.contains("ball") && msg.contains("prismatic"), "{msg}");
}

#[test]
fn nan_and_infinity_are_rejected() {
    let err = parse_err(&with_line(J3_MASS_LINE, "mass = nan"));
    assert_names(&err, "joint[3].mass", J3_MASS_LINE, &["finite", "NaN"]);

    let err = parse_err(&with_line(7, "xyz = [0.0, inf, 0.0]"));
    assert_names(&err, "base.xyz[2]", 7, &["finite", "inf"]);

    let err = parse_err(&with_line(
        J3_MASS_LINE + 2,
        "servo = { minus100 = 900.0, zero = nan, plus100 = 2400.0 }",
    ));
    assert_names(&err, "joint[3].servo", J3_MASS_LINE + 2, &["finite"]);
}

#[test]
fn negative_mass_and_compliance_are_rejected() {
    let err = parse_err(&with_line(J3_MASS_LINE, "mass = -0.1"));
    assert_names(
        &err,
        "joint[3].mass",
        J3_MASS_LINE,
        &["mass >= 0 kg", "-0.1"],
    );

    let err = parse_err(&with_line(J3_MASS_LINE - 2, "compliance = -0.01"));
    assert_names(
        &err,
        "joint[3].compliance",
        J3_MASS_LINE - 2,
        &["compliance >= 0 rad/Nm"],
    );

    let err = parse_err(&with_line(9, "compliance = -1.0"));
    assert_names(&err, "base.compliance", 9, &["compliance >= 0"]);
}

#[test]
fn limits_must_be_ordered() {
    let err = parse_err(&with_line(J3_MASS_LINE - 1, "limits = [1.0, -1.0]"));
    assert_names(
        &err,
        "joint[3].limits",
        J3_MASS_LINE - 1,
        &["lo < hi", "[1, -1]"],
    );
}

#[test]
fn servo_curve_must_be_monotonic() {
    let line = "servo = { minus100 = 900.0, zero = 2500.0, plus100 = 2400.0 }";
    let err = parse_err(&with_line(J3_MASS_LINE + 2, line));
    assert_names(
        &err,
        "joint[3].servo",
        J3_MASS_LINE + 2,
        &["monotonic", "900 / 2500 / 2400"],
    );
    // A servo mounted the other way round runs backwards: still monotonic, accepted.
    let reversed = "servo = { minus100 = 2400.0, zero = 1650.0, plus100 = 900.0 }";
    assert!(arm_toml::parse(&with_line(J3_MASS_LINE + 2, reversed)).is_ok());
}

#[test]
fn the_three_points_read_as_before_and_as_the_knots_through_them() {
    let old = arm_toml::parse(FIXTURE).unwrap();
    let curve = old.arm.joints[2].servo.unwrap();
    assert_eq!(
        curve,
        model::ServoCurve::from_three_points(900.0, 1650.0, 2400.0)
    );
    // Bit for bit the pulses of the two lines the three points used to mean.
    let (m, z, p) = (900.0, 1650.0, 2400.0);
    let span = 100f64.to_radians();
    for a in [-2.0, -1.2, -0.3, 0.0, 0.4, 1.7, 2.0] {
        let slope = if a < 0.0 {
            (z - m) / span
        } else {
            (p - z) / span
        };
        let lines: f64 = z + slope * a;
        assert_eq!(curve.pulse_us(a).to_bits(), lines.to_bits(), "at {a}");
    }
    let knots = "servo = { angles_deg = [-100, 0, 100], pulses_us = [900, 1650, 2400] }";
    let new = arm_toml::parse(&with_line(J3_MASS_LINE + 2, knots)).unwrap();
    assert_eq!(new, old);
}

#[test]
fn a_servo_curve_of_many_knots_reads_and_round_trips() {
    let line = "servo = { angles_deg = [-100.0, -50.0, 0.0, 33.3, 100.0], \
                pulses_us = [2400.0, 2010.0, 1650.0, 1400.0, 900.0] }";
    let d = arm_toml::parse(&with_line(J3_MASS_LINE + 2, line)).unwrap();
    let curve = d.arm.joints[2].servo.unwrap();
    assert_eq!(curve.knot_count(), 5);
    assert_eq!(curve.angles_rad()[3], 33.3f64.to_radians());
    assert_eq!(curve.pulse_us(0.0), 1650.0);
    let text = arm_toml::to_toml(&d);
    assert!(
        text.contains("angles_deg = [-100.0, -50.0, 0.0, 33.3, 100.0]"),
        "{text}"
    );
    assert_eq!(arm_toml::parse(&text).unwrap(), d);
}

#[test]
fn bad_servo_knots_name_the_key() {
    let servo = |body: &str| {
        parse_err(&with_line(
            J3_MASS_LINE + 2,
            &format!("servo = {{ {body} }}"),
        ))
    };
    let line = J3_MASS_LINE + 2;
    let e = servo("angles_deg = [-100, 0, 100], pulses_us = [900, 1650]");
    assert_names(
        &e,
        "joint[3].servo.pulses_us",
        line,
        &["one pulse", "2 pulses for 3 angles"],
    );
    let e = servo("angles_deg = [0], pulses_us = [1650]");
    assert_names(
        &e,
        "joint[3].servo.angles_deg",
        line,
        &["2 to 9 knots", "1 angles"],
    );
    let ten = "angles_deg = [0,1,2,3,4,5,6,7,8,9], pulses_us = [1,2,3,4,5,6,7,8,9,10]";
    assert_names(
        &servo(ten),
        "joint[3].servo.angles_deg",
        line,
        &["2 to 9 knots", "10 angles"],
    );
    let e = servo("angles_deg = [-100, 0, 0, 100], pulses_us = [900, 1600, 1700, 2400]");
    assert_names(
        &e,
        "joint[3].servo.angles_deg[3]",
        line,
        &["strictly increasing", "0 after 0"],
    );
    let e = servo("angles_deg = [-100, 50, 0, 100], pulses_us = [900, 1600, 1700, 2400]");
    assert_names(
        &e,
        "joint[3].servo.angles_deg[3]",
        line,
        &["strictly increasing", "0 after 50"],
    );
    let e =
        servo("angles_deg = [-100, -50, 0, 50, 100], pulses_us = [900, 1300, 1650, 1640, 2400]");
    assert_names(
        &e,
        "joint[3].servo.pulses_us[4]",
        line,
        &["monotonic", "1650 then 1640 where the curve rises"],
    );
    let e = servo("angles_deg = [-100, 0, 100], pulses_us = [900, nan, 2400]");
    assert_names(&e, "joint[3].servo.pulses_us[2]", line, &["finite", "NaN"]);
    let e = servo("angles_deg = [-100, inf, 100], pulses_us = [900, 1650, 2400]");
    assert_names(&e, "joint[3].servo.angles_deg[2]", line, &["finite", "inf"]);
    let e = servo("angles_deg = [-100, 0, 100], pulses_us = [400, 1650, 2400]");
    assert_names(
        &e,
        "joint[3].servo.pulses_us[1]",
        line,
        &["500..=2500 µs", "400 µs"],
    );
    let e = servo("minus100 = 900.0, zero = 1650.0, plus100 = 2600.0");
    assert_names(&e, "joint[3].servo", line, &["500..=2500 µs", "2600 µs"]);
    let e = servo("minus100 = 900.0, angles_deg = [-100, 100], pulses_us = [900, 2400]");
    assert_names(
        &e,
        "joint[3].servo",
        line,
        &["either", "the keys { minus100, angles_deg, pulses_us }"],
    );
    let e = servo("angles_deg = [-100, 100]");
    assert_names(
        &e,
        "joint[3].servo",
        line,
        &["either", "the keys { angles_deg }"],
    );
    let e = servo("angles_deg = [-100, 100], pulses_us = [900, 2400], knots = 2");
    assert_names(
        &e,
        "joint[3].servo.knots",
        line,
        &["unknown field", "angles_deg"],
    );
}

#[test]
fn wrong_type_names_key_and_line() {
    let err = parse_err(&with_line(J3_MASS_LINE, "mass = \"heavy\""));
    assert_names(&err, "joint[3].mass", J3_MASS_LINE, &["expected"]);

    let err = parse_err(&with_line(7, "xyz = [0.0, 0.0]"));
    assert_names(&err, "base.xyz", 7, &["3"]);
}

#[test]
fn toml_syntax_error_names_the_line() {
    let err = parse_err(&with_line(J3_MASS_LINE, "mass = "));
    assert_eq!(err.location.line, Some(J3_MASS_LINE as u64), "{err}");
}

#[test]
fn an_arm_without_servo_tables_parses_and_is_written_without_them() {
    let text: String = FIXTURE
        .lines()
        .filter(|l| !l.starts_with("servo"))
        .map(|l| format!("{l}\n"))
        .collect();
    let d = arm_toml::parse(&text).unwrap();
    assert!(d.arm.joints.iter().all(|j| j.servo.is_none()));
    let written = arm_toml::to_toml(&d);
    assert!(!written.contains("servo"), "{written}");
    assert_eq!(arm_toml::parse(&written).unwrap(), d);
    // One joint without: that one is named.
    let one = with_line(J3_MASS_LINE + 2, "");
    let d = arm_toml::parse(&one).unwrap();
    let without: Vec<usize> = (0..d.arm.joints.len())
        .filter(|&j| d.arm.joints[j].servo.is_none())
        .collect();
    assert_eq!(without, [2]);
    let fixture = arm_toml::parse(FIXTURE).unwrap();
    assert!(fixture.arm.joints.iter().all(|j| j.servo.is_some()));
}

/// The fixture with a collision description appended; its first line is `FIXTURE_LINES + 2`.
fn with_collision(text: &str) -> String {
    format!("{FIXTURE}\n{text}")
}

const FIXTURE_LINES: usize = 88;

const BODIES: &str = r#"[collision]
clearance = 0.02
floor = -0.1
ignore = [["base", "gripper"]]

[[body]]
name = "base"
capsule = { from = "base", to = "j1", radius = 0.04 }

[[body]]
name = "upper arm"
capsule = { from = "j1", to = { frame = "j2", xyz = [0.0, 0.0, 0.01] }, radius = 0.03 }

[[body]]
name = "gripper"
floor = false
box = { frame = "tool", min = [-0.02, -0.02, -0.01], max = [0.02, 0.02, 0.03] }
"#;

#[test]
fn a_collision_description_parses_round_trips_and_reaches_the_planner() {
    use lrmcal_core::collision::{Floor, FrameRef, ShapeSpec};
    use lrmcal_engine::plan::{PlanConfig, candidates};
    let d = arm_toml::parse(&with_collision(BODIES)).unwrap();
    let c = &d.collision;
    assert_eq!(c.clearance_m, Some(0.02));
    assert_eq!(c.floor, Floor::At { z_m: -0.1 });
    assert_eq!(c.ignore, [["base".to_owned(), "gripper".to_owned()]]);
    assert_eq!(c.bodies.len(), 3);
    let ShapeSpec::Capsule { to, radius_m, .. } = c.bodies[1].shape else {
        panic!("the upper arm is a capsule")
    };
    assert_eq!(
        (to.frame, to.xyz_m, radius_m),
        (FrameRef::Dh(2), [0.0, 0.0, 0.01], 0.03)
    );
    assert!(matches!(
        c.bodies[2].shape,
        ShapeSpec::Box {
            frame: FrameRef::Tool,
            ..
        }
    ));
    assert_eq!(c.bodies[2].floor, Some(false));
    let written = arm_toml::to_toml(&d);
    assert_eq!(arm_toml::parse(&written).unwrap(), d, "{written}");
    // What `plan --arm` uses.
    let config = PlanConfig::for_arm(&d.arm, &d.collision).unwrap();
    assert_eq!((config.clearance_m, config.ground_z_m), (0.02, Some(-0.1)));
    let bodies = config.bodies.as_ref().unwrap();
    let name = |i: usize| bodies.bodies()[i].name.as_str();
    let pairs: Vec<[&str; 2]> = bodies
        .tested_pairs()
        .iter()
        .map(|&[i, j]| [name(i), name(j)])
        .collect();
    assert_eq!(pairs, [["upper arm", "gripper"]]);
    assert!(!candidates(&d.arm, &config).unwrap().kept.is_empty());
    // A file without the description has none: the planner's defaults.
    assert_eq!(
        arm_toml::parse(FIXTURE).unwrap().collision,
        Default::default()
    );
    assert_eq!(
        arm_toml::parse(&with_collision("[collision]\nfloor = false\n"))
            .unwrap()
            .collision
            .floor,
        Floor::Off
    );
}

#[test]
fn bad_bodies_name_the_key_and_the_line() {
    let at = |k: usize| FIXTURE_LINES + 1 + k;
    let body = |line: &str| with_collision(&format!("[[body]]\nname = \"b\"\n{line}\n"));
    let err = parse_err(&body(
        r#"capsule = { from = "j7", to = "j1", radius = 0.04 }"#,
    ));
    assert_names(&err, "body[1].capsule.from", at(3), &["j7", "j0 … j6"]);
    let err = parse_err(&body(
        r#"capsule = { from = "j11", to = "j1", radius = 0.04 }"#,
    ));
    assert_names(&err, "body[1].capsule.from", at(3), &["j11", "j0 … j10"]);
    let err = parse_err(&body(
        r#"capsule = { from = "j1", to = { frame = "j2" }, radius = 0.04 }"#,
    ));
    assert_names(&err, "body[1].capsule.to", at(3), &["xyz"]);
    let err = parse_err(&body(
        r#"capsule = { from = "j1", to = "j4", radius = 0.04 }"#,
    ));
    assert_names(
        &err,
        "body[1].capsule",
        at(3),
        &["one link", "links 4 and 5"],
    );
    let err = parse_err(&body(
        r#"capsule = { from = "j1", to = "j2", radius = -0.04 }"#,
    ));
    assert_names(
        &err,
        "body[1].capsule.radius",
        at(3),
        &["radius >= 0 m", "-0.04"],
    );
    let err = parse_err(&body(
        r#"box = { frame = "j2", min = [0.0, 0.0, 0.1], max = [0.1, 0.1, 0.0] }"#,
    ));
    assert_names(&err, "body[1].box", at(3), &["`min` <= `max`", "on z"]);
    let err = parse_err(&body(
        r#"box = { frame = "hand", min = [0.0, 0.0, 0.0], max = [0.1, 0.1, 0.1] }"#,
    ));
    assert_names(&err, "body[1].box.frame", at(3), &["`hand`"]);
    let err = parse_err(&body("radius = 0.04"));
    assert!(err.to_string().contains("radius"), "{err}");
    let err = parse_err(&with_collision("[[body]]\nname = \"b\"\n"));
    assert_names(&err, "body[1]", at(1), &["exactly one of `capsule"]);
    let err = parse_err(&with_collision(
        "[collision]\nignore = [[\"link 1\", \"link 9\"]]\n",
    ));
    assert_names(
        &err,
        "collision.ignore[1]",
        at(2),
        &["`link 9`", "link 1, link 2"],
    );
    let err = parse_err(&with_collision("[collision]\nfloor = true\n"));
    assert_names(&err, "collision.floor", at(2), &["false for no floor"]);
    let err = parse_err(&with_collision(&format!("{BODIES}\n[collision.x]\n")));
    assert!(err.to_string().contains("collision"), "{err}");
    let err = parse_err(&with_collision(
        &BODIES.replace("clearance = 0.02", "clearance = 0.02\nradius = 0.03"),
    ));
    assert_names(&err, "collision.radius", at(3), &["each body its own size"]);
    let err = parse_err(&with_collision(
        &BODIES.replace("\"upper arm\"", "\"base\""),
    ));
    assert_names(&err, "body[2].name", at(10), &["`base`", "body[1]"]);
}

/// `[plan] levels_deg` gives the arm's candidate grid: read, written back,
/// and taken by the planner (`PlanConfig::for_loaded`, what `plan`,
/// `simulate` and `demo` use); a file without it keeps the paper's grid.
#[test]
fn the_plan_table_gives_the_grid_levels_and_reaches_the_planner() {
    use lrmcal_engine::plan::{Levels, PlanConfig};
    let d = arm_toml::parse(&with_collision(
        "[plan]\nlevels_deg = [-90.0, 0.0, 45.0, 90.0]\n",
    ))
    .unwrap();
    assert_eq!(d.levels_deg, Some(vec![-90.0, 0.0, 45.0, 90.0]));
    let written = arm_toml::to_toml(&d);
    assert!(written.contains("[plan]"), "{written}");
    assert_eq!(arm_toml::parse(&written).unwrap(), d, "{written}");
    assert_eq!(arm_toml::parse(FIXTURE).unwrap().levels_deg, None);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("arm.toml");
    arm_toml::write(&path, &d).unwrap();
    let loaded = ArmSource::Description(path).load().unwrap();
    let config = PlanConfig::for_loaded(&loaded).unwrap();
    assert_eq!(config.levels.to_string(), "-90,0,45,90");
    assert_eq!(config.levels.grid_size(6), Ok(4096));
    let default = PlanConfig::for_loaded(&ArmSource::Bundled("lrm").load().unwrap()).unwrap();
    assert_eq!(default.levels, Levels::paper());
}

#[test]
fn bad_grid_levels_name_the_key_and_the_line() {
    let at = |line: usize| FIXTURE_LINES + 1 + line;
    let plan = |levels: &str| with_collision(&format!("[plan]\nlevels_deg = {levels}\n"));
    assert_names(
        &parse_err(&plan("[]")),
        "plan.levels_deg",
        at(2),
        &["at least one"],
    );
    assert_names(
        &parse_err(&plan("[-90.0, 0.0, 0.0]")),
        "plan.levels_deg[3]",
        at(2),
        &["strictly increasing", "0 after 0"],
    );
    assert_names(
        &parse_err(&plan("[90.0, 0.0]")),
        "plan.levels_deg[2]",
        at(2),
        &["strictly increasing"],
    );
    assert_names(
        &parse_err(&plan("[0.0, inf]")),
        "plan.levels_deg[2]",
        at(2),
        &["inf"],
    );
    let err = parse_err(&with_collision("[plan]\nlevels = [0.0]\n"));
    assert!(err.to_string().contains("levels"), "{err}");
}
