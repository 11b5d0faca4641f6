//! What a person reads: the paper-style table and the lines `lrmcal identify`
//! and `lrmcal demo` print, rendered from the report, so the terminal and
//! `report.json` always tell the same story.

use crate::calib::CalibError;
use crate::calib::ParamKey;
use crate::calib::fit::choice::Rung;
use crate::calib::fit::registration::{MIN_TOOL_TURN, Registration, TILT_WARNING_RAD, frame_of};
use crate::calib::fit::validate::worst_per_pose;
use crate::calib::parameters::option::DEFAULT;
use crate::calib::parameters::prior::SERVO_CORRELATIONS_DEG;
use crate::calib::results::figures::{ErrorPoint, GridErrors, RandomBaseline};
use crate::calib::results::report::{
    LensReport, OptionReport, OutlierReport, RemovedReport, ValidationOutlier,
};
use crate::calib::results::study::Study;
use lrmcal_core::io::calibration_file::TargetTool;
use model::Arm;

/// The paper-style table: option, parameters, mean error before → after,
/// reduction, and the cross-load reduction when there is one.
pub fn table(options: &[OptionReport]) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "{:<22} {:>6} {:>26} {:>10} {:>11}\n",
        "model", "params", "mean error before -> after", "reduction", "cross-load"
    ));
    for o in options {
        let cross = o
            .cross_load
            .as_ref()
            .map(|c| format!("{:.1} %", c.reduction_pct))
            .unwrap_or("-".into());
        let (before, after, reduction) = match &o.validation {
            Some(v) => (
                format!("{:.2}", v.before.mean_m * 1e3),
                format!("{:.2}", v.after.mean_m * 1e3),
                format!("{:.1} %", v.reduction_pct),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        s.push_str(&format!(
            "{:<22} {:>6} {:>12} -> {:>6} mm {:>10} {:>11}\n",
            o.option.name(),
            o.fit.parameters.len(),
            before,
            after,
            reduction,
            cross
        ));
    }
    s
}

/// Each option's mean error on the grid and off it, side by side.
pub fn grid_table(errors: &[GridErrors]) -> String {
    let mut s = format!("{:<22} {:>10} {:>10}\n", "model", "grid", "off-grid");
    for e in errors {
        s.push_str(&format!(
            "{:<22} {:>7.2} mm {:>7.2} mm\n",
            e.option.name(),
            e.grid.mean_m * 1e3,
            e.off_grid.mean_m * 1e3
        ));
    }
    s
}

/// Each option's mean error on the grid and off it against the number of
/// poses fitted, a row per number (`-` where the poses could not determine
/// the option or its fit failed), the knot spacing chosen beside ours.
pub fn error_table(points: &[ErrorPoint]) -> String {
    let mut options: Vec<_> = Vec::new();
    let mut sizes: Vec<usize> = Vec::new();
    for p in points {
        if !options.contains(&p.option) {
            options.push(p.option);
        }
        if !sizes.contains(&p.poses) {
            sizes.push(p.poses);
        }
    }
    let mut s = format!("{:>5}", "poses");
    for o in &options {
        s.push_str(&format!("  {:>36}", format!("{o}: grid / off-grid")));
    }
    s.push('\n');
    for n in sizes {
        s.push_str(&format!("{n:>5}"));
        for o in &options {
            let cell = points
                .iter()
                .find(|p| p.poses == n && p.option == *o)
                .and_then(|p| {
                    let e = p.errors.as_ref()?;
                    let knots = p.knots.map(|k| format!(" ({k})")).unwrap_or_default();
                    Some(format!(
                        "{:.2} / {:.2} mm{knots}",
                        e.grid.mean_m * 1e3,
                        e.off_grid.mean_m * 1e3
                    ))
                })
                .unwrap_or("-".into());
            s.push_str(&format!("  {cell:>36}"));
        }
        s.push('\n');
    }
    if points.iter().any(|p| p.errors.is_none()) {
        s.push_str("  -: too few poses for the option's parameters, or its fit failed (report.json says which)\n");
    }
    s
}

/// How the servo curves' knot spacing was chosen, for an option that fits them.
pub fn knots(o: &OptionReport) -> Option<String> {
    let k = o.knots.as_ref()?;
    let trials: Vec<String> = k
        .trials
        .iter()
        .map(|t| match t.loo_mean_mm {
            Some(mm) => format!("{} {mm:.2} mm", t.spacing),
            None => format!("{} failed", t.spacing),
        })
        .collect();
    let spacing = match k.trials.len() {
        1 => format!("servo curves: knots {}", k.chosen),
        _ => format!(
            "servo curves: knots {}, the spacing whose fit best predicts each fitted pose left out (leave-one-out mean error: {})",
            k.chosen,
            trials.join(", ")
        ),
    };
    Some(match o.fit.servo_correlation_deg {
        Some(deg) => format!("{spacing}; {}", servo_smoothness(deg)),
        None => spacing,
    })
}

/// How smooth the prior kept the servo curves: the correlation length
/// `deg` the fit chose, among those it chooses from.
pub fn servo_smoothness(deg: f64) -> String {
    format!(
        "their errors correlated over {deg:.0}° (of {}), the length under which the measurements are most probable",
        SERVO_CORRELATIONS_DEG
            .map(|d| format!("{d:.0}°"))
            .join(", ")
    )
}

/// Which model the option's ladder kept, and each rung's leave-one-out
/// error, for an option fitted as a ladder (`calib::model_choice`).
pub fn model(o: &OptionReport) -> Option<String> {
    let m = o.model.as_ref()?;
    let trials: Vec<String> = m
        .trials
        .iter()
        .map(|t| match (t.loo_mean_mm, t.loo_se_mm) {
            (Some(mean), Some(se)) => format!("{} {mean:.3} ± {se:.3} mm", t.model),
            _ => match t.failure.as_deref().and_then(|f| f.split(':').next()) {
                Some(why) => format!("{} failed ({why})", t.model),
                None => format!("{} failed", t.model),
            },
        })
        .collect();
    let why = if m.chosen == Rung::Model(o.option) {
        "the richest model predicts the fitted poses left out best"
    } else {
        "the richer models do not predict the fitted poses left out better by more than a standard error"
    };
    Some(format!(
        "model: {} ({why}; leave-one-out mean error: {})",
        m.chosen,
        trials.join(", ")
    ))
}

/// What `lrmcal demo` prints of its study (`off_grid` poses off the grid):
/// the paper-style table with the cross-load check both ways, the grid and
/// off-grid errors, the error against the number of poses, and for our
/// option what it identified, its knot spacing, its selection against
/// random ones and its outliers.
pub fn study(study: &Study, off_grid: usize) -> Result<String, CalibError> {
    let load = study.report.identify_load_kg;
    let ours = study.result(DEFAULT)?;
    let mut s = format!(
        "\nValidation on the {} poses not selected, {load} kg load (mean 3D error):\n",
        ours.held_out()?.before.count,
    );
    let (forward, reversed) = study.report.options.split_at(study.results.len());
    s.push_str(&table(forward));
    for (option, e) in &study.refused {
        s.push_str(&format!("{option}: refused, no calibration: {e}\n"));
    }
    if let Some(line) = reversed.first().and_then(cross_load) {
        s.push_str(&format!("{line}\n"));
    }
    s.push_str(&format!(
        "\nOn the grid (its poses not selected) and off it ({off_grid} random poses), {load} kg (mean 3D error):\n"
    ));
    s.push_str(&grid_table(&study.grid_errors));
    if !study.report.error_vs_poses.is_empty() {
        s.push_str(&format!(
            "\nAgainst the number of poses fitted (DETMAX), {load} kg (mean 3D error):\n"
        ));
        s.push_str(&error_table(&study.report.error_vs_poses));
    }
    if let Some(o) = forward.iter().find(|o| o.option == DEFAULT) {
        s.push_str(&format!("\n{}\n", identifiable(o)));
        if let Some(line) = model(o) {
            s.push_str(&format!("{line}\n"));
        }
        if let Some(line) = knots(o) {
            s.push_str(&format!("{line}\n"));
        }
        s.push_str(&format!("{}\n", selection(o)));
        if let Some(b) = &study.report.random_baseline {
            s.push_str(&format!("{}\n", random_baseline(b)));
        }
        for line in outliers_by_pose(&o.fit.outliers) {
            s.push_str(&format!("{line}\n"));
        }
    }
    Ok(s)
}

/// One option's fit as `lrmcal identify` prints it: counts, selection,
/// convergence, removed parameters, every estimate and the outliers.
pub fn option_details(o: &OptionReport) -> String {
    let f = &o.fit;
    let (held, joined) = held_and_joined(o);
    let mut lines = vec![format!(
        "{}: {} parameters fitted ({} held at nominal as unidentifiable), {} poses, O1 {:.4}; {} after {} evaluations, residual RMS {:.3} mm",
        o.option,
        f.parameters.len(),
        held.len(),
        o.selected_poses.len(),
        o.observability.o1,
        if f.converged {
            "converged"
        } else {
            "NOT converged"
        },
        f.evaluations,
        f.rms_after_mm
    )];
    lines.extend(held.iter().map(|r| format!("  held {}", r.explain())));
    if !joined.is_empty() {
        lines.push(format!(
            "  fitted though confounded at the nominal arm (independent at the estimate): {}",
            joined.join(", ")
        ));
    }
    lines.extend(f.parameters.iter().map(|p| {
        let std = p
            .std
            .map(|s| format!("± {s:.3e}"))
            .unwrap_or("(held at its bound)".into());
        format!("  {:<11} {:+.6e} {std}", p.name, p.error)
    }));
    if let Some(line) = model(o) {
        lines.push(format!("  {line}"));
    }
    if let Some(line) = knots(o) {
        lines.push(format!("  {line}"));
    }
    if let Some(line) = weak(o) {
        lines.push(format!("  {line}"));
    }
    lines.extend(backlash(o).into_iter().map(|w| format!("  {w}")));
    lines.extend(outliers_by_pose(&f.outliers).map(|line| format!("  {line}")));
    lines.extend(
        o.validation
            .iter()
            .chain(&o.cross_load)
            .flat_map(|v| &v.outliers)
            .map(|x| format!("  {}", validation_outlier(x))),
    );
    lines.join("\n")
}

/// The parameters the rank analysis removed that stayed at their nominal
/// values, and the names of those the refresh fitted after all.
fn held_and_joined(o: &OptionReport) -> (Vec<&RemovedReport>, Vec<String>) {
    let fitted = |name: &ParamKey| o.fit.parameters.iter().any(|p| p.name == *name);
    let (joined, held): (Vec<&RemovedReport>, Vec<&RemovedReport>) = o
        .identifiability
        .removed
        .iter()
        .partition(|r| fitted(&r.name));
    (held, joined.iter().map(|r| r.name.to_string()).collect())
}

/// Warnings on the fitted backlash widths: one the fit left at the widest
/// the board takes (`calib::backlash::FIT_MAX_RAD`: the measurements asked
/// for more) and one wider than `calib::backlash::PLAUSIBLE_MAX_RAD`.
pub fn backlash(o: &OptionReport) -> Vec<String> {
    o.fit
        .parameters
        .iter()
        .filter_map(|p| {
            let ParamKey::Backlash { joint } = p.name else {
                return None;
            };
            let joint = joint + 1;
            let deg = p.value.to_degrees();
            if p.value >= crate::calib::parameters::backlash::FIT_MAX_RAD * (1.0 - 1e-9) {
                Some(format!(
                    "warning: joint {joint}'s backlash held at {deg:.2}°, the widest the board takes: the measurements asked for more, so those of joint {joint} are inconsistent, its servo is worn, or its play is confounded with its servo curve (measure it arriving both ways at more angles)"
                ))
            } else if p.value > crate::calib::parameters::backlash::PLAUSIBLE_MAX_RAD {
                Some(format!(
                    "warning: joint {joint}'s backlash fitted {deg:.2}°, more than {:.0}°: measurements of joint {joint} are inconsistent or the servo is worn",
                    crate::calib::parameters::backlash::PLAUSIBLE_MAX_RAD.to_degrees()
                ))
            } else {
                None
            }
        })
        .collect()
}

/// The parameters the fit's data barely determine, with value and standard
/// deviation (SI units), if any.
pub fn weak(o: &OptionReport) -> Option<String> {
    let named: Vec<String> = o
        .fit
        .parameters
        .iter()
        .filter(|p| o.fit.weak.contains(&p.name))
        .map(|p| {
            let std = p.std.map(|s| format!("{s:.2e}")).unwrap_or("-".into());
            format!("{} = {:.3e} (std {std})", p.name, p.value)
        })
        .collect();
    (!named.is_empty()).then(|| {
        format!(
            "weakly determined by these poses (kept; they barely move the measured points): {}",
            named.join(", ")
        )
    })
}

/// A measurement named as an outlier.
pub fn outlier(o: &OutlierReport) -> String {
    format!(
        "outlier: pose {} ({} kg), residual {:.2} mm, weight {:.2}",
        o.pose, o.load_kg, o.residual_mm, o.weight
    )
}

/// The fit's outliers (largest first) a line per pose and load: its worst
/// measurement, and how many of its measurements are outliers when more
/// than one is (a camera's view has dozens of corners).
fn outliers_by_pose(outliers: &[OutlierReport]) -> impl Iterator<Item = String> + '_ {
    worst_per_pose(outliers, |o| (o.pose, o.load_kg))
        .into_iter()
        .map(|(o, count)| format!("{}{}", outlier(o), of_many(count)))
}

