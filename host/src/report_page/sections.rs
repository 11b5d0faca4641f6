//! The page's sections, each from the report alone: the summary table,
//! the suspect measurements, the selection, the model and knot choices and
//! the registration ([`per_option`] is the shape of those that are a table
//! per option). A section whose data the run did not
//! produce says so instead of being left out, so every page has the same
//! outline.

use lrmcal_core::camera::Mount;
use lrmcal_engine::calib::results::report::{OptionReport, PixelErrors, Report};
use lrmcal_engine::calib::results::summary::{lens, servo_smoothness};

use super::html::{escape, num, opt_num, para, table};

/// An option's name and the load it was fitted with, for headings.
pub fn title(o: &OptionReport) -> String {
    format!("{} (fitted with {} kg)", o.option, o.identify_load_kg)
}

/// The summary table: per option, the fit and the validation before → after.
pub fn summary(report: &Report) -> String {
    let rows: Vec<Vec<String>> = report
        .options
        .iter()
        .map(|o| {
            let f = &o.fit;
            let v = o.validation.as_ref();
            let mm = |m: f64| num(m * 1e3, 2);
            vec![
                o.option.to_string(),
                o.identify_load_kg.to_string(),
                f.parameters.len().to_string(),
                o.selected_poses.len().to_string(),
                format!("{} → {}", num(f.rms_before_mm, 2), num(f.rms_after_mm, 2)),
                num(f.loo_mean_mm, 2),
                v.map_or("–".into(), |v| v.after.count.to_string()),
                v.map_or("–".into(), |v| {
                    format!("{} → {}", mm(v.before.mean_m), mm(v.after.mean_m))
                }),
                v.map_or("–".into(), |v| {
                    format!("{} → {}", mm(v.before.rms_m), mm(v.after.rms_m))
                }),
                v.map_or("–".into(), |v| {
                    format!("{} → {}", mm(v.before.max_m), mm(v.after.max_m))
                }),
                v.map_or("–".into(), |v| num(v.reduction_pct, 1)),
                o.cross_load.as_ref().map_or("–".into(), |c| {
                    format!(
                        "{} kg: {} → {} ({} %)",
                        c.load_kg,
                        mm(c.before.mean_m),
                        mm(c.after.mean_m),
                        num(c.reduction_pct, 1)
                    )
                }),
            ]
        })
        .collect();
    table(
        "summary-table",
        "Per model option: the fit (RMS residual on the fitted poses, leave-one-out mean) and the validation on the poses held out, before → after calibration (mm)",
        &[
            "option",
            "load kg",
            "parameters",
            "poses fitted",
            "fit RMS",
            "fit leave-one-out mean",
            "held-out measurements",
            "held-out mean",
            "held-out RMS",
            "held-out max",
            "reduction %",
            "cross-load mean",
        ],
        &rows,
    )
}

/// The measurements the fit and the validation named as far off the others,
/// and those registration left out.
pub fn suspect(report: &Report) -> String {
    let mut rows: Vec<Vec<String>> = Vec::new();
    for o in &report.options {
        rows.extend(o.fit.outliers.iter().map(|x| {
            vec![
                x.pose.to_string(),
                x.load_kg.to_string(),
                o.option.to_string(),
                "fit: down-weighted".into(),
                num(x.residual_mm, 2),
                num(x.weight, 2),
            ]
        }));
        for v in o.validation.iter().chain(&o.cross_load) {
            rows.extend(v.outliers.iter().map(|x| {
                vec![
                    x.pose.to_string(),
                    x.load_kg.to_string(),
                    o.option.to_string(),
                    "held out: far beyond the others' error".into(),
                    num(x.error_mm, 2),
                    "–".into(),
                ]
            }));
        }
    }
    if let Some(r) = &report.registration {
        rows.extend(r.left_out.iter().map(|x| {
            vec![
                x.pose.to_string(),
                x.load_kg.to_string(),
                "–".into(),
                "left out of the registration as far off".into(),
                "–".into(),
                "–".into(),
            ]
        }));
    }
    let mut out = if rows.is_empty() {
        para(
            "No measurement was named as far off the others: the robust fit kept every one at full weight and no held-out pose stands out.",
        )
    } else {
        String::new()
    };
    out.push_str(&table(
        "suspect-table",
        "Measurements far off the others (error in mm)",
        &[
            "pose",
            "load kg",
            "option",
            "why",
            "residual / error mm",
            "weight",
        ],
        &rows,
    ));
    out
}

