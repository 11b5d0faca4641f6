//! Tests of `calibration_file`.

use super::test_support::sample_file;
use super::*;

#[test]
fn round_trips_and_checks_its_nominal_arm() {
    let file = sample_file();
    let json = file.to_json();
    assert!(json.contains("\"option\": \"elastic\""), "{json}");
    let back = CalibrationFile::parse(&json).unwrap();
    assert_eq!(back, file);
    let path = Path::new("cal.json");
    assert!(back.check_nominal(&file.nominal, path).is_ok());
    let mut other = file.nominal;
    other.joints[2].a += 0.01;
    let err = back.check_nominal(&other, path).unwrap_err();
    assert!(!err.is_access());
    let err = err.report();
    assert!(err.contains("cal.json") && err.contains("j3.a"), "{err}");
}

/// A joint no servo drives is written `null` and read back as none; the
/// all-zero curve earlier versions wrote for it reads as none too.
#[test]
fn a_joint_without_a_servo_has_no_curve_in_every_version() {
    let mut file = sample_file();
    file.nominal.joints[0].servo = None;
    file.arm.joints[0].servo = None;
    let json = file.to_json();
    assert!(json.contains("\"servo\": null"), "{json}");
    assert_eq!(CalibrationFile::parse(&json).unwrap(), file);
    let zero = serde_json::to_string(&ServoCurve::from_three_points(0.0, 0.0, 0.0)).unwrap();
    let old = json
        .replace("\"servo\": null", &format!("\"servo\": {zero}"))
        .replace(
            &format!("\"schema_version\": {SCHEMA_VERSION}"),
            "\"schema_version\": 4",
        );
    assert!(
        old.contains("\"schema_version\": 4") && old.contains(&zero),
        "{old}"
    );
    assert_eq!(CalibrationFile::parse(&old).unwrap(), file);
}

/// An arm description is the calibration's nominal arm when its joints'
/// geometry, limits and masses are, rounded or not; the base, tool,
/// compliances and servo curves may differ.
#[test]
fn an_arm_description_describes_the_nominal_arm_by_its_joints() {
    let file = sample_file();
    let path = Path::new("cal.json");
    let label = "`my.toml`";
    let mut same = file.nominal;
    // As the page's example writes π/2 and the limits: 6 digits.
    fn rounded(x: f64) -> f64 {
        (x * 1e4).round() / 1e4
    }
    same.joints[1].theta = rounded(std::f64::consts::FRAC_PI_2);
    same.joints[0].limits = same.joints[0].limits.map(rounded);
    same.base.xyz = [1.0, 2.0, 3.0];
    same.tool.xyz = [0.0, 0.0, 0.1];
    same.joints[3].compliance = 0.5;
    file.check_describes_nominal(&same, label, path).unwrap();

    let mut other = file.nominal;
    other.joints[2].a = 0.12;
    let e = file
        .check_describes_nominal(&other, label, path)
        .unwrap_err();
    assert_eq!(
        e.report(),
        "error: failed to use calibration `cal.json`: its nominal arm is not `my.toml`: joint \
         3's a differs: 120 mm in `my.toml`, 0 mm in the calibration's nominal arm; pass --arm \
         the arm description it was identified from"
    );
    let mut other = file.nominal;
    other.joints[4].alpha += 1e-4;
    let e = file
        .check_describes_nominal(&other, label, path)
        .unwrap_err()
        .report();
    assert!(
        e.contains("joint 5's alpha differs: 90.00573° in `my.toml`, 90° in"),
        "{e}"
    );
    let mut other = file.nominal;
    other.joints[5].limits[1] = 1.5;
    let e = file
        .check_describes_nominal(&other, label, path)
        .unwrap_err()
        .report();
    assert!(
        e.contains("joint 6's upper limit differs: 85.943669° in `my.toml`"),
        "{e}"
    );
    let mut other = file.nominal;
    other.joints[0].mass = 0.2;
    let e = file
        .check_describes_nominal(&other, label, path)
        .unwrap_err()
        .report();
    assert!(
        e.contains("joint 1's mass differs: 0.2 kg in `my.toml`, 0.15 kg"),
        "{e}"
    );
}