/// What a pose's outlier line adds when `count` of its measurements are
/// outliers: nothing for one.
fn of_many(count: usize) -> String {
    match count {
        n if n > 1 => format!(" (the worst of its {n} outlying measurements)"),
        _ => String::new(),
    }
}

/// A lens in a line: focal lengths and principal point (px), then
/// OpenCV's distortion coefficients.
pub fn lens(l: &LensReport) -> String {
    let [k1, k2, p1, p2, k3] = l.distortion;
    format!(
        "fx {:.1} fy {:.1} cx {:.1} cy {:.1} px; k1 {k1:.4} k2 {k2:.4} p1 {p1:.5} p2 {p2:.5} k3 {k3:.4}",
        l.fx, l.fy, l.cx, l.cy
    )
}

/// The lens an option's fit refined beside the one told, when it refined
/// one.
pub fn lens_refined(o: &OptionReport) -> Option<String> {
    let camera = o.camera.as_ref().filter(|c| c.lens_refined)?;
    Some(format!(
        "  lens refined: {} (told {})\n",
        lens(&camera.lens),
        lens(&camera.lens_told)
    ))
}

/// A camera's reprojection errors, at the fitted corners and at the
/// held-out ones before → after, one line each; `None` for a tracker.
pub fn camera_pixels(o: &OptionReport) -> Option<String> {
    let camera = o.camera.as_ref()?;
    let f = &camera.fit_px;
    let mut lines = format!(
        "  reprojection error at the {} fitted corners: median {:.2} px, rms {:.2} px\n",
        f.count, f.median_px, f.rms_px
    );
    if let Some(p) = o.validation.as_ref().and_then(|v| v.pixels) {
        lines.push_str(&format!(
            "  at the {} held-out corners: median {:.2} -> {:.2} px, rms {:.2} -> {:.2} px\n",
            p.after.count, p.before.median_px, p.after.median_px, p.before.rms_px, p.after.rms_px
        ));
    }
    Some(lines)
}

