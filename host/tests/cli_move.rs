//! `lrmcal move --xyz … --dry-run` run as a user runs it, without a board:
//! the printed joint targets put the nominal tool point on the target, start
//! from --from-deg, and keep to the arm's limits; a target out of reach,
//! reachable only beyond the limits or only by colliding poses is refused
//! with the numbers at fault and exit code 3; a wrong command line with 2.
//! (`tests/tests/device_commands.rs` moves a board with it.)

use std::process::{Command, Output};

use lrmcal_core::io::arm_source;
use model::testing::TEST_ARM_JOINTS as JOINTS;

fn lrmcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .args(args)
        .env_remove("LRMCAL_PORT")
        .output()
        .expect("lrmcal runs")
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The numbers after `label` on its line of the dry run's output.
fn numbers_after(text: &str, label: &str) -> Vec<f64> {
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix(label))
        .unwrap_or_else(|| panic!("no `{label}` in\n{text}"));
    line.split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect()
}

/// The tool point of the bundled arm at `q_deg`, mm, as `--xyz` arguments.
fn tool_point_mm(q_deg: [f64; JOINTS]) -> [String; 3] {
    let arm = arm_source::bundled("lrm").unwrap().arm;
    let p = arm.chain().rigid_tool_point(&q_deg.map(f64::to_radians)) * 1e3;
    [p.x, p.y, p.z].map(|c| c.to_string())
}

fn dry_run(xyz: &[String; 3], more: &[&str]) -> Output {
    let mut args = vec!["move", "--xyz", &xyz[0], &xyz[1], &xyz[2], "--dry-run"];
    args.extend_from_slice(more);
    lrmcal(&args)
}

#[test]
fn dry_run_prints_joint_targets_that_reach_the_point() {
    let arm = arm_source::bundled("lrm").unwrap().arm;
    let pose = [20.0, 35.0, 40.0, -10.0, 50.0, 5.0];
    let xyz = tool_point_mm(pose);
    for start in [[0.0; JOINTS], [15.0, 30.0, 45.0, 0.0, 45.0, 0.0]] {
        let start_args: Vec<String> = start.iter().map(|a| a.to_string()).collect();
        let mut more = vec!["--from-deg"];
        more.extend(start_args.iter().map(String::as_str));
        let run = dry_run(&xyz, &more);
        assert!(run.status.success(), "{}", stderr(&run));
        let text = stdout(&run);
        assert!(
            text.starts_with("nominal arm: bundled arm `lrm` (lrm-like)\n"),
            "{text}"
        );
        assert_eq!(numbers_after(&text, "start (--from-deg), deg: "), start);
        let q: Vec<f64> = numbers_after(&text, "joint targets, deg: ");
        let q: [f64; JOINTS] = q.try_into().unwrap();
        assert!(arm.within_limits(&q.map(f64::to_radians)), "{q:?}");
        let reached = arm.chain().rigid_tool_point(&q.map(f64::to_radians)) * 1e3;
        let target: Vec<f64> = xyz.iter().map(|c| c.parse().unwrap()).collect();
        let miss = (reached - nalgebra::Vector3::from_column_slice(&target)).norm();
        // Printed to 1e-4°: a few µm at the tool.
        assert!(miss < 0.01, "{miss} mm\n{text}");
        assert!(text.contains(" mm from the target, "), "{text}");
    }
    // From the pose itself, the pose itself: no move is the nearest solution.
    let start_args: Vec<String> = pose.iter().map(|a| a.to_string()).collect();
    let mut more = vec!["--from-deg"];
    more.extend(start_args.iter().map(String::as_str));
    let text = stdout(&dry_run(&xyz, &more));
    let q = numbers_after(&text, "joint targets, deg: ");
    for (a, b) in q.iter().zip(pose) {
        assert!((a - b).abs() < 1e-4, "{q:?}");
    }
    assert!(text.contains("0.00° from the start"), "{text}");
}

#[test]
fn unreachable_targets_say_why_with_exit_code_3() {
    let refused = |xyz: &[String; 3], more: &[&str]| {
        let run = dry_run(xyz, more);
        assert_eq!(run.status.code(), Some(3), "{}", stdout(&run));
        assert!(stdout(&run).is_empty());
        stderr(&run)
    };
    let mm = |x: f64, y: f64, z: f64| [x, y, z].map(|c| c.to_string());

    let e = refused(&mm(800.0, 0.0, 100.0), &[]);
    assert_eq!(
        e.trim_end(),
        "error: failed to find joint targets for the tool point (800.0, 0.0, 100.0) mm: out of \
         reach: the target is 806.2 mm from the arm's base, 262.4 mm beyond the 543.9 mm its \
         links reach end to end"
    );
    let e = refused(&mm(0.0, 0.0, 543.0), &[]);
    assert!(
        e.contains(
            "out of reach: the nearest point the arm reaches within its joint limits is \
             (0.0, 0.0, 541.8) mm, 1.197 mm from the target"
        ),
        "{e}"
    );
    // Below the ground: every pose lays a body on it, unless there is no ground.
    let low = mm(300.0, 0.0, -20.0);
    let e = refused(&low, &[]);
    assert!(
        e.contains("every pose found that reaches it within the joint limits collides: ")
            && e.contains("too close to the ground"),
        "{e}"
    );
    assert!(dry_run(&low, &["--no-ground"]).status.success());
    assert!(
        dry_run(&low, &["--ground-z-mm", "-100", "--clearance-mm", "0"])
            .status
            .success()
    );

    // An arm whose joints turn only ±20°: reachable, but not within them.
    let dir = tempfile::tempdir().unwrap();
    let narrow = dir.path().join("narrow.toml");
    let text = arm_source::BUNDLED[0].1.replace(
        "limits = [-1.8325957145940461, 1.8325957145940461]",
        "limits = [-0.35, 0.35]",
    );
    std::fs::write(&narrow, text).unwrap();
    let e = refused(
        &tool_point_mm([0.0, 60.0, 30.0, 0.0, 20.0, 0.0]),
        &["--arm", narrow.to_str().unwrap()],
    );
    assert!(
        e.contains(
            "reachable only with joints beyond their limits: the pose needing the least has joint "
        ),
        "{e}"
    );
    assert!(e.contains("(limit 20.1°, "), "{e}");

    // A calibration file's arm is not the nominal one joint targets are for.
    let e = refused(&mm(200.0, 0.0, 300.0), &["--arm", "cal.json"]);
    assert!(
        e.contains("failed to load arm `cal.json`: joint targets are for a nominal arm"),
        "{e}"
    );
}

