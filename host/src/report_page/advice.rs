//! What to do next, worked out from the report's numbers: each rule looks
//! at one thing the run computed (the fit's outliers, the parameters it
//! barely determined, the validation against the fit, the bounds, the
//! registration) and speaks only when its condition holds, naming the poses,
//! joints and figures that made it speak.
//!
//! The measurements and parameters are judged on the calibration to push
//! (the one that predicts the held-out poses best): a simpler option that
//! misses every pose by centimetres names half of them as far off, which
//! says nothing about the measurements. Without a validation every option
//! fitted is judged.

use lrmcal_engine::calib::ParamKey;
use lrmcal_engine::calib::parameters::servo_knots::FINEST_SPACING_DEG;
use lrmcal_engine::calib::results::report::{OptionReport, Report, ValidationReport};
use lrmcal_engine::calib::results::summary;

/// The validation error (RMS) beyond this many times the fit's own says
/// that the calibration follows its poses more closely than the arm.
pub const VALIDATION_OVER_FIT: f64 = 2.0;

/// The rules that find problems, most pressing first.
const PROBLEMS: [fn(&Report) -> Vec<String>; 9] = [
    not_converged,
    remeasure_outliers,
    validation_outliers,
    validation_over_fit,
    nothing_held_out,
    poorly_determined,
    springs_at_bound,
    backlash,
    tool_not_found,
];

/// Each piece of advice, most pressing first: problems, then which file to push.
pub fn advice(report: &Report) -> Vec<String> {
    problems(report)
        .into_iter()
        .chain(push_best(report))
        .collect()
}

/// The problems the rules find, most pressing first.
pub fn problems(report: &Report) -> Vec<String> {
    PROBLEMS.iter().flat_map(|rule| rule(report)).collect()
}

/// The option the page shows first: the one to push ([`best`]), or, when
/// none was validated, the converged one whose fit predicts its own poses
/// left out best; the first fitted when none converged.
pub fn focus(report: &Report) -> Option<&OptionReport> {
    if let Some((o, _)) = best(report) {
        return Some(o);
    }
    fitted(report)
        .filter(|o| o.fit.converged && o.fit.loo_mean_mm.is_finite())
        .min_by(|a, b| a.fit.loo_mean_mm.total_cmp(&b.fit.loo_mean_mm))
        .or_else(|| fitted(report).next())
}

/// The options fitted under the run's load (the demo adds fits under the
/// other load after them, for its cross-load check).
fn fitted(report: &Report) -> impl Iterator<Item = &OptionReport> {
    report
        .options
        .iter()
        .filter(move |o| o.identify_load_kg == report.identify_load_kg)
}

/// The most poses an advice names before it says how many more.
const NAMED: usize = 12;

/// The options whose measurements and parameters are judged: the best
/// validated one ([`best`]), or every one fitted when none was validated.
fn judged(report: &Report) -> Vec<&OptionReport> {
    match best(report) {
        Some((o, _)) => vec![o],
        None => fitted(report).collect(),
    }
}

/// The converged option fitted under the run's load with the smallest
/// mean validation error, and its validation: the calibration to push.
pub fn best(report: &Report) -> Option<(&OptionReport, &ValidationReport)> {
    fitted(report)
        .filter(|o| o.fit.converged)
        .filter_map(|o| Some((o, o.validation.as_ref()?)))
        .min_by(|a, b| a.1.after.mean_m.total_cmp(&b.1.after.mean_m))
}

/// `(pose, load)` pairs as `pose 12 (0.0663 kg)`, each once, in the order
/// given: how many, and the first [`NAMED`] of them with how many more.
fn poses(pairs: impl IntoIterator<Item = (u32, f64)>) -> (usize, String) {
    let mut named: Vec<String> = Vec::new();
    for (pose, load) in pairs {
        let name = format!("pose {pose} ({load} kg)");
        if !named.contains(&name) {
            named.push(name);
        }
    }
    let count = named.len();
    let more = count.saturating_sub(NAMED);
    named.truncate(NAMED);
    let mut text = named.join(", ");
    if more > 0 {
        text.push_str(&format!(
            " and {more} more (the table of suspect measurements lists them)"
        ));
    }
    (count, text)
}