/// A validation measurement named as an outlier.
pub fn validation_outlier(o: &ValidationOutlier) -> String {
    format!(
        "validation outlier: pose {} ({} kg), error {:.2} mm after calibration{}",
        o.pose,
        o.load_kg,
        o.error_mm,
        of_many(o.measurements)
    )
}

/// The cross-load check of a fit validated under another load, if it has one.
pub fn cross_load(o: &OptionReport) -> Option<String> {
    let c = o.cross_load.as_ref()?;
    let fitted = if o.identify_load_kg == 0.0 {
        "without load".to_string()
    } else {
        format!("with {} kg", o.identify_load_kg)
    };
    Some(format!(
        "cross-load: fitted {fitted}, validated with {} kg: {:.2} -> {:.2} mm ({:.1} %)",
        c.load_kg,
        c.before.mean_m * 1e3,
        c.after.mean_m * 1e3,
        c.reduction_pct
    ))
}

/// How many of an option's candidate parameters are identifiable and why the others are not.
pub fn identifiable(o: &OptionReport) -> String {
    let ident = &o.identifiability;
    let (held, joined) = held_and_joined(o);
    let removed: Vec<String> = held.iter().map(|r| r.explain()).collect();
    let joined = if joined.is_empty() {
        String::new()
    } else {
        format!(
            "; {} more fitted, independent at the estimate: {}",
            joined.len(),
            joined.join(", ")
        )
    };
    format!(
        "{}: {} of {} parameters identifiable{joined}; held at nominal: {}",
        o.option,
        ident.kept.len(),
        ident.candidates,
        removed.join("; ")
    )
}

