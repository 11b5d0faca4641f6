//! The parameters as a person reads them: in mm, degrees and degrees per
//! N·m (the report's JSON keeps SI units), grouped by the part of the arm
//! they belong to (the base, each joint, the tool), each with its ± one
//! standard deviation and whether it was fitted, is poorly determined or
//! held; and each joint's play and spring on their own.

use lrmcal_core::io::calibration_file::FittedParam;
use lrmcal_engine::calib::ParamKey;
use lrmcal_engine::calib::results::report::{OptionReport, Report};
use model::ParamId;
use model::params::{ParamKind, ParamPart};

use super::html::{grouped_table, para, table};
use super::sections::{per_option, title};

/// A parameter's unit on the page and the factor from its SI value.
fn unit(key: ParamKey) -> (&'static str, f64) {
    let degrees = 1f64.to_degrees();
    match key {
        ParamKey::Softening { .. } => ("1/(N·m)", 1.0),
        // Relative or per focal length: dimensionless (`calib::parameters::camera`).
        ParamKey::Lens { .. } => ("", 1.0),
        key => match key.kind() {
            ParamKind::Length => ("mm", 1e3),
            ParamKind::Angle => ("°", degrees),
            ParamKind::Compliance => ("°/(N·m)", degrees),
        },
    }
}

/// `x` with `digits` significant digits, in plain notation unless it is
/// very small or large; `–` when it is not finite.
pub fn significant(x: f64, digits: i32) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let magnitude = x.abs().log10().floor() as i32;
    if !(-5..6).contains(&magnitude) {
        return format!("{:.*e}", (digits - 1).max(0) as usize, x);
    }
    let decimals = (digits - 1 - magnitude).clamp(0, 9) as usize;
    format!("{x:.decimals$}")
}

/// Where a parameter belongs: `base` (its placement and spring), `joint
/// N`, `tool` (the tool points), or `other`; with its order on the page.
fn group(key: ParamKey) -> (usize, String) {
    if key.is_tool() {
        return (usize::MAX - 1, "tool".into());
    }
    match key.joint() {
        Some(j) => (j + 1, format!("joint {}", j + 1)),
        // What belongs to no joint and no tool is the base's: its placement,
        // its spring `k0` and that spring's softening `s0`.
        None => (0, "base".into()),
    }
}

/// A fitted parameter's row: name, correction, value and deviation in its
/// unit, the unit, and its status.
fn fitted_row(o: &OptionReport, p: &FittedParam) -> Vec<String> {
    let f = &o.fit;
    let (unit, factor) = unit(p.name);
    let status = if p.std.is_none() || f.at_bound.contains(&p.name) {
        "held at its bound"
    } else if f.weak.contains(&p.name) {
        "fitted, poorly determined"
    } else {
        "fitted"
    };
    vec![
        p.name.to_string(),
        format!(
            "{}{}",
            if p.error >= 0.0 { "+" } else { "" },
            significant(p.error * factor, 4)
        ),
        significant(p.value * factor, 5),
        p.std.map_or("–".into(), |s| {
            format!("±\u{a0}{}", significant(s * factor, 2))
        }),
        unit.into(),
        status.into(),
    ]
}

/// Each option's parameters, one group of rows per part of the arm:
/// fitted (with their deviations), held at a bound, poorly determined,
/// and those held at nominal with why.
pub fn parameters(report: &Report) -> String {
    let mut out = para(
        "Corrections and values in mm, degrees and degrees per N·m (report.json has them in SI units), ± one standard deviation, grouped by the part of the arm they belong to. A parameter the poses barely determine is flagged; one held at nominal or at a bound was not fitted.",
    );
    for (i, o) in report.options.iter().enumerate() {
        let f = &o.fit;
        let mut rows: Vec<(usize, String, Vec<String>)> = f
            .parameters
            .iter()
            .map(|p| {
                let (order, name) = group(p.name);
                (order, name, fitted_row(o, p))
            })
            .collect();
        rows.extend(
            o.identifiability
                .removed
                .iter()
                .filter(|r| !f.parameters.iter().any(|p| p.name == r.name))
                .map(|r| {
                    let (order, name) = group(r.name);
                    (
                        order,
                        name,
                        vec![
                            r.name.to_string(),
                            "0".into(),
                            "nominal".into(),
                            "–".into(),
                            unit(r.name).0.into(),
                            format!("held at nominal: {}", r.explain()),
                        ],
                    )
                }),
        );
        // Stable: within a group, the order of the report.
        rows.sort_by_key(|r| r.0);
        let mut groups: Vec<(String, Vec<Vec<String>>)> = Vec::new();
        for (_, name, row) in rows {
            match groups.last_mut() {
                Some((last, rows)) if *last == name => rows.push(row),
                _ => groups.push((name, vec![row])),
            }
        }
        out.push_str(&grouped_table(
            &format!("params-{i}"),
            &format!("{}: {} parameters fitted", title(o), f.parameters.len()),
            &["parameter", "correction", "value", "±", "unit", "status"],
            &groups,
        ));
    }
    out
}