/// Every option reads by its name: ours, `elasto-kinematic-servo`, the
/// default of every lrmcal that wrote calibration files, too.
#[test]
fn every_option_reads_by_its_name() {
    let json = sample_file().to_json();
    for o in ModelOption::ALL {
        let text = json.replacen(
            "\"option\": \"elastic\"",
            &format!("\"option\": \"{}\"", o.name()),
            1,
        );
        assert_eq!(CalibrationFile::parse(&text).unwrap().option, o);
    }
}

/// Each refusal names the key (and the line, where the JSON text has one).
#[test]
fn rejects_other_schemas_versions_and_bad_values() {
    let json = sample_file().to_json();
    let refused = |text: &str| CalibrationFile::parse(text).unwrap_err().to_string();
    let e = refused("{\"a\": 1}");
    assert!(e.contains("key `schema`") && e.contains(SCHEMA), "{e}");
    let e = refused(&json.replace(
        &format!("\"schema_version\": {SCHEMA_VERSION}"),
        "\"schema_version\": 9",
    ));
    assert!(e.contains("key `schema_version`") && e.contains('9'), "{e}");
    let e = refused(&json.replacen("\"k2\"", "\"k9\"", 1));
    assert!(
        e.contains("key `parameters[1].name`") && e.contains("k9"),
        "{e}"
    );
    let e = refused(&json.replacen("\"compliance\": 0.1", "\"compliance\": -0.1", 1));
    assert!(e.contains("key `arm.joints[2].compliance`"), "{e}");
    // The first arm written is the nominal, its joints after its base.
    let e = refused(&json.replacen("\"softening\": 0.0", "\"softening\": -0.5", 1));
    assert!(
        e.contains("key `nominal.joints[1].softening`") && e.contains("-0.5"),
        "{e}"
    );
    let e = refused(&json.replacen("\"base_softening\": 0.0", "\"base_softening\": -2.0", 2));
    assert!(e.contains("key `nominal.base_softening`"), "{e}");
    // A negative rated payload, in either arm, as the board refuses it.
    let mut negative = sample_file();
    negative.arm.rated_payload_kg = -0.1;
    let e = refused(&negative.to_json());
    assert!(
        e.contains("key `arm.rated_payload_kg`") && e.contains("-0.1"),
        "{e}"
    );
    let e = refused(&json.replacen("\"elastic\"", "\"rigid\"", 1));
    assert!(
        e.contains("key `option`")
            && e.contains("rigid")
            && e.contains("line 4")
            && e.contains("elasto-kinematic-servo, paper-kinematic or paper-elasto-kinematic"),
        "{e}"
    );
    let e = refused(&json.replacen("\"mean_m\"", "\"mean_mm\"", 1));
    assert!(e.contains("key `fit_residual.mean_mm`"), "{e}");
    let e = refused(&json[..json.len() / 2]);
    assert!(e.contains("not JSON"), "{e}");
    // JSON has no NaN or infinity; a number too large for f64 is refused.
    let e = refused(&json.replacen("0.1", "1e999", 1));
    assert!(e.contains("not JSON") && e.contains("number"), "{e}");
}

/// The first target by default, another by name, both arms carrying its
/// tool point; an unknown name lists the names; a file without targets is
/// itself and refuses any name.
#[test]
fn target_selection_moves_both_tool_points() {
    let mut file = sample_file();
    assert_eq!(file.for_target(None).as_ref(), Ok(&file));
    let e = file.for_target(Some("m1")).unwrap_err();
    assert!(e.contains("`m1`") && e.contains("target` column"), "{e}");
    let stats = ErrorStats::of(&[0.001]);
    for (name, tool_m) in [("m0", file.arm.tool.xyz), ("m1", [0.0, 0.03, 0.05])] {
        file.targets.push(TargetTool {
            name: name.into(),
            tool_m,
            fit_residual: stats,
            validation_after: None,
        });
    }
    file.parameters.push(FittedParam {
        name: ParamKey::from_name("tool[1].y").unwrap(),
        error: 0.03,
        value: 0.03,
        std: None,
    });
    let file = CalibrationFile::parse(&file.to_json()).unwrap();
    let (nominal, arm) = file.for_target(Some("m1")).unwrap().board_arms();
    assert_eq!(nominal.tool.xyz, [0.0, 0.03, 0.05]);
    assert_eq!(arm.tool.xyz, [0.0, 0.03, 0.05]);
    assert_eq!(arm.joints, file.arm.joints);
    assert_eq!(nominal.joints, file.nominal.joints);
    let (nominal, arm) = file.for_target(None).unwrap().board_arms();
    assert_eq!(
        (nominal.tool.xyz, arm.tool.xyz),
        (file.arm.tool.xyz, file.arm.tool.xyz)
    );
    let e = file.for_target(Some("m9")).unwrap_err();
    assert!(e.contains("`m9`") && e.contains("m0, m1"), "{e}");
    // A parameter of a target the file does not list, a repeated name, a
    // first target away from the arm's tool point: refused with the key.
    let json = file.to_json();
    let refused = |text: &str| CalibrationFile::parse(text).unwrap_err().to_string();
    let e = refused(&json.replacen("tool[1].y", "tool[2].y", 1));
    assert!(e.contains("parameters[2].name"), "{e}");
    let e = refused(&json.replacen("\"m1\"", "\"m0\"", 1));
    assert!(e.contains("targets[2]") && e.contains("`m0` again"), "{e}");
    let mut moved = file.clone();
    moved.targets[0].tool_m[0] += 0.01;
    let e = refused(&moved.to_json());
    assert!(e.contains("targets[1].tool_m"), "{e}");
}