/// A fit that did not converge.
fn not_converged(report: &Report) -> Vec<String> {
    report
        .options
        .iter()
        .filter(|o| !o.fit.converged)
        .map(|o| {
            format!(
                "{}: the fit did not converge ({}): do not push this calibration; measure more poses or fit a smaller option.",
                o.option, o.fit.termination
            )
        })
        .collect()
}

/// The measurements the robust fit down-weighted, largest residual first.
fn remeasure_outliers(report: &Report) -> Vec<String> {
    let mut outliers: Vec<_> = judged(report)
        .into_iter()
        .flat_map(|o| &o.fit.outliers)
        .collect();
    if outliers.is_empty() {
        return Vec::new();
    }
    outliers.sort_by(|a, b| b.residual_mm.total_cmp(&a.residual_mm));
    let (count, named) = poses(outliers.iter().map(|o| (o.pose, o.load_kg)));
    vec![format!(
        "{count} {} wrong (far off the others, down-weighted by the fit, residual up to {:.2} mm): re-measure {named}. If a pose measures the same again, the arm does something there the model does not describe.",
        if count == 1 {
            "measurement looks"
        } else {
            "measurements look"
        },
        outliers[0].residual_mm,
    )]
}

/// Held-out measurements far beyond the others' error.
fn validation_outliers(report: &Report) -> Vec<String> {
    let mut outliers: Vec<_> = judged(report)
        .into_iter()
        .flat_map(|o| o.validation.iter().chain(&o.cross_load))
        .flat_map(|v| &v.outliers)
        .collect();
    if outliers.is_empty() {
        return Vec::new();
    }
    outliers.sort_by(|a, b| b.error_mm.total_cmp(&a.error_mm));
    let (count, named) = poses(outliers.iter().map(|o| (o.pose, o.load_kg)));
    vec![format!(
        "Held out of the fit, {named} {} far from where the calibration puts the tool (up to {:.2} mm): re-measure {}, or check the tracker's view of the target there.",
        if count == 1 { "is" } else { "are" },
        outliers[0].error_mm,
        if count == 1 { "it" } else { "them" },
    )]
}

/// A validation error much larger than the fit's.
fn validation_over_fit(report: &Report) -> Vec<String> {
    report
        .options
        .iter()
        .filter_map(|o| {
            let v = o.validation.as_ref()?;
            let held_out = v.after.rms_m * 1e3;
            let fit = o.fit.rms_after_mm;
            (held_out > VALIDATION_OVER_FIT * fit).then(|| {
                format!(
                    "{}: the validation error ({held_out:.2} mm RMS on the poses held out) is {:.1} times the fit's ({fit:.2} mm RMS): the calibration follows its own poses more closely than the arm. Add poses (a larger --select), or check the tracker: a tracker or target moved between measurements does this.",
                    o.option,
                    held_out / fit
                )
            })
        })
        .collect()
}

/// No measured pose left to validate on.
fn nothing_held_out(report: &Report) -> Vec<String> {
    if report.options.is_empty() || report.options.iter().any(|o| o.validation.is_some()) {
        return Vec::new();
    }
    vec!["Every measured pose was fitted and none held out: the errors above are the fit's residuals and say little about other poses. Measure more poses than you fit (--select N below the number measured) to validate the calibration.".into()]
}