/// O1 of an option's selection.
pub fn selection(o: &OptionReport) -> String {
    format!(
        "O1 of the {} selected poses: {:.4} ({})",
        o.selected_poses.len(),
        o.observability.o1,
        o.option
    )
}

/// DETMAX against random selections of the same size.
pub fn random_baseline(b: &RandomBaseline) -> String {
    format!(
        "DETMAX vs {} random {}-pose sets ({}): O1 {:.4} vs median {:.4}; validation mean {:.2} vs median {:.2} mm",
        b.sets,
        b.poses,
        b.option,
        b.detmax_o1,
        b.random_o1_median,
        b.detmax_mean_m * 1e3,
        b.random_mean_median_m * 1e3
    )
}

/// The error per measured target: tool point, fit residual and held-out
/// error (mean and max, mm), one line each.
pub fn targets_table(targets: &[TargetTool]) -> String {
    let mut out = format!(
        "  {:<12} {:>26} | {:>15} | {:>15}\n",
        "target", "tool point x y z (mm)", "fit: mean max", "held-out: mean max"
    );
    for t in targets {
        let held_out = t.validation_after.map_or("-".to_string(), |v| {
            format!("{:6.3} {:7.3}", v.mean_m * 1e3, v.max_m * 1e3)
        });
        out += &format!(
            "  {:<12} {:8.2} {:8.2} {:8.2} | {:6.3} {:8.3} | {held_out:>15}\n",
            t.name,
            t.tool_m[0] * 1e3,
            t.tool_m[1] * 1e3,
            t.tool_m[2] * 1e3,
            t.fit_residual.mean_m * 1e3,
            t.fit_residual.max_m * 1e3,
        );
    }
    out
}

