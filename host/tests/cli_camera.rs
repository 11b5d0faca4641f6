//! `lrmcal plan --camera`: a webcam in front of the bundled arm keeps only the
//! poses whose board it sees, and a bad setup file is refused by name.

mod common;

use std::path::Path;

use common::{lrmcal, p, text};
use lrmcal_core::camera::{Intrinsics, board, intrinsics_file, setup, views};
use lrmcal_core::io::{arm_source::ArmSource, pose_list};
use model::Frame;
use nalgebra::Vector3;

/// A 720p webcam with a little barrel distortion.
fn webcam() -> Intrinsics {
    Intrinsics {
        width_px: 1280,
        height_px: 720,
        fx: 910.0,
        fy: 908.0,
        cx: 641.0,
        cy: 358.0,
        distortion: [-0.1, 0.06, 0.001, -0.0005, 0.0],
    }
}

/// [`webcam`] as ROS's camera calibrator writes it.
const CAMERA_INFO: &str = include_str!("../core/arms/lrm-webcam/camera_info.yaml");

/// A 3x3 grid of 3 cm tags: 108 mm across, its centre at (54, 54) mm.
const BOARD: &str = "target_type: 'aprilgrid'\ntagCols: 3\ntagRows: 3\ntagSize: 0.03\n\
tagSpacing: 0.3\n";

/// The camera 0.8 m in front of the arm (along x), 25 cm up, looking back
/// at it: its z along the world's -x, its y (down) along -z. The board on
/// the flange, centred on its axis, facing out.
const SETUP: &str = r#"intrinsics = "camera_info.yaml"
board_file = "board.yaml"
mount = "eye-to-hand"

[camera]
xyz_mm = [800.0, 0.0, 250.0]
rpy_deg = [-90.0, 0.0, 90.0]

[board]
xyz_mm = [-54.0, -54.0, 5.0]
rpy_deg = [0.0, 0.0, 0.0]
"#;

/// A folder with the setup (as `setup`), the camera_info file and the board.
fn files(dir: &Path, setup: &str) {
    std::fs::write(dir.join("camera_info.yaml"), CAMERA_INFO).unwrap();
    std::fs::write(dir.join("board.yaml"), BOARD).unwrap();
    std::fs::write(dir.join("setup.toml"), setup).unwrap();
}

/// Poses `lrmcal plan` writes with `extra` options.
fn plan(dir: &Path, name: &str, extra: &[&str]) -> Vec<lrmcal_core::dataset::PoseRow> {
    let out = dir.join(name);
    let mut args = vec!["plan", "--random", "40", "--out", p(&out)];
    args.extend_from_slice(extra);
    let run = lrmcal(&args);
    assert!(run.status.success(), "{}", text(&run));
    pose_list::read(&out).unwrap()
}

#[test]
fn the_camera_keeps_the_poses_whose_board_it_sees() {
    let dir = tempfile::tempdir().unwrap();
    files(dir.path(), SETUP);
    let all = plan(dir.path(), "all.csv", &[]);
    let setup = dir.path().join("setup.toml");
    let seen = plan(dir.path(), "seen.csv", &["--camera", p(&setup)]);
    assert!(
        !seen.is_empty() && seen.len() < all.len(),
        "{} of {}",
        seen.len(),
        all.len()
    );

    // Every pose kept, worked out here from the files and the arm, corner by
    // corner: in the image 10 px from its edges, the board facing the camera
    // within 60°.
    let arm = "lrm".parse::<ArmSource>().unwrap().load().unwrap().arm;
    let camera = intrinsics_file::read(&dir.path().join("camera_info.yaml")).unwrap();
    assert_eq!(camera, webcam());
    let grid = board::read(&dir.path().join("board.yaml")).unwrap();
    let deg = |v: [f64; 3]| v.map(f64::to_radians);
    let world_camera = Frame {
        xyz: [0.8, 0.0, 0.25],
        rpy: deg([-90.0, 0.0, 90.0]),
    }
    .isometry();
    let flange_board = Frame {
        xyz: [-0.054, -0.054, 0.005],
        rpy: [0.0; 3],
    }
    .isometry();
    let chain = arm.chain();
    for row in &seen {
        let flange = chain.frames(&row.pose.q, 0.0).frames.last_value();
        let camera_board = world_camera.inverse() * flange * flange_board;
        for corner in grid.corners() {
            let uv = camera.project(&(camera_board * corner)).unwrap();
            assert!(
                (10.0..=1269.0).contains(&uv.x) && (10.0..=709.0).contains(&uv.y),
                "pose {}: a corner at {uv}",
                row.pose.id
            );
        }
        let centre = camera_board * grid.centre();
        let normal = camera_board * Vector3::z();
        let angle = normal.angle(&-centre.coords).to_degrees();
        assert!(angle <= 60.0, "pose {}: seen at {angle}°", row.pose.id);
    }
}