/// The parameters the fit barely determined, each once: a joint's play,
/// and a servo curve's knots joint by joint, with the poses that would
/// determine them; the others together.
fn poorly_determined(report: &Report) -> Vec<String> {
    let mut keys: Vec<ParamKey> = Vec::new();
    for key in judged(report).into_iter().flat_map(|o| &o.fit.weak) {
        if !keys.contains(key) {
            keys.push(*key);
        }
    }
    let mut out = Vec::new();
    // Per joint (from 0), the knot angles, degrees.
    let mut knots: Vec<(u8, Vec<f64>)> = Vec::new();
    let mut others = Vec::new();
    for key in keys {
        match key {
            ParamKey::Backlash { joint } => out.push(format!(
                "Joint {}'s play ({key}) is poorly determined: add poses that reverse joint {} (reach its angles from both directions).",
                joint + 1,
                joint + 1
            )),
            ParamKey::ServoKnot { joint, knot } => {
                let deg = -100.0 + FINEST_SPACING_DEG * f64::from(knot);
                match knots.iter_mut().find(|(j, _)| *j == joint) {
                    Some((_, angles)) => angles.push(deg),
                    None => knots.push((joint, vec![deg])),
                }
            }
            _ => others.push(key.to_string()),
        }
    }
    out.extend(knots.into_iter().map(|(joint, angles)| {
        let angles: Vec<String> = angles.iter().map(|d| format!("{d:+.0}°")).collect();
        format!(
            "Joint {}'s servo curve is poorly determined near {}: add poses with joint {} at {}.",
            joint + 1,
            angles.join(", "),
            joint + 1,
            if angles.len() == 1 {
                "that angle"
            } else {
                "those angles"
            }
        )
    }));
    if !others.is_empty() {
        out.push(format!(
            "Poorly determined by these poses: {}. Add poses that move {} (select from more varied candidates).",
            others.join(", "),
            if others.len() == 1 { "it" } else { "them" }
        ));
    }
    out
}

/// Parameters the fit held at the ceiling of their physical range (one held
/// at zero, a joint without play or a spring that does not soften, says
/// nothing wrong).
fn springs_at_bound(report: &Report) -> Vec<String> {
    judged(report)
        .into_iter()
        .filter_map(|o| {
            let at_ceiling: Vec<String> = o
                .fit
                .at_bound
                .iter()
                .filter(|name| {
                    let fitted = o.fit.parameters.iter().find(|p| &p.name == *name);
                    fitted.is_none_or(|p| p.value != 0.0)
                })
                .map(ParamKey::to_string)
                .collect();
            (!at_ceiling.is_empty()).then(|| {
                format!(
                    "{}: {} held at the ceiling of {} physical range, the measurements asking for more: check the load given (--load-kg) and the arm file's masses and [payload] rated_kg.",
                    o.option,
                    at_ceiling.join(", "),
                    if at_ceiling.len() == 1 { "its" } else { "their" }
                )
            })
        })
        .collect()
}

/// Backlash widths at the board's limit or beyond what a servo plausibly has.
fn backlash(report: &Report) -> Vec<String> {
    report
        .options
        .iter()
        .flat_map(summary::backlash)
        .map(|w| {
            let w = w.strip_prefix("warning: ").unwrap_or(&w);
            let mut w = w.to_owned();
            w.push('.');
            w
        })
        .collect()
}

/// A registration that kept the arm file's tool point.
fn tool_not_found(report: &Report) -> Vec<String> {
    match &report.registration {
        Some(r) if r.tool_mm.is_none() => vec![format!(
            "The tool point was not found with the base (the last link turns {:.2} over the poses, {:.1} needed), so the arm file's [tool] was kept: measure poses that turn the wrist further.",
            r.tool_turn, r.tool_turn_needed
        )],
        _ => Vec::new(),
    }
}

