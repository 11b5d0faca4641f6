//! The whole calibration through the `lrmcal` binary, as a user runs it, on a
//! small problem: `plan` → `simulate` (model-only: no unmodelled effects, no
//! noise, both loads) → `identify` → `validate` → `predict --arm
//! calibration.json`. Checks the files each step leaves (headers, schema,
//! documented fields) and that the calibrated arm predicts held-out poses far
//! better than the nominal one; then the exit codes of a few bad inputs.

mod common;

use common::{default_calibration_file, lrmcal};

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use host::error::exit_codes;
use lrmcal_core::dataset::{Measurement, PoseRow};
use lrmcal_core::io::{measurements, pose_list, predictions};
use serde_json::Value;

/// The paper's payload, kg.
const LOAD_KG: f64 = 0.0663;
/// Poses DETMAX selects for the fit.
const SELECT: usize = 30;

/// Runs `lrmcal`, asserting success; returns standard output.
fn ok(args: &[&str]) -> String {
    let out = lrmcal(args);
    assert!(
        out.status.success(),
        "lrmcal {} failed ({:?}): {}",
        args.join(" "),
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `lrmcal`, asserting exit code `code`; returns standard error.
fn fails(args: &[&str], code: u8) -> String {
    let out = lrmcal(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(i32::from(code)),
        "lrmcal {}: {stderr}",
        args.join(" ")
    );
    stderr
}

fn s(path: &Path) -> &str {
    path.to_str().expect("temporary paths are UTF-8")
}

fn header(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().next().unwrap_or_default().to_owned()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The part of `docs/FORMATS.md` about the JSON files (arms, calibration, report, truth).
fn json_formats_doc() -> &'static str {
    const FORMATS: &str = include_str!("../../docs/FORMATS.md");
    let start = FORMATS
        .find("\n## Arms in JSON files")
        .expect("docs/FORMATS.md has a section on arms in JSON files");
    &FORMATS[start..]
}

/// Asserts every object key in `value` (except under the keys in `free_form`)
/// is documented as `` `key` `` in `doc`.
fn assert_documented(value: &Value, doc: &str, free_form: &[&str], file: &str) {
    let mut keys = BTreeSet::new();
    collect_keys(value, free_form, &mut keys);
    let missing: Vec<_> = keys
        .iter()
        .filter(|k| !doc.contains(&format!("`{k}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "fields of {file} missing from docs/FORMATS.md: {missing:?}"
    );
}

fn collect_keys(value: &Value, free_form: &[&str], keys: &mut BTreeSet<String>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                keys.insert(k.clone());
                if !free_form.contains(&k.as_str()) {
                    collect_keys(v, free_form, keys);
                }
            }
        }
        Value::Array(items) => items.iter().for_each(|v| collect_keys(v, free_form, keys)),
        _ => {}
    }
}

/// Mean 3D distance (m) between predictions and the measurements of the same poses under `load_kg`.
fn mean_error_m(predicted: &Path, measured: &[Measurement], load_kg: f64) -> f64 {
    let truth: HashMap<u32, _> = measured
        .iter()
        .filter(|m| m.load_kg == load_kg)
        .map(|m| (m.pose.id, m.position))
        .collect();
    let rows = predictions::read(predicted).unwrap();
    assert!(!rows.is_empty());
    let sum: f64 = rows
        .iter()
        .map(|p| (p.position - truth[&p.pose]).norm())
        .sum();
    sum / rows.len() as f64
}

#[test]
fn plan_simulate_identify_validate_predict() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| -> PathBuf { dir.path().join(name) };
    let candidates = path("candidates.csv");
    let poses = path("poses.csv");
    let meas = path("measurements.csv");
    let truth = path("truth.json");
    let cal_dir = path("cal");

    // plan: the candidate poses, a pose list with the contract's header.
    ok(&["plan", "--out", s(&candidates)]);
    assert_eq!(
        header(&candidates),
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg"
    );
    let all = pose_list::read(&candidates).unwrap();
    assert!(all.len() > 300, "{} candidates", all.len());

    // A small pose set: every fourth candidate (ids kept).
    let small: Vec<PoseRow> = all.iter().step_by(4).copied().collect();
    pose_list::write(&poses, &small, &[model::JointKind::Revolute; 6]).unwrap();

    // simulate: model-only (no unmodelled effects, no noise), both loads, with the truth file.
    ok(&[
        "simulate",
        "--poses",
        s(&poses),
        "--model-only",
        "--loads",
        &format!("0,{LOAD_KG}"),
        "--seed",
        "3",
        "--out",
        s(&meas),
        "--truth",
        s(&truth),
    ]);
    assert_eq!(
        header(&meas),
        "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm"
    );
    let measured = measurements::read(&meas).unwrap();
    assert_eq!(measured.len(), 2 * small.len());
    let truth_json = json(&truth);
    assert_eq!(truth_json["schema"], "lrmcal-sim-truth/2");
    assert_eq!(truth_json["seed"], 3);
    assert_documented(
        &truth_json,
        json_formats_doc(),
        &["config", "errors"],
        "truth.json",
    );

    // identify: DETMAX picks SELECT poses, fit under the paper's load.
    let select = SELECT.to_string();
    let load = LOAD_KG.to_string();
    ok(&[
        "identify",
        "--measurements",
        s(&meas),
        "--candidates",
        s(&poses),
        "--select",
        &select,
        "--load-kg",
        &load,
        "--starts",
        "2",
        "--out",
        s(&cal_dir),
    ]);
    let cal = cal_dir.join(default_calibration_file());
    let report = cal_dir.join("report.json");
    let cal_json = json(&cal);
    assert_eq!(cal_json["schema"], "lrmcal-calibration");
    assert_eq!(
        cal_json["schema_version"],
        lrmcal_core::io::calibration_file::SCHEMA_VERSION
    );
    assert_eq!(
        cal_json["option"],
        lrmcal_engine::calib::parameters::option::DEFAULT.name()
    );
    assert_eq!(cal_json["loads_kg"], serde_json::json!([LOAD_KG]));
    assert_ne!(cal_json["arm"], cal_json["nominal"]);
    let used: BTreeSet<u32> = cal_json["poses_used"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as u32)
        .collect();
    assert_eq!(used.len(), SELECT);
    assert!(used.iter().all(|id| small.iter().any(|r| r.pose.id == *id)));
    assert_documented(&cal_json, json_formats_doc(), &[], "the calibration file");
    let report_json = json(&report);
    assert_eq!(report_json["schema"], "lrmcal-report");
    assert_eq!(
        report_json["schema_version"],
        lrmcal_engine::calib::results::report::REPORT_SCHEMA_VERSION
    );
    assert_documented(
        &report_json,
        json_formats_doc(),
        &["measurements"],
        "report.json",
    );

    // validate: one line per load of the file, each reducing the error.
    let table = ok(&[
        "validate",
        "--calibration",
        s(&cal),
        "--measurements",
        s(&meas),
    ]);
    let reductions: Vec<f64> = table
        .lines()
        .filter_map(|l| l.trim().strip_suffix('%'))
        .filter_map(|l| l.split_whitespace().last()?.parse().ok())
        .collect();
    assert_eq!(reductions.len(), 2, "{table}");
    assert!(reductions.iter().all(|r| *r > 90.0), "{table}");

    // predict the held-out poses with the calibrated and the nominal arm, under both loads.
    let held_out: Vec<PoseRow> = small
        .iter()
        .filter(|r| !used.contains(&r.pose.id))
        .copied()
        .collect();
    let held_out_path = path("held_out.csv");
    pose_list::write(&held_out_path, &held_out, &[model::JointKind::Revolute; 6]).unwrap();
    for load_kg in [LOAD_KG, 0.0] {
        let load = load_kg.to_string();
        let (calibrated, nominal) = (path("calibrated.csv"), path("nominal.csv"));
        ok(&[
            "predict",
            "--arm",
            s(&cal),
            "--poses",
            s(&held_out_path),
            "--load-kg",
            &load,
            "--out",
            s(&calibrated),
        ]);
        ok(&[
            "predict",
            "--poses",
            s(&held_out_path),
            "--load-kg",
            &load,
            "--out",
            s(&nominal),
        ]);
        assert_eq!(header(&calibrated), "pose,x_mm,y_mm,z_mm");
        let before = mean_error_m(&nominal, &measured, load_kg);
        let after = mean_error_m(&calibrated, &measured, load_kg);
        // The simulated arm is some 20 mm off the nominal one; the model is
        // exact here, so the calibrated arm must be within a tenth of that.
        assert!(before > 0.005, "nominal arm only {before} m off");
        assert!(
            after < 0.1 * before,
            "{load_kg} kg: calibrated {after} m vs nominal {before} m"
        );
    }
}