#[test]
fn a_wrong_command_line_is_a_usage_error() {
    for args in [
        &["move", "--xyz", "1", "2"][..],
        &["move", "--xyz", "1", "2", "nan", "--dry-run"],
        &["move", "--xyz", "1", "2", "3"],
        &["move", "0", "0", "0", "0", "0", "0", "--dry-run"],
        &["move", "0", "0", "0", "0", "0", "0", "--xyz", "1", "2", "3"],
        &[
            "move",
            "--xyz",
            "1",
            "2",
            "3",
            "--from-deg",
            "0",
            "0",
            "0",
            "0",
            "0",
            "0",
        ],
        &["move", "--dry-run"],
    ] {
        let run = lrmcal(args);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {}", stderr(&run));
    }
    let run = lrmcal(&["move", "--xyz", "1", "2", "3"]);
    assert!(stderr(&run).contains("--port <PORT>"), "{}", stderr(&run));
}

#[test]
fn help_explains_cartesian_targets() {
    let help = stdout(&lrmcal(&["move", "--help"]));
    for needle in [
        "--xyz <X> <Y> <Z>",
        "--dry-run",
        "--from-deg",
        "nearest the board's current pose",
        "lrmcal move --xyz 250 -50 120 --port /dev/ttyACM0",
        "exit code 3",
    ] {
        assert!(help.contains(needle), "`{needle}` missing from\n{help}");
    }
}

/// With `--calibration`, only poses the board holding it can command are
/// sent: a calibration whose shoulder's zero is 10° off cannot command the
/// nominal arm's nearest pose with the shoulder at its lower limit, so
/// another is found, and the compensated commands stay within the limits; a
/// point only such poses reach is refused naming the compensation.
#[test]
fn dry_run_with_a_calibration_keeps_the_compensated_commands_within_the_limits() {
    use lrmcal_core::io::calibration_file::{CalibrationFile, ErrorStats, SCHEMA, SCHEMA_VERSION};
    use lrmcal_engine::device::commanded::Commanded;

    let mut nominal = arm_source::bundled("lrm").unwrap().arm;
    // The shoulder may not lean back past upright.
    nominal.joints[1].limits[0] = 0.0;
    let mut calibrated = nominal;
    calibrated.joints[1].theta += 10f64.to_radians();
    let file = CalibrationFile {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        option: protocol::ModelOption::Kinematic,
        nominal,
        arm: calibrated,
        parameters: vec![],
        at_bound: vec![],
        removed: vec![],
        poses_used: vec![],
        loads_kg: vec![0.0],
        fit_residual: ErrorStats::of(&[]),
        converged: true,
        arm_name: None,
        joint_names: vec![],
        validation: None,
        targets: vec![],
        registration: None,
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cal.json");
    std::fs::write(&path, file.to_json()).unwrap();
    let cal = path.to_str().unwrap();
    // The upright shoulder's point: nominally at the shoulder's lower limit.
    let pose = [0.0, 0.0, 40.0, 0.0, 30.0, 0.0];
    let xyz = tool_point_mm(pose);
    let plain = dry_run(&xyz, &[]);
    assert!(plain.status.success(), "{}", stderr(&plain));
    let with = dry_run(&xyz, &["--calibration", cal]);
    assert!(with.status.success(), "{}", stderr(&with));
    let q_deg = numbers_after(&stdout(&with), "joint targets, deg: ");
    let q: [f64; JOINTS] = std::array::from_fn(|i| q_deg[i].to_radians());
    let payload = lrmcal_engine::device::calibration::payload(&file, [0.0; JOINTS].into()).unwrap();
    let board = Commanded::new(&payload, protocol::CompensationMode::Full, 0.0);
    let command = board.command(&q).expect("a pose the board can command");
    assert!(command[1] >= 0.0, "{command:?}");
    assert!(
        (nominal.chain().rigid_tool_point(&q) * 1e3
            - nalgebra::Vector3::from(xyz.clone().map(|c| c.parse::<f64>().unwrap())))
        .norm()
            < 1e-2,
        "the printed angles (to 1e-4°) put the tool on the target"
    );
    // Without the calibration the nearest pose keeps the shoulder near
    // upright, where the board holding it would have to command it below its limit.
    let plain_q = numbers_after(&stdout(&plain), "joint targets, deg: ");
    let plain_q: [f64; JOINTS] = std::array::from_fn(|i| plain_q[i].to_radians());
    let refusal = board.command(&plain_q).unwrap_err().to_string();
    assert!(refusal.contains("joint 2"), "{refusal}");
    // Straight up only the upright shoulder reaches: refused, before anything moves.
    let top = dry_run(&tool_point_mm([0.0; JOINTS]), &["--calibration", cal]);
    assert_eq!(top.status.code(), Some(3), "{}", stdout(&top));
    let message = stderr(&top);
    assert!(
        message.contains("can be commanded") && message.contains("joint 2"),
        "{message}"
    );
}