/// The calibration that predicts the held-out poses best.
fn push_best(report: &Report) -> Vec<String> {
    let Some((o, v)) = best(report) else {
        return Vec::new();
    };
    let others = fitted(report).filter(|x| x.validation.is_some()).count() - 1;
    vec![format!(
        "Push calibration-{}.json (lrmcal push): {} the poses held out to {:.2} mm mean, {:.1} % less than uncalibrated.",
        o.option,
        if others > 0 {
            format!("of the {} options validated it predicts best,", others + 1)
        } else {
            "it predicts".to_owned()
        },
        v.after.mean_m * 1e3,
        v.reduction_pct
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report_page::fixture;
    use lrmcal_engine::calib::results::report::{OutlierReport, ValidationOutlier};

    /// The fixture has nothing suspect: every rule but the push is silent.
    #[test]
    fn a_clean_run_only_says_which_file_to_push() {
        let report = fixture::report();
        for rule in PROBLEMS {
            assert_eq!(rule(&report), Vec::<String>::new());
        }
        assert_eq!(
            advice(&report),
            [
                "Push calibration-elasto-kinematic-servo.json (lrmcal push): it predicts the poses held out to 1.03 mm mean, 97.3 % less than uncalibrated."
            ]
        );
    }

    #[test]
    fn outliers_are_named_for_re_measuring_largest_first() {
        let mut report = fixture::report();
        let o = |pose, residual_mm| OutlierReport {
            pose,
            load_kg: 0.0663,
            residual_mm,
            weight: 0.3,
        };
        report.options[0].fit.outliers = vec![o(17, 3.0), o(12, 9.5), o(31, 4.0)];
        let a = remeasure_outliers(&report);
        assert_eq!(a.len(), 1);
        assert!(
            a[0].starts_with("3 measurements look wrong")
                && a[0].contains("up to 9.50 mm")
                && a[0].contains(
                    "re-measure pose 12 (0.0663 kg), pose 31 (0.0663 kg), pose 17 (0.0663 kg)."
                ),
            "{}",
            a[0]
        );
    }

    #[test]
    fn a_held_out_outlier_is_named() {
        let mut report = fixture::report();
        report.options[0]
            .validation
            .as_mut()
            .unwrap()
            .outliers
            .push(ValidationOutlier {
                pose: 9,
                load_kg: 0.0663,
                error_mm: 14.0,
                measurements: 1,
            });
        let a = validation_outliers(&report);
        assert!(
            a.len() == 1 && a[0].contains("pose 9 (0.0663 kg) is far") && a[0].contains("14.00 mm"),
            "{a:?}"
        );
    }

    #[test]
    fn a_validation_error_far_above_the_fit_s_says_add_poses_or_check_the_tracker() {
        let mut report = fixture::report();
        // 1.04 mm RMS held out against 0.9 in the fit: fine.
        assert!(validation_over_fit(&report).is_empty());
        report.options[0].fit.rms_after_mm = 0.4;
        let a = validation_over_fit(&report);
        assert!(
            a.len() == 1
                && a[0].contains("1.04 mm RMS")
                && a[0].contains("2.6 times")
                && a[0].contains("check the tracker"),
            "{a:?}"
        );
    }

    #[test]
    fn a_run_without_held_out_poses_says_so_and_recommends_nothing() {
        let mut report = fixture::report();
        report.options[0].validation = None;
        assert!(nothing_held_out(&report)[0].starts_with("Every measured pose was fitted"));
        assert!(push_best(&report).is_empty());
    }

    #[test]
    fn weak_parameters_say_which_poses_would_determine_them() {
        let mut report = fixture::report();
        report.options[0].fit.weak = vec![
            fixture::key("j6.backlash"),
            fixture::key("j3.servo[7]"),
            fixture::key("j5.servo[1]"),
            fixture::key("j5.servo[9]"),
            fixture::key("k2"),
            fixture::key("j2.d"),
        ];
        let a = poorly_determined(&report);
        assert_eq!(a.len(), 4, "{a:?}");
        assert!(
            a[0].starts_with(
                "Joint 6's play (j6.backlash) is poorly determined: add poses that reverse joint 6"
            ),
            "{}",
            a[0]
        );
        assert_eq!(
            a[1],
            "Joint 3's servo curve is poorly determined near +50°: add poses with joint 3 at that angle."
        );
        assert_eq!(
            a[2],
            "Joint 5's servo curve is poorly determined near -100°, +100°: add poses with joint 5 at those angles."
        );
        assert!(
            a[3].starts_with(
                "Poorly determined by these poses: k2, j2.d. Add poses that move them"
            ),
            "{}",
            a[3]
        );
    }

    #[test]
    fn a_fit_not_converged_or_at_a_bound_is_named() {
        let mut report = fixture::report();
        // j6.backlash held at zero (no play) says nothing; k2 at its ceiling does.
        report.options[0].fit.parameters[2].value = 0.0;
        report.options[0].fit.at_bound = vec![fixture::key("j6.backlash")];
        assert!(springs_at_bound(&report).is_empty());
        report.options[0].fit.at_bound.push(fixture::key("k2"));
        assert_eq!(
            springs_at_bound(&report),
            [
                "elasto-kinematic-servo: k2 held at the ceiling of its physical range, the measurements asking for more: check the load given (--load-kg) and the arm file's masses and [payload] rated_kg."
            ]
        );
        report.options[0].fit.converged = false;
        assert!(not_converged(&report)[0].contains("did not converge (converged)"));
        // Not converged: not recommended.
        assert!(push_best(&report).is_empty());
    }

    #[test]
    fn a_worn_servo_s_play_is_named() {
        let mut report = fixture::report();
        report.options[0].fit.parameters[2].value = 4f64.to_radians();
        let a = backlash(&report);
        assert!(
            a.len() == 1 && a[0].starts_with("joint 6's backlash fitted 4.00°"),
            "{a:?}"
        );
    }

    #[test]
    fn a_tool_point_kept_asks_for_wrist_turns() {
        let mut report = fixture::report();
        report.registration.as_mut().unwrap().tool_mm = None;
        let a = tool_not_found(&report);
        assert!(
            a.len() == 1 && a[0].contains("turns 0.80") && a[0].contains("turn the wrist"),
            "{a:?}"
        );
        report.registration = None;
        assert!(tool_not_found(&report).is_empty());
    }

    /// A simpler option's outliers and weak parameters say nothing about
    /// the measurements when a better one was validated; many poses are
    /// counted rather than all named.
    #[test]
    fn measurements_are_judged_on_the_option_to_push() {
        let mut report = fixture::report();
        let mut poor = report.options[0].clone();
        poor.option = lrmcal_engine::calib::ModelOption::Kinematic;
        poor.validation.as_mut().unwrap().after.mean_m = 0.03;
        poor.fit.weak = vec![fixture::key("j2.d")];
        poor.fit.outliers = (0..20)
            .map(|pose| OutlierReport {
                pose,
                load_kg: 0.0,
                residual_mm: 30.0,
                weight: 0.1,
            })
            .collect();
        report.options.push(poor);
        assert!(remeasure_outliers(&report).is_empty());
        assert!(poorly_determined(&report).is_empty());
        report.options[0].validation = None;
        report.options[1].validation = None;
        let a = remeasure_outliers(&report);
        assert!(
            a[0].starts_with("20 measurements look wrong")
                && a[0].contains("pose 11 (0 kg) and 8 more"),
            "{a:?}"
        );
    }

    #[test]
    fn the_best_of_several_options_is_recommended() {
        let mut report = fixture::report();
        let mut other = report.options[0].clone();
        other.option = lrmcal_engine::calib::ModelOption::Kinematic;
        other.validation.as_mut().unwrap().after.mean_m = 0.02;
        report.options.insert(0, other);
        let a = push_best(&report);
        assert!(
            a.len() == 1
                && a[0].starts_with("Push calibration-elasto-kinematic-servo.json")
                && a[0].contains("of the 2 options validated"),
            "{a:?}"
        );
    }
}
