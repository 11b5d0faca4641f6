//! Real measurements through the CLI: 23 poses of a UR10e measured by an
//! external instrument (public data, `tests/data/ur10e/NOTICE.md`), in the
//! instrument's own frame, with a target about 13 cm off the flange. The arm
//! file gives the target's place to the nearest 5 cm, as a ruler would (the
//! fit finds it); its base pose is unknown (zeros) and registration finds it.
//! Every fourth pose is held out; the rest are calibrated with the kinematic
//! option (the arm is rigid at this scale) and the held-out poses predicted.
//!
//! An independent least-squares fit of the same split (base, tool point and
//! the DH parameters, scipy's Levenberg–Marquardt) misses the held-out poses
//! by 4.3 mm on average, and by 4.1 mm fitting only the base and the tool
//! point: the data set is noise-dominated (its authors' fit: about 3.2 ->
//! 2.5 mm on all poses). Registration finds the target's place with the
//! base (3.2 mm RMS after it); with the base alone and the flange centre as
//! the tool point the arm missed by 163 mm.

/// Where the target sits in the flange frame (DH frame 6), m, to the nearest
/// 5 cm: the fit puts it at (-33, -123, 6) mm.
const TOOL_BY_RULER: [f64; 3] = [-0.05, -0.1, 0.0];

mod common;

use common::lrmcal;

use std::path::{Path, PathBuf};

use lrmcal_core::io::predictions;

/// The joint columns of the data set, base to tip.
const JOINT_COLUMNS: [&str; model::testing::TEST_ARM_JOINTS] = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
];

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ur10e")
        .join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 temporary path")
}

/// The data set's rows as (pose id, joint angles in degrees, position in mm).
fn rows() -> Vec<(u32, [f64; model::testing::TEST_ARM_JOINTS], [f64; 3])> {
    let mut reader = csv::Reader::from_path(data("calibration.csv")).expect("the data set");
    let header = reader.headers().expect("a header").clone();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("column {name}"))
    };
    let q_cols = JOINT_COLUMNS.map(column);
    let xyz_cols = ["x1", "y1", "z1"].map(column);
    reader
        .records()
        .enumerate()
        .map(|(i, r)| {
            let r = r.expect("a row");
            let num = |c: usize| r[c].parse::<f64>().expect("a number");
            (
                i as u32 + 1,
                q_cols.map(|c| num(c).to_degrees()),
                xyz_cols.map(|c| num(c) * 1e3),
            )
        })
        .collect()
}

/// Writes `rows` as an lrmcal measurement file.
fn write_measurements(
    path: &Path,
    rows: &[(u32, [f64; model::testing::TEST_ARM_JOINTS], [f64; 3])],
) {
    let mut text =
        String::from("pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n");
    for (id, q, p) in rows {
        let q: Vec<String> = q.iter().map(|v| format!("{v:.9}")).collect();
        text.push_str(&format!(
            "{id},0,{},{:.6},{:.6},{:.6}\n",
            q.join(","),
            p[0],
            p[1],
            p[2]
        ));
    }
    std::fs::write(path, text).expect("write the measurement file");
}

/// Calibrates the fitted split with the arm file's tool point at `tool`
/// (frame 6, m) and returns the held-out errors' mean (mm), the errors and
/// what identify printed.
fn held_out_with_tool(tool: [f64; 3]) -> (f64, Vec<f64>, String) {
    let dir = tempfile::tempdir().unwrap();
    let all = rows();
    assert_eq!(all.len(), 23);
    let (held, fit): (Vec<_>, Vec<_>) = all.iter().partition(|(id, _, _)| id % 4 == 0);
    let fit_csv = dir.path().join("fit.csv");
    let held_csv = dir.path().join("held.csv");
    write_measurements(&fit_csv, &fit);
    write_measurements(&held_csv, &held);

    let arm = dir.path().join("ur10e.toml");
    let nominal = std::fs::read_to_string(data("ur10e.toml")).expect("the arm file");
    let [x, y, z] = tool;
    let nominal = nominal.replacen(
        "[tool]\nxyz = [0.0, 0.0, 0.0]",
        &format!("[tool]\nxyz = [{x:?}, {y:?}, {z:?}]"),
        1,
    );
    assert!(
        nominal.contains(&format!("xyz = [{x:?}")),
        "the arm file's tool point is set"
    );
    std::fs::write(&arm, nominal).expect("write the arm file");

    let out = dir.path().join("cal");
    let run = lrmcal(&[
        "identify",
        "--arm",
        s(&arm),
        "--measurements",
        s(&fit_csv),
        "--option",
        "kinematic",
        "--out",
        s(&out),
    ]);
    let printed =
        String::from_utf8_lossy(&run.stdout).into_owned() + &String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{printed}");

    let predicted = dir.path().join("predicted.csv");
    let cal = out.join("calibration-kinematic.json");
    let run = lrmcal(&[
        "predict",
        "--arm",
        s(&cal),
        "--poses",
        s(&held_csv),
        "--out",
        s(&predicted),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let predicted = predictions::read(&predicted).unwrap();
    let errors: Vec<f64> = held
        .iter()
        .map(|(id, _, p)| {
            let at = predicted
                .iter()
                .find(|x| x.pose == *id)
                .unwrap_or_else(|| panic!("pose {id} predicted"));
            let d = at.position * 1e3 - nalgebra::Vector3::from(*p);
            d.norm()
        })
        .collect();
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    (mean, errors, printed)
}

#[test]
fn a_real_ur10e_in_its_instruments_frame_calibrates_to_the_independent_fits_accuracy() {
    let (mean, errors, printed) = held_out_with_tool(TOOL_BY_RULER);
    println!("{printed}\nheld-out errors (mm): {errors:.2?}, mean {mean:.2}");
    // The independent fit of this split: 4.3 mm (4.1 with base and tool only).
    assert!(
        mean < 5.0,
        "held-out mean {mean:.2} mm: {errors:.2?}\n{printed}"
    );
    // Registration found the target's place with the base, to a few mm of
    // where the fit puts it, (-33, -123, 6) mm.
    assert!(
        printed.contains("tool point found with it: (-3") && printed.contains("after registration"),
        "{printed}"
    );
}

/// The arm file's tool point at the flange centre, 13 cm from the target:
/// registration finds the target's place with the base (the base alone
/// left the arm 163 mm from the points and identify refused), and the
/// calibration is the one with the ruler's tool point.
#[test]
fn a_target_13_cm_from_the_files_tool_point_is_found_by_registration() {
    let (ruler, _, _) = held_out_with_tool(TOOL_BY_RULER);
    let (mean, errors, printed) = held_out_with_tool([0.0, 0.0, 0.0]);
    println!("{printed}\nheld-out errors (mm): {errors:.2?}, mean {mean:.2}");
    assert!(
        (mean - ruler).abs() < 0.01,
        "{mean:.3} vs {ruler:.3} mm\n{printed}"
    );
    assert!(
        printed.contains("(the arm file: (0.0, 0.0, 0.0) mm)"),
        "{printed}"
    );
}