/// What `identify` prints of a registration of `nominal`: where the base
/// stands, how far the arm was from the measurements before and after, the
/// tool point found or kept, the measurements left out; and a warning when
/// the base came out tilted.
pub fn registration(reg: &Registration, nominal: &Arm<f64>) -> (String, Option<String>) {
    let mm = |v: [f64; 3]| {
        format!(
            "({:.1}, {:.1}, {:.1}) mm",
            v[0] * 1e3,
            v[1] * 1e3,
            v[2] * 1e3
        )
    };
    let base = frame_of(&reg.base);
    let mut lines = vec![
        format!(
            "Registered the arm in the measurement frame: base at {}, roll {:.2} pitch {:.2} yaw {:.2} deg",
            mm(base.xyz),
            base.rpy[0].to_degrees(),
            base.rpy[1].to_degrees(),
            base.rpy[2].to_degrees()
        ),
        format!(
            "  nominal arm to the measurements: {:.1} mm RMS as the arm file places it, {:.1} mm after registration (largest {:.1} mm)",
            reg.before_rms_m * 1e3,
            reg.after_rms_m * 1e3,
            reg.after_max_m * 1e3
        ),
        match reg.tool {
            Some(tool) => format!(
                "  tool point found with it: {} in frame {} (the arm file: {}); the fit starts there",
                mm(tool.into()),
                nominal.joints.len(),
                mm(nominal.tool.xyz)
            ),
            None => format!(
                "  tool point: the arm file's {} kept; the last link turns too little to find it (turn {:.2}, {:.1} needed: measure poses that turn the wrist)",
                mm(nominal.tool.xyz),
                reg.tool_turn,
                MIN_TOOL_TURN
            ),
        },
    ];
    if !reg.trimmed.is_empty() {
        let named: Vec<String> = reg
            .trimmed
            .iter()
            .map(|(pose, load)| format!("pose {pose} ({load} kg)"))
            .collect();
        lines.push(format!(
            "  left out of the registration as far off: {}",
            named.join(", ")
        ));
    }
    let warning = (reg.base_tilt_rad > TILT_WARNING_RAD).then(|| {
        format!(
            "warning: the registered base is tilted {:.0} deg from up (-gravity {:?} m/s² in the measurement frame); if the arm stands level, give the frame's up axis with --up or pass --level-base",
            reg.base_tilt_rad.to_degrees(),
            reg.gravity.map(|v| (v * 1e3).round() / 1e3).as_slice()
        )
    });
    (lines.join("\n"), warning)
}

