//! The page's plots, drawn by `crate::plots` into SVG text from the
//! report's numbers: the validation error per option (and across loads),
//! each option's error per held-out pose, and the demo's O1 and error
//! against the number of poses.

use std::path::Path;

use lrmcal_engine::calib::results::report::Report;

use crate::error::Error;
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

/// The figure drawn as SVG for inline use: the namespace declaration goes
/// (an HTML parser puts `<svg>` in it by itself), so the page names no URL.
fn inline(figure: &impl Figure, page: &Path) -> Result<String, Error> {
    let svg = plots::svg(figure, page)?;
    Ok(svg.replacen(r#" xmlns="http://www.w3.org/2000/svg""#, "", 1))
}

/// The error plots of `report` (before/after per option, per pose), for `page`.
pub fn errors(report: &Report, page: &Path) -> Result<Vec<Plot>, Error> {
    let mut out = Vec::new();
    let load = report.identify_load_kg;
    let with_poses = |v: Option<&_>| {
        v.is_some_and(
            |v: &lrmcal_engine::calib::results::report::ValidationReport| !v.per_pose.is_empty(),
        )
    };
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
    for (i, o) in report.options.iter().enumerate() {
        if !with_poses(o.validation.as_ref()) {
            continue;
        }
        let title = format!(
            "Error per validation pose ({}, fitted with {} kg)",
            o.option, o.identify_load_kg
        );
        let svg = inline(
            &Lines {
                title: &title,
                x_desc: "pose id",
                y_desc: "3D error norm (mm)",
                series: &plots::per_pose_series(o),
                lines: false,
            },
            page,
        )?;
        out.push(Plot {
            id: format!("fig-per-pose-{i}"),
            caption: title,
            svg,
        });
    }
    Ok(out)
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