#[test]
fn a_bad_setup_is_refused_naming_the_file_and_the_key() {
    for (from, to, names) in [
        ("mount = \"eye-to-hand\"\n", "", ["setup.toml", "mount"]),
        (
            "\"eye-to-hand\"",
            "\"on-a-stick\"",
            ["setup.toml", "on-a-stick"],
        ),
        (
            "\"camera_info.yaml\"",
            "\"missing.yaml\"",
            ["missing.yaml", "read"],
        ),
        ("rpy_deg = [0.0, 0.0, 0.0]\n", "", ["setup.toml", "rpy_deg"]),
    ] {
        let dir = tempfile::tempdir().unwrap();
        files(dir.path(), &SETUP.replace(from, to));
        let setup = dir.path().join("setup.toml");
        let run = lrmcal(&[
            "plan",
            "--camera",
            p(&setup),
            "--out",
            p(&dir.path().join("c.csv")),
        ]);
        let message = text(&run);
        assert!(!run.status.success(), "{to}: {message}");
        for name in names {
            assert!(message.contains(name), "`{name}` not in: {message}");
        }
    }
    // A bad board file is named with its key.
    let dir = tempfile::tempdir().unwrap();
    files(dir.path(), SETUP);
    std::fs::write(
        dir.path().join("board.yaml"),
        BOARD.replace("0.03", "-0.03"),
    )
    .unwrap();
    let run = lrmcal(&["plan", "--camera", p(&dir.path().join("setup.toml"))]);
    let message = text(&run);
    assert_eq!(run.status.code(), Some(3), "{message}");
    assert!(
        message.contains("board.yaml") && message.contains("tagSize"),
        "{message}"
    );
}

/// The views `simulate --camera` writes of the webcam of `setup` at the
/// poses of `dir/planned.csv` under the paper's load.
fn seen_views(dir: &Path, setup: &Path) -> Vec<views::View> {
    let out = dir.join("all.csv");
    let run = lrmcal(&[
        "simulate",
        "--camera",
        p(setup),
        "--poses",
        p(&dir.join("planned.csv")),
        "--loads",
        "0.0663",
        "--out",
        p(&out),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    views::read(&out).unwrap()
}

/// What `validate --camera setup` of `calibration` on the camera
/// measurements `views` (with `extra` options) says, the run succeeding.
fn validate_camera(setup: &Path, calibration: &Path, views: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "validate",
        "--camera",
        p(setup),
        "--calibration",
        p(calibration),
        "--measurements",
        p(views),
    ];
    args.extend_from_slice(extra);
    let run = lrmcal(&args);
    let said = text(&run);
    assert!(run.status.success(), "{said}");
    said
}

/// The mean error's reduction, %, on `validate`'s table line under the
/// paper's load.
fn reduction_pct(said: &str) -> f64 {
    said.lines()
        .find(|l| l.trim_start().starts_with("0.0663"))
        .and_then(|l| l.split_whitespace().rev().nth(1))
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("{said}"))
}

/// Writes `seen` as `dir/views.csv`, to fit, and `dir/other.csv`, every
/// `nth` view held out to check it, so both spread over the poses.
fn split_views(dir: &Path, seen: &[views::View], nth: usize) {
    let (other, fit): (Vec<_>, Vec<_>) = seen
        .iter()
        .cloned()
        .enumerate()
        .partition(|(k, _)| k % nth == nth - 1);
    let strip = |v: Vec<(usize, views::View)>| v.into_iter().map(|(_, v)| v).collect::<Vec<_>>();
    let units = [model::JointKind::Revolute; 6];
    views::write(&dir.join("views.csv"), &strip(fit), &units).unwrap();
    views::write(&dir.join("other.csv"), &strip(other), &units).unwrap();
}