/// A version 2 file (no registration) still reads; a registration
/// round trips, and lets the nominal arm's base differ from the arm
/// file's (it is the registered base) but nothing else.
#[test]
fn reads_version_2_and_records_the_registration() {
    let file = sample_file();
    let v2 = file.to_json().replace(
        &format!("\"schema_version\": {SCHEMA_VERSION}"),
        "\"schema_version\": 2",
    );
    assert!(!v2.contains("registration"), "{v2}");
    // Read as this version's file (the upgrade rewrites the version).
    assert_eq!(CalibrationFile::parse(&v2).unwrap(), file);
    let arm_file = file.nominal;
    let mut registered = file.clone();
    registered.nominal.base.xyz[0] += 0.5;
    registered.nominal.base.rpy[2] += 1.0;
    let path = Path::new("cal.json");
    let e = registered.check_nominal(&arm_file, path).unwrap_err();
    assert!(e.to_string().contains("base.x"), "{e}");
    let record = RegistrationRecord {
        registered: true,
        frame: Frame {
            xyz: [0.5, 0.0, 0.0],
            rpy: [0.0, 0.0, 1.0],
        },
        base: Frame {
            xyz: [0.5, 0.0, 0.0],
            rpy: [0.0, 0.0, 1.0],
        },
        gravity: [0.0, -9.8, 0.0],
        before_rms_m: 2.0,
        after_rms_m: 0.03,
        trimmed: vec![7],
        tool_m: None,
    };
    let with = registered.clone().with_registration(record.clone());
    assert!(!with.to_json().contains("tool_m"));
    assert_eq!(CalibrationFile::parse(&with.to_json()).unwrap(), with);
    with.check_nominal(&arm_file, path).unwrap();
    let mut other = arm_file;
    other.joints[2].a += 0.01;
    let e = with.check_nominal(&other, path).unwrap_err();
    assert!(e.to_string().contains("j3.a"), "{e}");
    // A tool point registration found replaces the file's: not compared.
    let mut moved_tool = registered.clone();
    moved_tool.nominal.tool.xyz[1] += 0.13;
    let e = moved_tool
        .clone()
        .with_registration(record.clone())
        .check_nominal(&arm_file, path)
        .unwrap_err();
    assert!(e.to_string().contains("tool.y"), "{e}");
    let tool_m = Some(moved_tool.nominal.tool.xyz);
    let found = moved_tool.with_registration(RegistrationRecord { tool_m, ..record });
    assert_eq!(CalibrationFile::parse(&found.to_json()).unwrap(), found);
    found.check_nominal(&arm_file, path).unwrap();
}

#[test]
fn statistics_of_a_known_set() {
    let s = ErrorStats::of(&[4.0, 1.0, 3.0, 2.0, 5.0]);
    assert_eq!(s.count, 5);
    assert!((s.mean_m - 3.0).abs() < 1e-12);
    assert!((s.median_m - 3.0).abs() < 1e-12);
    assert!((s.rms_m - 11f64.sqrt()).abs() < 1e-12);
    assert!((s.p95_m - 4.8).abs() < 1e-12);
    assert_eq!(s.max_m, 5.0);
    assert_eq!(ErrorStats::of(&[]).count, 0);
}

