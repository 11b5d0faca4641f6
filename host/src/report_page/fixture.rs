//! A small report for the page's tests: one option of ours, fitted from
//! 6 poses and validated on 4, with nothing suspect, joint 2's servo curve
//! identified; each test changes what its rule or section looks at.

use lrmcal_engine::calib::ParamKey;
use lrmcal_engine::calib::results::report::Report;
use serde_json::json;

/// The parameter called `name`.
pub fn key(name: &str) -> ParamKey {
    ParamKey::from_name(name).expect("a parameter name")
}

/// Error statistics with `mean` and `rms` (mm) over `count` measurements.
fn stats(count: usize, mean_mm: f64, rms_mm: f64) -> serde_json::Value {
    json!({
        "count": count, "mean_m": mean_mm / 1e3, "median_m": mean_mm / 1e3,
        "rms_m": rms_mm / 1e3, "p95_m": rms_mm * 1.5 / 1e3, "max_m": rms_mm * 2.0 / 1e3
    })
}

/// The fixture's report, as `lrmcal identify` would write it.
pub fn report() -> Report {
    let per_pose: Vec<_> = [
        (7, 30.0, 1.0),
        (8, 40.0, 1.2),
        (9, 35.0, 0.8),
        (10, 50.0, 1.1),
    ]
    .iter()
    .map(|&(pose, before, after)| {
        json!({"pose": pose, "target": 0, "before_mm": before, "after_mm": after,
                   "xyz_mm": [100.0 + f64::from(pose), -50.0, 200.0]})
    })
    .collect();
    let fitted: Vec<_> = (1..=6)
        .map(|pose| {
            let k = f64::from(pose);
            json!({"pose": pose, "load_kg": 0.0663, "target": 0,
                   "xyz_mm": [150.0 - 20.0 * k, 30.0 * k, 250.0 - 10.0 * k],
                   "before_mm": 30.0 + k, "after_mm": 0.5 + 0.1 * k, "loo_mm": 0.8 + 0.1 * k})
        })
        .collect();
    let knot = |name: &str, deg: f64, offset: f64, std: Option<f64>| json!({"name": name, "commanded_deg": deg, "offset_deg": offset, "std_deg": std});
    let curve: Vec<_> = (-40..=40)
        .map(|k| {
            let deg = 2.5 * f64::from(k);
            json!({"commanded_deg": deg, "offset_deg": 0.3 * (deg / 100.0), "std_deg": 0.02 + 0.0002 * deg.abs()})
        })
        .collect();
    let param = |name: &str, error: f64, std: Option<f64>| json!({"name": name, "error": error, "value": error, "std": std});
    let text = json!({
        "schema": "lrmcal-report",
        "schema_version": 5,
        "arm": "bundled:lrm",
        "candidates": 10,
        "identify_load_kg": 0.0663,
        "measurements": {"source": "measured.csv", "loads_kg": [0.0663]},
        "options": [{
            "option": "elasto-kinematic-servo",
            "identify_load_kg": 0.0663,
            "identifiability": {
                "candidates": 4, "kept": ["j2.d", "k2", "j6.backlash"],
                "removed": [{"name": "j1.d", "residual": 0.0,
                             "confounded_with": [{"name": "base.z", "coefficient": 1.0}]}],
                "svd_rank": 3, "kept_condition": 12.5
            },
            "selected_poses": [1, 2, 3, 4, 5, 6],
            "log_det": -3.5,
            "start_log_dets": [-3.5, -3.6],
            "observability": {"o1": 0.7, "o2": 0.01, "o3": 0.3, "o4": 0.004, "o5": 0.04},
            "fit": {
                "termination": "converged", "converged": true, "evaluations": 12,
                "active_set_rounds": 1, "failed_steps": 0, "irls_rounds": 2,
                "at_bound": [], "weak": [],
                "rms_before_mm": 40.0, "rms_after_mm": 0.9, "sigma_mm": 0.5,
                "condition": 80.0, "loo_mean_mm": 1.0,
                "parameters": [
                    param("j2.d", 0.001, Some(1e-5)),
                    param("k2", 0.002, Some(1e-4)),
                    param("j6.backlash", 0.01, Some(1e-3)),
                    param("j2.servo[1]", -0.005, Some(3e-4))
                ],
                "outliers": [],
                "per_pose": fitted
            },
            "knots": {"chosen": "50deg", "trials": [
                {"spacing": "25deg", "loo_mean_mm": 1.4, "failure": null},
                {"spacing": "50deg", "loo_mean_mm": 1.0, "failure": null},
                {"spacing": "100deg", "loo_mean_mm": null, "failure": "too few poses"}
            ]},
            "validation": {
                "load_kg": 0.0663, "before": stats(4, 38.75, 39.5), "after": stats(4, 1.03, 1.04),
                "reduction_pct": 97.3, "outliers": [], "per_pose": per_pose
            },
            "cross_load": null,
            "servo_curves": [{"joint": 2, "knots": [
                knot("j2.servo[1]", -100.0, -0.3, Some(0.017)),
                knot("j2.servo[5]", 0.0, 0.0, None),
                knot("j2.servo[9]", 100.0, 0.3, Some(0.02))
            ], "curve": curve}]
        }],
        "random_baseline": null,
        "o1_vs_poses": [],
        "error_vs_poses": [],
        "registration": {
            "base_xyz_mm": [100.0, -20.0, 5.0], "base_rpy_deg": [0.1, -0.2, 30.0],
            "base_tilt_deg": 0.2, "before_rms_mm": 1500.0, "after_rms_mm": 12.0,
            "after_max_mm": 30.0, "tool_mm": [0.0, 0.0, 40.0], "tool_turn": 0.8,
            "tool_turn_needed": 0.3, "left_out": []
        }
    });
    Report::parse(&text.to_string()).expect("the fixture is a report")
}