/// `simulate --camera`: the camera measurement file it writes is read back
/// whole, every view has the board's twelve tags, and the truth file says
/// where the webcam really stood, off its setup; the noise-free corners sit
/// within a few sigmas of the noisy ones.
#[test]
fn a_simulated_webcam_writes_camera_measurements() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm-webcam");
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    let setup = data.join("setup.toml");
    let poses = plan(dir.path(), "poses.csv", &["--camera", p(&setup)]);
    assert!(!poses.is_empty());
    let run = lrmcal(&[
        "simulate",
        "--camera",
        p(&setup),
        "--poses",
        p(&out("poses.csv")),
        "--loads",
        "0,0.0663",
        "--out",
        p(&out("views.csv")),
        "--noise-free",
        p(&out("exact.csv")),
        "--truth",
        p(&out("truth.json")),
    ]);
    let message = text(&run);
    assert!(run.status.success(), "{message}");
    assert!(
        message.contains("mean distance nominal model and setup"),
        "{message}"
    );
    let seen = views::read(&out("views.csv")).unwrap();
    let exact = views::read(&out("exact.csv")).unwrap();
    assert_eq!(seen.len(), exact.len());
    assert!(seen.len() > poses.len(), "{} views", seen.len());
    let mut worst: f64 = 0.0;
    for (a, b) in seen.iter().zip(&exact) {
        assert_eq!(
            (a.pose, a.load_kg, a.approach),
            (b.pose, b.load_kg, b.approach)
        );
        assert_eq!(a.tags.len(), 12);
        for (s, e) in a.tags.iter().zip(&b.tags) {
            for (u, v) in s.corners_px.iter().zip(&e.corners_px) {
                worst = worst.max((u[0] - v[0]).abs()).max((u[1] - v[1]).abs());
            }
        }
    }
    assert!(worst > 0.0 && worst < 6.0 * 0.3, "{worst}");

    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out("truth.json")).unwrap()).unwrap();
    let told = setup::read(&setup).unwrap();
    let xyz: Vec<f64> = truth["webcam"]["camera"]["xyz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let off = (Vector3::from_column_slice(&xyz) - Vector3::from(told.camera.xyz)).norm();
    assert!(off > 0.0 && off < 0.15, "{off}");
    assert_eq!(truth["webcam"]["pixel_noise_px"], 0.3);
}

/// A camera that sees the board at none of the poses is said so, and no
/// file is written.
#[test]
fn a_webcam_that_sees_nothing_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    files(
        dir.path(),
        &SETUP.replace("[800.0, 0.0, 250.0]", "[-800.0, 0.0, 250.0]"),
    );
    let out = dir.path().join("views.csv");
    let run = lrmcal(&[
        "simulate",
        "--camera",
        p(&dir.path().join("setup.toml")),
        "--out",
        p(&out),
    ]);
    let message = text(&run);
    assert_eq!(run.status.code(), Some(2), "{message}");
    assert!(message.contains("sees the board at none"), "{message}");
    assert!(!out.exists());
}