/// Each option's selection: how many poses, the observability indices, and
/// DETMAX against random sets when the demo compared them.
pub fn selection(report: &Report) -> String {
    let rows: Vec<Vec<String>> = report
        .options
        .iter()
        .map(|o| {
            let b = &o.observability;
            vec![
                title(o),
                o.selected_poses.len().to_string(),
                num(b.o1, 4),
                format!("{:.3e}", b.o2),
                num(b.o3, 4),
                format!("{:.3e}", b.o4),
                num(b.o5, 4),
                num(o.log_det, 2),
                num(o.identifiability.kept_condition, 1),
            ]
        })
        .collect();
    let mut out = table(
        "selection-table",
        "The poses fitted: observability indices of the selection (O1 is what DETMAX maximises)",
        &[
            "option",
            "poses",
            "O1",
            "O2",
            "O3",
            "O4",
            "O5",
            "ln det",
            "condition of the kept columns",
        ],
        &rows,
    );
    if let Some(b) = &report.random_baseline {
        out.push_str(&para(&format!(
            "DETMAX against {} random {}-pose sets ({}): O1 {:.4} against a median of {:.4}; validation mean {:.2} mm against a median of {:.2} mm.",
            b.sets, b.poses, b.option, b.detmax_o1, b.random_o1_median, b.detmax_mean_m * 1e3, b.random_mean_median_m * 1e3
        )));
    }
    for o in &report.options {
        let ids: Vec<String> = o.selected_poses.iter().map(u32::to_string).collect();
        out.push_str(&format!(
            "<details><summary>{}: the {} poses fitted</summary><p>{}</p></details>\n",
            escape(&title(o)),
            ids.len(),
            escape(&ids.join(", "))
        ));
    }
    out
}

/// One table per option that has what `part` picks out, made by `table`
/// from the option's place in the report, the option and that part; the
/// sentence `none` when no option has it. The shape of every section that
/// is a table per option (the model ladder, the knots, play and springs).
pub fn per_option<T>(
    report: &Report,
    part: impl Fn(&OptionReport) -> Option<&T>,
    none: &str,
    table: impl Fn(usize, &OptionReport, &T) -> String,
) -> String {
    let out: String = report
        .options
        .iter()
        .enumerate()
        .filter_map(|(i, o)| part(o).map(|t| table(i, o, t)))
        .collect();
    if out.is_empty() { para(none) } else { out }
}

/// The model each laddered option kept and the rungs compared.
pub fn model(report: &Report) -> String {
    per_option(
        report,
        |o| o.model.as_ref(),
        "No option of this run was fitted as a ladder of models (ours and elasto-kinematic are): each holds the parameters it was asked for.",
        |i, o, m| {
            let rows: Vec<Vec<String>> = m
                .trials
                .iter()
                .map(|t| {
                    vec![
                        t.model.to_string(),
                        t.parameters.to_string(),
                        match (t.loo_mean_mm, t.loo_se_mm) {
                            (Some(mean), Some(se)) => format!("{mean:.3} ± {se:.3}"),
                            _ => "-".into(),
                        },
                        if t.model == m.chosen {
                            "kept".into()
                        } else {
                            t.failure.clone().unwrap_or_default()
                        },
                    ]
                })
                .collect();
            table(
                &format!("model-{i}"),
                &format!(
                    "{}: holds the {} model, the simplest whose fit predicts the fitted poses left out within one standard error of the best",
                    title(o),
                    m.chosen
                ),
                &[
                    "model",
                    "parameters",
                    "leave-one-out mean ± standard error, mm",
                    "outcome",
                ],
                &rows,
            )
        },
    )
}

/// The servo curves' knot spacing chosen and the ones compared.
pub fn knots(report: &Report) -> String {
    per_option(
        report,
        |o| o.knots.as_ref(),
        "No option of this run fits servo curves: there was no knot spacing to choose.",
        |i, o, k| {
            let rows: Vec<Vec<String>> = k
                .trials
                .iter()
                .map(|t| {
                    vec![
                        format!(
                            "every {:.0}° ({} knots)",
                            t.spacing.degrees(),
                            t.spacing.knots()
                        ),
                        opt_num(t.loo_mean_mm, 2),
                        if t.spacing == k.chosen {
                            "chosen".into()
                        } else {
                            t.failure.clone().unwrap_or_default()
                        },
                    ]
                })
                .collect();
            let why = match o.fit.servo_correlation_deg {
                // Under the prior, the finest grid alone; the curves'
                // smoothness is the correlation length the fit chose.
                Some(deg) => format!(
                    "the finest grid, the curves kept smooth by the prior: {}",
                    servo_smoothness(deg)
                ),
                None => "the spacing whose fit best predicts each fitted pose left out".into(),
            };
            table(
                &format!("knots-{i}"),
                &format!(
                    "{}: knots every {:.0}°, {why}",
                    title(o),
                    k.chosen.degrees()
                ),
                &["spacing", "leave-one-out mean mm", "outcome"],
                &rows,
            )
        },
    )
}

