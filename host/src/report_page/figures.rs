//! The page's plots, drawn by `crate::plots` into SVG text from the
//! report's numbers: the validation error per option (and across loads),
//! each option's error per measurement (fitted, left out, held out), the
//! measured points in two views of the workspace coloured by their error,
//! each identified servo curve, and the demo's O1 and error against the
//! number of poses.

use std::path::Path;

use lrmcal_engine::calib::results::report::{OptionReport, Report, ValidationReport};
use lrmcal_engine::calib::results::servo_curves::ServoCurveReport;

use crate::error::Error;
use crate::plots::page::{
    MarkedSeries, Marker, Panel, PerPose, ServoCurve, ValuedPoint, Workspace,
};
use crate::plots::{self, Boxes, Figure, Lines};

/// A plot for the page: its element id, caption and SVG.
pub struct Plot {
    /// The `<figure>`'s id.
    pub id: String,
    /// What it shows.
    pub caption: String,
    /// The drawing, inline SVG.
    pub svg: String,
}

impl Plot {
    /// The plot as a `<figure>` with its caption.
    pub fn html(&self) -> String {
        super::html::figure(&self.id, &self.svg, &self.caption)
    }
}

/// The figure drawn as SVG for inline use: the namespace declaration goes
/// (an HTML parser puts `<svg>` in it by itself), so the page names no URL.
fn inline(figure: &impl Figure, page: &Path) -> Result<String, Error> {
    let svg = plots::svg(figure, page)?;
    Ok(svg.replacen(r#" xmlns="http://www.w3.org/2000/svg""#, "", 1))
}

/// Whether `v` has the error of each measurement.
fn with_poses(v: Option<&ValidationReport>) -> bool {
    v.is_some_and(|v| !v.per_pose.is_empty())
}

/// The validation box plots of `report` (before/after per option, and
/// across loads), for `page`; none without held-out poses.
pub fn validation(report: &Report, page: &Path) -> Result<Vec<Plot>, Error> {
    let mut out = Vec::new();
    let load = report.identify_load_kg;
    for (cross_load, id, caption) in [
        (
            false,
            "fig-errors",
            format!(
                "Validation error on the poses held out, {load} kg: uncalibrated, then each option"
            ),
        ),
        (
            true,
            "fig-errors-cross-load",
            "Cross-load: each option validated under the other load".to_string(),
        ),
    ] {
        let options: Vec<_> = report
            .options
            .iter()
            .filter(|o| o.identify_load_kg == load)
            .cloned()
            .collect();
        let present = options.iter().any(|o| {
            with_poses(if cross_load {
                o.cross_load.as_ref()
            } else {
                o.validation.as_ref()
            })
        });
        if !present {
            continue;
        }
        let boxes = plots::validation_boxes(&options, cross_load);
        out.push(Plot {
            id: id.into(),
            svg: inline(
                &Boxes {
                    title: &caption,
                    boxes: &boxes,
                },
                page,
            )?,
            caption,
        });
    }
    Ok(out)
}

/// Colours of the kinds of error, RGB.
const UNCALIBRATED: (u8, u8, u8) = (127, 127, 127);
const CALIBRATED: (u8, u8, u8) = (31, 119, 180);
const LEFT_OUT: (u8, u8, u8) = (255, 127, 14);
const HELD_OUT: (u8, u8, u8) = (214, 39, 40);

/// The error of each of `o`'s measurements against its pose id, mm: the
/// fitted ones before, after and left out one at a time, the held-out ones
/// before and after.
pub fn per_pose_series(o: &OptionReport) -> Vec<MarkedSeries> {
    let fit = &o.fit.per_pose;
    let held: &[_] = o.validation.as_ref().map_or(&[], |v| &v.per_pose);
    let series = |label: &str, marker, colour, points: Vec<(f64, f64)>| MarkedSeries {
        label: label.into(),
        points,
        marker,
        colour,
    };
    let mut out = vec![
        series(
            "fitted, uncalibrated",
            Marker::Circle,
            UNCALIBRATED,
            fit.iter()
                .map(|p| (f64::from(p.pose), p.before_mm))
                .collect(),
        ),
        series(
            "fitted, calibrated (fit residual)",
            Marker::Circle,
            CALIBRATED,
            fit.iter()
                .map(|p| (f64::from(p.pose), p.after_mm))
                .collect(),
        ),
        series(
            "fitted, left out of the fit one at a time",
            Marker::Circle,
            LEFT_OUT,
            fit.iter().map(|p| (f64::from(p.pose), p.loo_mm)).collect(),
        ),
    ];
    if !held.is_empty() {
        out.push(series(
            "held out, uncalibrated",
            Marker::Triangle,
            UNCALIBRATED,
            held.iter()
                .map(|p| (f64::from(p.pose), p.before_mm))
                .collect(),
        ));
        out.push(series(
            "held out, calibrated",
            Marker::Triangle,
            HELD_OUT,
            held.iter()
                .map(|p| (f64::from(p.pose), p.after_mm))
                .collect(),
        ));
    }
    out
}

/// Each option's error per measurement (`fig-per-pose-N`, N the option's
/// place in the report), for the options whose report has them.
pub fn per_pose(report: &Report, page: &Path) -> Result<Vec<Plot>, Error> {
    let mut out = Vec::new();
    for (i, o) in report.options.iter().enumerate() {
        if o.fit.per_pose.is_empty() && !with_poses(o.validation.as_ref()) {
            continue;
        }
        let title = format!(
            "Error per measurement ({}, fitted with {} kg)",
            o.option, o.identify_load_kg
        );
        let held = match o.validation.as_ref() {
            Some(v) if !v.per_pose.is_empty() => format!(
                "triangles: the {} measurements held out of the fit, before and after",
                v.per_pose.len()
            ),
            _ => "no measurement was held out of the fit".into(),
        };
        let fitted = if o.fit.per_pose.is_empty() {
            "the fitted measurements' errors are not in this report (written before version 5)"
                .to_string()
        } else {
            format!(
                "circles: the {} fitted measurements, uncalibrated, calibrated (the fit's residual) and left out of the fit one at a time (leave-one-out)",
                o.fit.per_pose.len()
            )
        };
        let caption = format!("{title}: {fitted}; {held}. Log scale.");
        let svg = inline(
            &PerPose {
                title: &title,
                x_desc: "pose id",
                y_desc: "3D error (mm, log scale)",
                series: &per_pose_series(o),
            },
            page,
        )?;
        out.push(Plot {
            id: format!("fig-per-pose-{i}"),
            caption,
            svg,
        });
    }
    Ok(out)
}

/// The measured points of `o` with their positions, mm: each as (x, y, z,
/// error before, error after, held out).
fn located(o: &OptionReport) -> Vec<([f64; 3], f64, f64, bool)> {
    let fitted = o
        .fit
        .per_pose
        .iter()
        .map(|p| (p.xyz_mm, p.before_mm, p.after_mm, false));
    let held = o
        .validation
        .iter()
        .flat_map(|v| &v.per_pose)
        .filter_map(|p| Some((p.xyz_mm?, p.before_mm, p.after_mm, true)));
    fitted.chain(held).collect()
}

/// The workspace seen from above (x–y) and from the side (x–z), the
/// measured points of `o` coloured by their error before and after
/// (`fig-workspace-top`, `fig-workspace-side`); none when the report has no
/// positions (written before it had them).
pub fn workspace(o: &OptionReport, page: &Path) -> Result<Vec<Plot>, Error> {
    let points = located(o);
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let held = points.iter().filter(|p| p.3).count();
    let mut out = Vec::new();
    for (id, view, b, b_desc) in [
        ("fig-workspace-top", "from above (x–y)", 1, "y (mm)"),
        ("fig-workspace-side", "from the side (x–z)", 2, "z (mm)"),
    ] {
        let panel = |after: bool| Panel {
            title: if after {
                format!("calibrated ({})", o.option)
            } else {
                "uncalibrated".into()
            },
            points: points
                .iter()
                .map(|&(xyz, before, after_mm, held)| ValuedPoint {
                    a: xyz[0],
                    b: xyz[b],
                    value: if after { after_mm } else { before },
                    marker: if held {
                        Marker::Triangle
                    } else {
                        Marker::Circle
                    },
                })
                .collect(),
        };
        let title = format!("The measured points seen {view}, coloured by their error");
        let svg = inline(
            &Workspace {
                title: &title,
                a_desc: "x (mm)",
                b_desc,
                value_desc: "3D error (mm)",
                panels: &[panel(false), panel(true)],
            },
            page,
        )?;
        out.push(Plot {
            id: id.into(),
            caption: format!(
                "{title}, before calibration (left) and after, with {} (right; each panel its own colour scale, the largest errors yellow). In the arm's frame, where the fit ran. Circles: the {} fitted measurements (the fit's residual); triangles: the {held} held out (the validation error).",
                o.option,
                points.len() - held
            ),
            svg,
        });
    }
    Ok(out)
}

/// One figure per identified servo curve of `o`, option `i` of the report
/// (`fig-servo-I-jJ`, J the joint from 1).
pub fn servo(i: usize, o: &OptionReport, page: &Path) -> Result<Vec<Plot>, Error> {
    o.servo_curves
        .iter()
        .map(|c: &ServoCurveReport| {
            let title = format!("Joint {}'s servo curve ({})", c.joint, o.option);
            let curve: Vec<(f64, f64, f64)> = c
                .curve
                .iter()
                .map(|p| (p.commanded_deg, p.offset_deg, p.std_deg))
                .collect();
            let knots: Vec<(f64, f64, Option<f64>)> = c
                .knots
                .iter()
                .map(|k| (k.commanded_deg, k.offset_deg, k.std_deg))
                .collect();
            let svg = inline(
                &ServoCurve {
                    title: &title,
                    curve: &curve,
                    knots: &knots,
                },
                page,
            )?;
            let widest = c
                .curve
                .iter()
                .map(|p| p.std_deg)
                .filter(|s| s.is_finite())
                .fold(0.0, f64::max);
            Ok(Plot {
                id: format!("fig-servo-{i}-j{}", c.joint),
                caption: format!(
                    "{title}: where joint {} really stands, minus the angle the arm file's servo curve says a command reaches, against the angle commanded; the band is ± one standard deviation from the fit's covariance (at most ±{widest:.3}°), the dots the {} knots (open: held, its offset being the joint's θ).",
                    c.joint,
                    c.knots.len()
                ),
                svg,
            })
        })
        .collect()
}

/// The demo's experiments, when the report has them: O1 and the mean error
/// against the number of poses.
pub fn experiments(report: &Report, page: &Path) -> Result<Vec<Plot>, Error> {
    let mut out = Vec::new();
    if !report.o1_vs_poses.is_empty() {
        let caption = "O1 of DETMAX selections against the number of poses".to_string();
        let svg = inline(
            &Lines {
                title: &caption,
                x_desc: "number of poses",
                y_desc: "O1",
                series: &plots::o1_series(&report.o1_vs_poses),
                lines: true,
            },
            page,
        )?;
        out.push(Plot {
            id: "fig-o1-vs-poses".into(),
            caption,
            svg,
        });
    }
    if !report.error_vs_poses.is_empty() {
        let caption = format!(
            "Mean error against the number of poses fitted, {} kg",
            report.identify_load_kg
        );
        let svg = inline(
            &Lines {
                title: &caption,
                x_desc: "number of poses (DETMAX)",
                y_desc: "mean 3D error (mm)",
                series: &plots::error_series(&report.error_vs_poses),
                lines: true,
            },
            page,
        )?;
        out.push(Plot {
            id: "fig-errors-vs-poses".into(),
            caption,
            svg,
        });
    }
    Ok(out)
}