/// Parameter `key` of `o`, as `value ± std` in its unit, or `–`.
fn shown(o: &OptionReport, key: Option<ParamKey>) -> String {
    let Some(p) = o.fit.parameters.iter().find(|p| Some(p.name) == key) else {
        return "–".into();
    };
    let (_, factor) = unit(p.name);
    let mut text = significant(p.value * factor, 4);
    match p.std {
        Some(s) => text.push_str(&format!(" ±\u{a0}{}", significant(s * factor, 2))),
        None => text.push_str(" (held at its bound)"),
    }
    if o.fit.weak.contains(&p.name) {
        text.push_str(" (poorly determined)");
    }
    text
}

/// Each joint's play (the full width of its backlash) and spring (its
/// compliance and how that softens with torque), per option that fits any.
pub fn mechanics(report: &Report) -> String {
    per_option(
        report,
        |o| {
            o.fit
                .parameters
                .iter()
                .any(|p| {
                    matches!(
                        p.name,
                        ParamKey::Backlash { .. } | ParamKey::Softening { .. }
                    ) || p.name.kind() == ParamKind::Compliance
                })
                .then_some(o)
        },
        "No option of this run fits a joint's play or spring.",
        |i, o, _| {
            let joints = o
                .fit
                .parameters
                .iter()
                .filter_map(|p| p.name.joint())
                .max()
                .map_or(0, |j| j + 1);
            // Spring 0 is the base's, spring j + 1 joint j's.
            let spring = |spring: usize| {
                let compliance = match spring.checked_sub(1) {
                    None => ParamPart::BaseCompliance,
                    Some(joint) => ParamPart::Compliance { joint },
                };
                [
                    ParamId::from_part(compliance).map(ParamKey::Arm),
                    u8::try_from(spring)
                        .ok()
                        .map(|spring| ParamKey::Softening { spring }),
                ]
                .map(|key| shown(o, key))
            };
            let [k, s] = spring(0);
            let mut rows = vec![vec!["base".into(), "–".into(), k, s]];
            rows.extend((1..=joints).map(|j| {
                let play = u8::try_from(j - 1)
                    .ok()
                    .map(|joint| ParamKey::Backlash { joint });
                let [k, s] = spring(j);
                vec![format!("joint {j}"), shown(o, play), k, s]
            }));
            rows.retain(|r| r[1..].iter().any(|c| c != "–"));
            table(
                &format!("mechanics-{i}"),
                &format!(
                    "{}: each joint's play and spring as fitted, ± one standard deviation (– not fitted)",
                    title(o)
                ),
                &[
                    "part",
                    "play (backlash, full width) °",
                    "spring compliance °/(N·m)",
                    "spring softening 1/(N·m)",
                ],
                &rows,
            )
        },
    )
}

#[cfg(test)]
mod tests {
    use super::super::fixture::key;
    use super::*;

    #[test]
    fn numbers_keep_their_significant_digits() {
        assert_eq!(significant(1.23456, 3), "1.23");
        assert_eq!(significant(-0.000123456, 3), "-0.000123");
        assert_eq!(significant(123.456, 4), "123.5");
        assert_eq!(significant(1234567.0, 3), "1.23e6");
        assert_eq!(significant(0.0, 3), "0");
        assert_eq!(significant(f64::NAN, 3), "–");
    }

    #[test]
    fn units_are_a_person_s() {
        assert_eq!(unit(key("j2.d")), ("mm", 1e3));
        assert_eq!(unit(key("tool[2].x")).0, "mm");
        assert_eq!(unit(key("j3.servo[5]")).0, "°");
        assert_eq!(unit(key("j6.backlash")).0, "°");
        assert_eq!(unit(key("k2")).0, "°/(N·m)");
        assert_eq!(unit(key("s2")).0, "1/(N·m)");
        assert_eq!(group(key("k2")), (2, "joint 2".into()));
        assert_eq!(group(key("base.yaw")), (0, "base".into()));
        assert_eq!(group(key("k0")), (0, "base".into()));
        assert_eq!(group(key("tool[1].z")).1, "tool");
        assert_eq!(group(key("j3.servo[5]")).1, "joint 3");
    }
}