/// Where registration found the arm's base, and how far the arm was from the measurements.
pub fn registration(report: &Report) -> String {
    let Some(r) = &report.registration else {
        return para(
            "The arm was not registered: the arm file's base was kept (identify --no-register, or the demo's simulated arm, which stands where its file says).",
        );
    };
    let v3 =
        |v: [f64; 3], d: usize| format!("({}, {}, {})", num(v[0], d), num(v[1], d), num(v[2], d));
    let rows = vec![
        vec![
            "base position in the measurement frame".into(),
            format!("{} mm", v3(r.base_xyz_mm, 1)),
        ],
        vec![
            "base roll, pitch, yaw".into(),
            format!("{} °", v3(r.base_rpy_deg, 2)),
        ],
        vec![
            "base tilt from up".into(),
            format!("{} °", num(r.base_tilt_deg, 2)),
        ],
        vec![
            "nominal arm to the measurements, as the arm file places it".into(),
            format!("{} mm RMS", num(r.before_rms_mm, 1)),
        ],
        vec![
            "after registration".into(),
            format!(
                "{} mm RMS, largest {} mm",
                num(r.after_rms_mm, 1),
                num(r.after_max_mm, 1)
            ),
        ],
        vec![
            // The report names no joint count: the frame by what it is.
            "tool point in the last joint's frame".into(),
            match r.tool_mm {
                Some(t) => format!("{} mm, found with the base", v3(t, 1)),
                None => format!(
                    "the arm file's, kept (the last link turns {:.2}, {:.1} needed)",
                    r.tool_turn, r.tool_turn_needed
                ),
            },
        ],
        vec![
            "measurements left out as far off".into(),
            r.left_out.len().to_string(),
        ],
    ];
    table(
        "registration-table",
        "The arm placed on the measurements before the fit",
        &["what", "found"],
        &rows,
    )
}

/// Where each option's fit puts the camera, the lens it saw through, and
/// the reprojection errors in pixels beside the millimetres they imply.
pub fn camera(report: &Report) -> String {
    per_option(
        report,
        |o| o.camera.as_ref(),
        "No camera measured: the measurements are a tracker's points.",
        |i, o, c| {
            let v3 = |v: [f64; 3], d: usize| {
                format!("({}, {}, {})", num(v[0], d), num(v[1], d), num(v[2], d))
            };
            let px = |p: &PixelErrors| {
                format!(
                    "median {}, rms {}, largest {} px ({} corners)",
                    num(p.median_px, 2),
                    num(p.rms_px, 2),
                    num(p.max_px, 2),
                    p.count
                )
            };
            let mut rows = vec![
                vec![
                    match c.mount {
                        Mount::EyeToHand => "camera's optical frame in the arm's base frame",
                        Mount::EyeInHand => {
                            "camera's optical frame on the arm's last frame (the flange)"
                        }
                    }
                    .into(),
                    format!(
                        "{} mm; roll, pitch, yaw {} °",
                        v3(c.xyz_mm, 1),
                        v3(c.rpy_deg, 2)
                    ),
                ],
                vec![
                    "as a quaternion (x y z w)".into(),
                    c.quaternion_xyzw.map(|q| num(q, 6)).join(" "),
                ],
                vec!["lens as the setup told it".into(), lens(&c.lens_told)],
                vec![
                    if c.lens_refined {
                        "lens refined with the arm".into()
                    } else {
                        "lens (held as told)".into()
                    },
                    lens(&c.lens),
                ],
                vec![
                    "reprojection error at the fitted corners".into(),
                    px(&c.fit_px),
                ],
            ];
            if let Some(v) = &o.validation {
                if let Some(p) = &v.pixels {
                    rows.push(vec![
                        "at the held-out corners, before → after".into(),
                        format!("{} → {}", px(&p.before), px(&p.after)),
                    ]);
                }
                rows.push(vec![
                    "the same carried to the corners' distance".into(),
                    format!(
                        "mean {} → {} mm",
                        num(v.before.mean_m * 1e3, 2),
                        num(v.after.mean_m * 1e3, 2)
                    ),
                ]);
            }
            table(
                &format!("camera-table-{i}"),
                &format!(
                    "{}: where the camera stands (identify writes its camera_info and the launch file publishing it)",
                    title(o)
                ),
                &["", "value"],
                &rows,
            )
        },
    )
}