#[test]
fn schema_1_files_read_as_the_same_curves() {
    let mut file = sample_file();
    file.arm.joints[1].servo = Some(ServoCurve::from_three_points(880.5, 1640.25, 2410.125));
    let json = file.to_json();
    assert!(
        json.contains(&format!("\"schema_version\": {SCHEMA_VERSION}"))
            && json.contains("\"angles_rad\"")
    );
    // The same file as schema 1 wrote it: each curve as its three pulses.
    let mut v1: serde_json::Value = serde_json::from_str(&json).unwrap();
    v1["schema_version"] = 1.into();
    for arm in ["nominal", "arm"] {
        for joint in v1[arm]["joints"].as_array_mut().unwrap() {
            let p = joint["servo"]["pulses_us"].clone();
            joint["servo"] = serde_json::json!({ "minus100": p[0], "zero": p[1], "plus100": p[2] });
        }
    }
    let text = serde_json::to_string_pretty(&v1).unwrap();
    assert!(text.contains("\"minus100\": 880.5"), "{text}");
    assert_eq!(CalibrationFile::parse(&text).unwrap(), file);

    v1["arm"]["joints"][2]["servo"] = serde_json::json!({ "minus100": 900.0, "zero": 1650.0 });
    let text = serde_json::to_string_pretty(&v1).unwrap();
    let e = CalibrationFile::parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("arm.joints[3].servo") && e.contains("plus100"),
        "{e}"
    );
    // A key missing from the whole document is placed on its last line,
    // as in a file of the current version.
    let mut no_option = v1.clone();
    no_option.as_object_mut().unwrap().remove("option");
    no_option["arm"]["joints"][2]["servo"] =
        serde_json::json!({ "minus100": 900.0, "zero": 1650.0, "plus100": 2400.0 });
    let text = serde_json::to_string_pretty(&no_option).unwrap();
    let e = CalibrationFile::parse(&text).unwrap_err();
    assert_eq!(e.location.line, Some(text.lines().count() as u64), "{e}");
    assert!(e.to_string().contains("option"), "{e}");
    // A schema-2 file must hold knots: the three points alone are refused.
    v1["schema_version"] = 2.into();
    v1["arm"]["joints"][2]["servo"] =
        serde_json::json!({ "minus100": 900.0, "zero": 1650.0, "plus100": 2400.0 });
    let e = CalibrationFile::parse(&serde_json::to_string(&v1).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("minus100"), "{e}");
}

/// The board's nominal arm stands on the calibrated base; everything else,
/// the tool included, is the file's nominal arm.
#[test]
fn the_boards_nominal_arm_stands_where_the_calibrated_one_does() {
    let mut file = sample_file();
    file.arm.base.xyz = [0.01, -0.02, -0.06];
    file.arm.base.rpy = [0.02, 0.0, 0.1];
    file.arm.tool.xyz[1] += 0.004;
    let (nominal, arm) = file.board_arms();
    assert_eq!(arm, file.arm);
    assert_eq!(nominal.base, file.arm.base);
    let mut rest = nominal;
    rest.base = file.nominal.base;
    assert_eq!(rest, file.nominal);
}

/// A file knows the arm it was made for: its name and its joints' names
/// read back as written, and a list of names that is not one per joint is
/// refused naming the key; files without them read as before.
#[test]
fn the_arms_name_and_joint_names_round_trip_and_are_checked() {
    let names: Vec<String> = (1..=6).map(|i| format!("j{i}_servo")).collect();
    let named = sample_file().for_arm("my arm", &names);
    let json = named.to_json();
    let back = CalibrationFile::parse(&json).unwrap();
    assert_eq!(back, named);
    assert_eq!(back.joint_names_or_numbered(), names);
    assert_eq!(back.arm_name.as_deref(), Some("my arm"));
    let unnamed = sample_file();
    assert!(!unnamed.to_json().contains("joint_names"));
    assert_eq!(unnamed.joint_names_or_numbered()[5], "joint_6");
    let five = sample_file().for_arm("my arm", &names[..5]);
    let e = CalibrationFile::parse(&five.to_json())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("key `joint_names`") && e.contains("one name per joint of the arm (6)"),
        "{e}"
    );
}