/// A valid calibration file of the bundled arm, made through the library.
fn calibration_json() -> String {
    use lrmcal_core::io::calibration_file::{CalibrationFile, ErrorStats, SCHEMA, SCHEMA_VERSION};
    use lrmcal_engine::calib::ModelOption;
    let nominal = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let mut arm = nominal;
    arm.joints[1].compliance = 0.1;
    CalibrationFile {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        option: ModelOption::Elastic,
        nominal,
        arm,
        parameters: vec![],
        at_bound: vec![],
        removed: vec![],
        poses_used: vec![1],
        loads_kg: vec![LOAD_KG],
        fit_residual: ErrorStats::of(&[1e-4]),
        converged: true,
        arm_name: None,
        joint_names: vec![],
        validation: None,
        registration: None,
        targets: vec![],
    }
    .to_json()
}

#[test]
fn bad_inputs_give_the_documented_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    let poses = path("poses.csv");
    std::fs::write(
        &poses,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n",
    )
    .unwrap();
    let out = path("out.csv");

    // A calibration file of this version is used (the control for what follows).
    let good = path("cal.json");
    std::fs::write(&good, calibration_json()).unwrap();
    ok(&[
        "predict",
        "--arm",
        s(&good),
        "--poses",
        s(&poses),
        "--out",
        s(&out),
    ]);

    // Another version of the calibration schema: invalid input, naming the field.
    let future = path("future.json");
    std::fs::write(
        &future,
        calibration_json().replace(
            &format!(
                "\"schema_version\": {}",
                lrmcal_core::io::calibration_file::SCHEMA_VERSION
            ),
            "\"schema_version\": 99",
        ),
    )
    .unwrap();
    let e = fails(
        &["predict", "--arm", s(&future), "--poses", s(&poses)],
        exit_codes::INVALID_INPUT,
    );
    assert!(
        e.contains("future.json") && e.contains("schema_version"),
        "{e}"
    );

    // A JSON file of another kind (the simulator's truth file).
    let truth = path("truth.json");
    ok(&[
        "simulate",
        "--poses",
        s(&poses),
        "--model-only",
        "--truth",
        s(&truth),
        "--out",
        s(&path("m.csv")),
    ]);
    let e = fails(
        &["predict", "--arm", s(&truth), "--poses", s(&poses)],
        exit_codes::INVALID_INPUT,
    );
    assert!(
        e.contains("truth.json") && e.contains("lrmcal-calibration"),
        "{e}"
    );

    // A measurement file with a column of another kind of file.
    let meas = path("bad.csv");
    std::fs::write(
        &meas,
        "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm,speed\n\
         1,0,0,0,0,0,0,0,1,2,3,4\n",
    )
    .unwrap();
    let e = fails(
        &[
            "identify",
            "--measurements",
            s(&meas),
            "--out",
            s(&path("cal")),
        ],
        exit_codes::INVALID_INPUT,
    );
    assert!(
        e.contains("bad.csv") && e.contains("line 1") && e.contains("column `speed`"),
        "{e}"
    );
    assert!(!path("cal").join("report.json").exists());

    // A calibration file that is not there.
    let e = fails(
        &[
            "validate",
            "--calibration",
            s(&path("missing.json")),
            "--measurements",
            s(&path("m.csv")),
        ],
        exit_codes::FILE_ACCESS,
    );
    assert!(e.contains("missing.json"), "{e}");

    // An arm file of no known kind: a usage error, before any file is read.
    let e = fails(
        &["predict", "--arm", "arm.yaml", "--poses", s(&poses)],
        exit_codes::USAGE,
    );
    assert!(e.contains(".toml") && e.contains(".json"), "{e}");
}