/// The warning `identify --no-robust` gives when the fit of option `o` to
/// the measurements of `file` left some far off the others at full weight.
pub fn unweighted_outliers(o: &OptionReport, file: &str) -> Option<String> {
    if o.fit.outliers.is_empty() {
        return None;
    }
    let poses: Vec<String> = o
        .fit
        .outliers
        .iter()
        .map(|x| format!("{} ({:.1} mm)", x.pose, x.residual_mm))
        .collect();
    Some(format!(
        "warning: {}: {} measurements of {file} are far off the others (poses {}) and keep their full weight because of --no-robust; without it they are down-weighted",
        o.option,
        poses.len(),
        poses.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::ModelOption;
    use crate::calib::testing::{calibrate_in_arm_frame, elastic_run, elastic_settings};

    /// A pose with several outlying measurements is one line, its worst,
    /// saying how many; a pose with one is its line alone.
    #[test]
    fn outliers_are_named_once_per_pose() {
        let o = |pose: u32, residual_mm: f64| OutlierReport {
            pose,
            load_kg: 0.0663,
            residual_mm,
            weight: 0.5,
        };
        let lines: Vec<String> =
            outliers_by_pose(&[o(7, 3.0), o(9, 2.5), o(7, 2.0), o(7, 1.0)]).collect();
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert!(
            lines[0].starts_with("outlier: pose 7 (0.0663 kg), residual 3.00 mm")
                && lines[0].ends_with("(the worst of its 3 outlying measurements)"),
            "{lines:?}"
        );
        assert_eq!(lines[1], outlier(&o(9, 2.5)));
    }

    fn elastic_report() -> OptionReport {
        let (nominal, _, all) = elastic_run();
        let r = calibrate_in_arm_frame(&nominal, &all, ModelOption::Elastic, &elastic_settings())
            .unwrap();
        OptionReport::from(&r)
    }

    /// A negative width is said to be set to zero; one of 4° names the joint
    /// and what it means; a plausible one says nothing.
    #[test]
    fn implausible_backlash_widths_are_warned_about() {
        let mut o = elastic_report();
        let template = o.fit.parameters[0].clone();
        o.fit.parameters = [
            (
                "j2.backlash",
                crate::calib::parameters::backlash::FIT_MAX_RAD,
            ),
            ("j5.backlash", 4f64.to_radians()),
            ("j3.backlash", 0.01),
        ]
        .into_iter()
        .map(
            |(name, value)| lrmcal_core::io::calibration_file::FittedParam {
                name: ParamKey::from_name(name).unwrap(),
                value,
                ..template.clone()
            },
        )
        .collect();
        let w = backlash(&o);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(
            w[0].contains("joint 2") && w[0].contains("the widest the board takes"),
            "{}",
            w[0]
        );
        assert!(
            w[1].contains("4.00°")
                && w[1].contains("measurements of joint 5 are inconsistent or the servo is worn"),
            "{}",
            w[1]
        );
        assert!(option_details(&o).contains(&w[1]));
    }

    #[test]
    fn lines_count_what_the_run_had() {
        let o = elastic_report();
        let kept = o.identifiability.kept.len();
        // k1 is removed at the nominal arm (no torque on the level base) and
        // fitted by the refresh (the tilted estimate loads it); k6 is held
        // (the tool point on its axis): each said once, as it ended.
        let fitted = |n: &str| o.fit.parameters.iter().any(|p| p.name.to_string() == n);
        assert!(fitted("k1") && !fitted("k6"), "{:?}", o.fit.parameters);
        assert_eq!(
            identifiable(&o),
            format!(
                "elastic: {kept} of 7 parameters identifiable; 1 more fitted, independent at the estimate: k1; held at nominal: k6: no effect on the measured point (zero column)"
            )
        );
        assert!(selection(&o).starts_with("O1 of the 10 selected poses: "));
        let details = option_details(&o);
        assert!(details.starts_with(&format!(
            "elastic: {} parameters fitted (1 held at nominal as unidentifiable)",
            kept + 1
        )));
        assert!(details.contains("\n  held k6: no effect on the measured point"));
        assert!(details.contains("independent at the estimate): k1\n"));
        assert!(!details.contains("held k1"), "{details}");
        // The refresh may fit a removed parameter too: every fitted one with its deviation.
        let with_std = o.fit.parameters.iter().filter(|p| p.std.is_some()).count();
        assert_eq!(
            details.lines().filter(|l| l.contains("± ")).count(),
            with_std
        );
        let t = table(&[o]);
        assert!(t.lines().nth(1).unwrap().starts_with("elastic "), "{t}");
        assert!(t.contains(" -> ") && t.contains('%'), "{t}");
    }

    #[test]
    fn an_outlier_and_the_random_baseline_read_in_mm() {
        let o = OutlierReport {
            pose: 12,
            load_kg: 0.0663,
            residual_mm: 29.4394,
            weight: 0.25,
        };
        assert_eq!(
            outlier(&o),
            "outlier: pose 12 (0.0663 kg), residual 29.44 mm, weight 0.25"
        );
        let b = RandomBaseline {
            option: ModelOption::ElastoKinematic,
            sets: 20,
            poses: 40,
            detmax_o1: 0.69134,
            random_o1_median: 0.647,
            detmax_mean_m: 0.00328,
            random_mean_median_m: 0.00341,
        };
        assert_eq!(
            random_baseline(&b),
            "DETMAX vs 20 random 40-pose sets (elasto-kinematic): O1 0.6913 vs median 0.6470; validation mean 3.28 vs median 3.41 mm"
        );
    }
}