/// `identify --camera`: the corners a simulated webcam saw at 40 poses fit
/// the arm, the board and the camera; the calibration file is written, the
/// camera's place in the base frame printed, and the held-out poses' error
/// falls from centimetres to about a millimetre. A tag the board does not
/// have is refused naming the file and the pose, and nothing is written.
#[test]
fn a_webcams_corners_calibrate_the_arm() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm-webcam");
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    let setup = data.join("setup.toml");
    let planned = plan(dir.path(), "planned.csv", &["--camera", p(&setup)]);
    // The poses the camera really saw: 40 to fit, 10 to validate.
    let seen = seen_views(dir.path(), &setup);
    assert!(
        seen.len() > 60 && seen.len() < planned.len(),
        "{} seen",
        seen.len()
    );
    let chosen = &seen[..50];
    views::write(&out("views.csv"), chosen, &[model::JointKind::Revolute; 6]).unwrap();
    let mut list = String::from("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,role\n");
    for (k, v) in chosen.iter().enumerate() {
        let q: Vec<String> = v
            .pose
            .q
            .iter()
            .map(|a| a.to_degrees().to_string())
            .collect();
        let role = if k < 40 { "fit" } else { "validate" };
        list.push_str(&format!("{},{},{role}\n", v.pose.id, q.join(",")));
    }
    std::fs::write(out("list.csv"), list).unwrap();
    let run = lrmcal(&[
        "identify",
        "--camera",
        p(&setup),
        "--measurements",
        p(&out("views.csv")),
        "--poses",
        p(&out("list.csv")),
        "--out",
        p(&out("cal")),
    ]);
    let message = text(&run);
    assert!(run.status.success(), "{message}");
    assert!(
        message.contains("camera in the arm's base frame"),
        "{message}"
    );
    assert!(message.contains("static_transform_publisher"), "{message}");
    assert!(
        message.contains("reprojection error at the") && message.contains("px, rms"),
        "{message}"
    );
    assert!(out("cal/calibration-elasto-kinematic-servo.json").exists());
    // The camera's files for ROS: the lens as told (held), and the launch
    // file publishing the transform the output printed.
    let lens = intrinsics_file::read(&out("cal/camera_info-elasto-kinematic-servo.yaml")).unwrap();
    assert_eq!(lens, setup::read(&setup).unwrap().intrinsics);
    let launch =
        std::fs::read_to_string(out("cal/camera_tf-elasto-kinematic-servo.launch.xml")).unwrap();
    let printed = message
        .lines()
        .find_map(|l| l.split("static_transform_publisher ").nth(1))
        .unwrap();
    assert!(launch.contains(&format!("args=\"{printed}\"")), "{launch}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out("cal/report.json")).unwrap()).unwrap();
    let validation = &report["options"][0]["validation"];
    let (before, after) = (
        validation["before"]["mean_m"].as_f64().unwrap(),
        validation["after"]["mean_m"].as_f64().unwrap(),
    );
    assert!(before > 0.01 && after < 0.002, "{before} -> {after} m");
    // The camera on the report and its page: where it stands, its lens and
    // the pixels, the held-out ones before and after.
    let camera = &report["options"][0]["camera"];
    assert!(
        camera["fit_px"]["median_px"].as_f64().unwrap() < 1.0,
        "{camera}"
    );
    assert_eq!(camera["lens_refined"], false);
    let pixels = &validation["pixels"];
    assert!(
        pixels["after"]["median_px"].as_f64().unwrap()
            < 0.2 * pixels["before"]["median_px"].as_f64().unwrap(),
        "{pixels}"
    );
    let page = std::fs::read_to_string(out("cal/report.html")).unwrap();
    assert!(page.contains("id=\"camera-table-0\""), "no camera table");
    // The file means the same to every reader: predict and the board take it.
    let cal = out("cal/calibration-elasto-kinematic-servo.json");
    let run = lrmcal(&[
        "predict",
        "--arm",
        p(&cal),
        "--poses",
        p(&out("list.csv")),
        "--load-kg",
        "0.0663",
        "--out",
        p(&out("predicted.csv")),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    let run = lrmcal(&["push", p(&cal), "--dry-run"]);
    assert!(run.status.success(), "{}", text(&run));
    // validate reads the camera's measurements of poses the fit never saw.
    views::write(
        &out("other.csv"),
        &seen[50..],
        &[model::JointKind::Revolute; 6],
    )
    .unwrap();
    let said = validate_camera(&setup, &cal, &out("other.csv"), &[]);
    let reduction = reduction_pct(&said);
    assert!(said.contains("corners") && reduction > 80.0, "{said}");
    assert!(said.contains("reprojection error over the"), "{said}");

    // A tag of another board.
    let foreign = std::fs::read_to_string(out("views.csv"))
        .unwrap()
        .replacen(",0,0,", ",40,0,", 1);
    std::fs::write(out("foreign.csv"), foreign).unwrap();
    let run = lrmcal(&[
        "identify",
        "--camera",
        p(&setup),
        "--measurements",
        p(&out("foreign.csv")),
        "--out",
        p(&out("refused")),
    ]);
    let message = text(&run);
    assert_eq!(run.status.code(), Some(3), "{message}");
    assert!(
        message.contains("foreign.csv") && message.contains("tag 40"),
        "{message}"
    );
    assert!(!out("refused").exists());
}

/// `identify --camera --refine-intrinsics`: the setup's intrinsics file is
/// off the webcam's lens (focal lengths 3 % short, k1 0.04 and k2 0.03
/// off), as a lens's nominal figures are. Refined, the lens comes out near
/// the webcam's (the camera_info written beside the calibration; fx 883.5
/// told, 909.5 refined, 910 true), and `validate --intrinsics` with it
/// meets held-out corners closer than the lens held (0.61 against 0.89 px
/// median). In pixels the arm's parameters absorb most of a wrong focal
/// length; it shows in depth, where the engine's `camera_fit` test judges
/// it (the camera 22 mm off held, 0.14 mm refined).
#[test]
fn a_lens_off_its_file_is_refined() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm-webcam");
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    let true_setup = data.join("setup.toml");
    plan(dir.path(), "planned.csv", &["--camera", p(&true_setup)]);
    let seen = seen_views(dir.path(), &true_setup);
    // Every other pose fitted, the rest held out: both spread over the grid.
    split_views(dir.path(), &seen, 2);
    // The same setup, its lens told off.
    let truth = setup::read(&true_setup).unwrap().intrinsics;
    let told = Intrinsics {
        fx: truth.fx / 1.03,
        fy: truth.fy / 1.03,
        cx: truth.cx - 12.0,
        distortion: [
            truth.distortion[0] - 0.04,
            truth.distortion[1],
            truth.distortion[2],
            truth.distortion[3],
            truth.distortion[4],
        ],
        ..truth.clone()
    };
    for name in ["board.yaml", "setup.toml"] {
        std::fs::copy(data.join(name), out(name)).unwrap();
    }
    std::fs::write(
        out("camera_info.yaml"),
        intrinsics_file::to_camera_info(&told, "told"),
    )
    .unwrap();
    let (setup_file, views_file, other_file) =
        (out("setup.toml"), out("views.csv"), out("other.csv"));
    let identify = |extra: &[&str], folder: &str| {
        let folder = out(folder);
        let mut args = vec![
            "identify",
            "--camera",
            p(&setup_file),
            "--measurements",
            p(&views_file),
            "--out",
            p(&folder),
        ];
        args.extend_from_slice(extra);
        let run = lrmcal(&args);
        assert!(run.status.success(), "{}", text(&run));
        text(&run)
    };
    let validate = |folder: &str, extra: &[&str]| -> f64 {
        let cal = out(folder).join("calibration-elasto-kinematic-servo.json");
        let said = validate_camera(&setup_file, &cal, &other_file, extra);
        // The median reprojection error after calibration, px.
        said.lines()
            .filter(|l| l.starts_with("reprojection error over"))
            .find_map(|l| l.split("median ").nth(1))
            .and_then(|r| r.split(" -> ").nth(1))
            .and_then(|r| r.trim_end_matches(',').split(',').next())
            .and_then(|r| r.trim().parse().ok())
            .unwrap_or_else(|| panic!("{said}"))
    };
    identify(&[], "held");
    let said = identify(&["--refine-intrinsics"], "refined");
    assert!(said.contains("lens refined: fx"), "{said}");
    let info = out("refined/camera_info-elasto-kinematic-servo.yaml");
    let refined = intrinsics_file::read(&info).unwrap();
    let held_px = validate("held", &[]);
    let refined_px = validate("refined", &["--intrinsics", p(&info)]);
    eprintln!(
        "fx told {:.1}, refined {:.1}, true {:.1}; held-out median {held_px:.2} px held, {refined_px:.2} px refined",
        told.fx, refined.fx, truth.fx
    );
    assert!((refined.fx / truth.fx - 1.0).abs() < 0.01, "{refined:?}");
    assert!(
        refined_px < held_px && refined_px < 1.0,
        "{held_px} {refined_px}"
    );
}

/// The camera on the flange, the board standing before the arm (the
/// bundled `setup-eye-in-hand.toml`): the same commands plan the poses it
/// sees the board from, simulate its views, fit the arm and the camera,
/// and check held-out views. The camera is put on the flange, its
/// transform published from there, and the board placed in the base frame.
#[test]
fn a_camera_on_the_flange_calibrates_the_arm() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm-webcam");
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    let setup = data.join("setup-eye-in-hand.toml");
    // The board shows in few grid poses: more random ones.
    let run = lrmcal(&[
        "plan",
        "--camera",
        p(&setup),
        "--random",
        "150",
        "--out",
        p(&out("planned.csv")),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    let seen = seen_views(dir.path(), &setup);
    assert!(seen.len() > 60, "{} seen", seen.len());
    split_views(dir.path(), &seen, 3);
    let run = lrmcal(&[
        "identify",
        "--camera",
        p(&setup),
        "--measurements",
        p(&out("views.csv")),
        "--out",
        p(&out("cal")),
    ]);
    let message = text(&run);
    assert!(run.status.success(), "{message}");
    assert!(
        message.contains("camera in the arm's last frame (the flange")
            && message.contains("--frame-id flange")
            && message.contains("board in the arm's base frame"),
        "{message}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out("cal/report.json")).unwrap()).unwrap();
    assert_eq!(report["options"][0]["camera"]["mount"], "eye-in-hand");
    // The camera on the flange where the setup says, give or take what the
    // simulator drew (millimetres).
    let xyz = &report["options"][0]["camera"]["xyz_mm"];
    let told = [30.0, 0.0, 20.0];
    for (axis, t) in told.iter().enumerate() {
        let v = xyz[axis].as_f64().unwrap();
        assert!((v - t).abs() < 10.0, "{xyz}");
    }
    let said = validate_camera(
        &setup,
        &out("cal/calibration-elasto-kinematic-servo.json"),
        &out("other.csv"),
        &[],
    );
    assert!(reduction_pct(&said) > 80.0, "{said}");
}
