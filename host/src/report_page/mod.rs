//! `report.html`: one self-contained page per calibration, built from the
//! report (`lrmcal_engine::calib::results::report::Report`) that
//! `report.json` holds, so `identify`, `demo` and `lrmcal report` write the
//! same page for the same report. Its first screen answers whether the
//! calibration is good and what to do next (the verdict, the headline
//! numbers before → after, the file to push and the [`advice`]); below
//! come the summary, the error of every measurement (fitted, left out,
//! held out), where in the workspace the arm was worst, each identified
//! servo curve, each joint's play and spring, the suspect measurements, the
//! parameters in a person's units grouped per joint, the selection, the
//! model and knot choices and the registration.
//!
//! Everything is inline: the CSS, the plots as SVG; the page loads nothing
//! (no script, image, font or style from anywhere) and needs no JavaScript.
//! Text from files passes through [`html::escape`].

pub mod advice;
mod figures;
pub mod html;
mod parameters;
mod sections;

#[cfg(test)]
mod fixture;

use std::fmt::Write;
use std::path::{Path, PathBuf};

use lrmcal_engine::calib::results::report::{OptionReport, Report};

use crate::commands::helpers::write_text;
use crate::error::Error;
use html::{escape, num, para};

/// The page's file name in a calibration folder.
pub const PAGE: &str = "report.html";

/// The ids of the page's sections, in order, with their headings.
pub const SECTIONS: [(&str, &str); 13] = [
    ("next", "Is it good, and what to do next"),
    ("summary", "Summary"),
    ("errors", "Errors before and after, pose by pose"),
    ("workspace", "Where in the workspace the arm was worst"),
    ("servo", "Servo curves"),
    ("mechanics", "Play and springs"),
    ("suspect", "Suspect measurements"),
    ("parameters", "Parameters"),
    ("selection", "Selection and observability"),
    ("model", "How much model the poses carry"),
    ("knots", "Servo curve knots"),
    ("registration", "Registration"),
    ("camera", "The camera"),
];

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:0 auto;max-width:1100px;padding:1em;color:#222}\
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}\
nav ul{list-style:none;padding:0;display:flex;flex-wrap:wrap;gap:.4em 1.2em}\
table{border-collapse:collapse;margin:1em 0;font-size:.9em}caption{text-align:left;font-weight:600;padding:.3em 0}\
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:left;vertical-align:top}th{background:#f2f2f2}\
tbody tr:nth-child(even){background:#fafafa}figure{margin:1em 0}svg{max-width:100%;height:auto;border:1px solid #eee}\
figcaption{font-size:.9em;color:#555}#next li{margin:.4em 0}.meta{color:#555}\
#verdict{font-size:1.15em}#push{font-weight:600}code{background:#f4f4f4;padding:0 .2em}\
th[scope=rowgroup]{background:#e8eef5}";

/// The page of `report`, which is to be written to `page` (named in errors).
pub fn render(report: &Report, page: &Path) -> Result<String, Error> {
    let source = report
        .measurements
        .get("source")
        .and_then(|s| s.as_str())
        .unwrap_or("-");
    let mut options: Vec<String> = Vec::new();
    for o in &report.options {
        if !options.contains(&o.option.to_string()) {
            options.push(o.option.to_string());
        }
    }
    let mut out = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>lrmcal calibration report: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
         <h1>Calibration report</h1>\n<p class=\"meta\">Arm: {}; measurements: {}; {} candidate poses; fitted under {} kg; options: {}. Built from report.json (schema {} version {}).</p>\n<nav><ul>",
        escape(source),
        escape(&report.arm),
        escape(source),
        report.candidates,
        report.identify_load_kg,
        escape(&options.join(", ")),
        escape(&report.schema),
        report.schema_version,
    );
    for (id, heading) in SECTIONS {
        let _ = write!(out, "<li><a href=\"#{id}\">{heading}</a></li>");
    }
    out.push_str("</ul></nav>\n");
    for (id, heading) in SECTIONS {
        let body = match id {
            "next" => next(report),
            "summary" => sections::summary(report),
            "errors" => errors(report, page)?,
            "workspace" => workspace(report, page)?,
            "servo" => servo(report, page)?,
            "mechanics" => parameters::mechanics(report),
            "suspect" => sections::suspect(report),
            "parameters" => parameters::parameters(report),
            "selection" => sections::selection(report),
            "model" => sections::model(report),
            "knots" => sections::knots(report),
            "camera" => sections::camera(report),
            _ => sections::registration(report),
        };
        let _ = write!(
            out,
            "<section id=\"{id}\">\n<h2>{heading}</h2>\n{body}</section>\n"
        );
    }
    out.push_str("</body>\n</html>\n");
    Ok(out)
}

/// Writes `report`'s page into `dir` whole or not at all; its path.
pub fn write(dir: &Path, report: &Report) -> Result<PathBuf, Error> {
    let path = dir.join(PAGE);
    write_text(&path, &render(report, &path)?)?;
    Ok(path)
}

/// The first screen: is it good (the verdict), the headline numbers of the
/// calibration it is about before → after, the file to push, and the advice.
fn next(report: &Report) -> String {
    let Some(o) = advice::focus(report) else {
        return para("Nothing to advise: no option was fitted.");
    };
    let problems = advice::problems(report).len();
    let look = match problems {
        0 => String::new(),
        1 => " Look at the point below first.".into(),
        n => format!(" Look at the {n} points below first."),
    };
    let best = advice::best(report);
    let verdict = match best {
        Some((o, v)) if v.reduction_pct > 0.0 => format!(
            "{}: on the {} measurements held out of the fit (poses it never saw), calibration-{}.json cuts the mean error from {} to {} mm ({} % less).{look}",
            if problems == 0 {
                "Good"
            } else {
                "Good, with reservations"
            },
            v.after.count,
            o.option,
            num(v.before.mean_m * 1e3, 2),
            num(v.after.mean_m * 1e3, 2),
            num(v.reduction_pct, 1),
        ),
        Some((o, v)) => format!(
            "Not good: on the {} measurements held out of the fit, calibration-{}.json is no better than the arm uncalibrated ({} mm mean before, {} after).{look}",
            v.after.count,
            o.option,
            num(v.before.mean_m * 1e3, 2),
            num(v.after.mean_m * 1e3, 2),
        ),
        None if !o.fit.converged => format!(
            "Not good: no option's fit converged ({} ended with {}).{look}",
            o.option, o.fit.termination
        ),
        None => format!(
            "Not known yet: no measured pose was held out of the fit, so there are only the fit's own numbers ({}: residual {} mm RMS, {} mm mean when each measurement is left out). Measure validation poses too (lrmcal select sets them aside) to know.{look}",
            o.option,
            num(o.fit.rms_after_mm, 2),
            num(o.fit.loo_mean_mm, 2),
        ),
    };
    let mut out = format!("<p id=\"verdict\">{}</p>\n", escape(&verdict));
    out.push_str(&headline(o));
    let push = match best {
        Some((o, _)) => format!(
            "File to push: calibration-{}.json, from this folder: lrmcal push calibration-{}.json (with --dry-run first, the board's checks without a board).",
            o.option, o.option
        ),
        None => "No file to push yet: none was validated on poses held out of the fit.".into(),
    };
    let _ = writeln!(out, "<p id=\"push\">{}</p>", escape(&push));
    let items = advice::advice(report);
    if !items.is_empty() {
        out.push_str("<ul id=\"advice\">\n");
        for item in items {
            let _ = writeln!(out, "<li>{}</li>", escape(&item));
        }
        out.push_str("</ul>\n");
    }
    out
}

/// The headline numbers of `o`, before → after: on the poses held out, on
/// the fitted ones, and on the fitted ones left out one at a time.
fn headline(o: &OptionReport) -> String {
    let mm = |m: f64| num(m * 1e3, 2);
    let arrow = |b: String, a: String| format!("{b} → {a}");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let max = |v: &[f64]| v.iter().copied().fold(f64::NAN, f64::max);
    let mut rows = Vec::new();
    if let Some(v) = &o.validation {
        rows.push(vec![
            format!("held out of the fit ({} kg)", v.load_kg),
            v.after.count.to_string(),
            arrow(mm(v.before.mean_m), mm(v.after.mean_m)),
            arrow(mm(v.before.max_m), mm(v.after.max_m)),
        ]);
    }
    let fit = &o.fit.per_pose;
    let before: Vec<f64> = fit.iter().map(|p| p.before_mm).collect();
    let after: Vec<f64> = fit.iter().map(|p| p.after_mm).collect();
    let loo: Vec<f64> = fit.iter().map(|p| p.loo_mm).collect();
    if fit.is_empty() {
        rows.push(vec![
            "fitted (RMS)".into(),
            o.selected_poses.len().to_string(),
            arrow(num(o.fit.rms_before_mm, 2), num(o.fit.rms_after_mm, 2)),
            "–".into(),
        ]);
    } else {
        rows.push(vec![
            format!("fitted ({} kg)", o.identify_load_kg),
            fit.len().to_string(),
            arrow(num(mean(&before), 2), num(mean(&after), 2)),
            arrow(num(max(&before), 2), num(max(&after), 2)),
        ]);
        rows.push(vec![
            "fitted, each left out of the fit".into(),
            loo.len().to_string(),
            arrow(num(mean(&before), 2), num(mean(&loo), 2)),
            arrow(num(max(&before), 2), num(max(&loo), 2)),
        ]);
    }
    if let Some(c) = &o.cross_load {
        rows.push(vec![
            format!("held out, under the other load ({} kg)", c.load_kg),
            c.after.count.to_string(),
            arrow(mm(c.before.mean_m), mm(c.after.mean_m)),
            arrow(mm(c.before.max_m), mm(c.after.max_m)),
        ]);
    }
    html::table(
        "headline-table",
        &format!(
            "{}: 3D error uncalibrated → calibrated, mm",
            sections::title(o)
        ),
        &["measurements", "count", "mean", "largest"],
        &rows,
    )
}

/// The error plots: the validation boxes, every option's error per
/// measurement, and the demo's experiments; what was held out, said first.
fn errors(report: &Report, page: &Path) -> Result<String, Error> {
    let mut out = String::new();
    if !report.options.iter().any(|o| o.validation.is_some()) {
        out.push_str(&para(
            "No measured pose was held out of the fit, so there are no validation errors: the figures show the fit's own residuals and each fitted measurement's error when it is left out of the fit (leave-one-out), the nearest to a validation the fit gives.",
        ));
    }
    for p in figures::validation(report, page)?
        .into_iter()
        .chain(figures::per_pose(report, page)?)
        .chain(figures::experiments(report, page)?)
    {
        out.push_str(&p.html());
    }
    Ok(out)
}

/// Where the arm was worst: the option the page is about, seen from above
/// and from the side.
fn workspace(report: &Report, page: &Path) -> Result<String, Error> {
    let plots = match advice::focus(report) {
        Some(o) => figures::workspace(o, page)?,
        None => Vec::new(),
    };
    if plots.is_empty() {
        return Ok(para(
            "The report has no measured positions to draw (no option was fitted, or it was written before reports had them).",
        ));
    }
    Ok(plots.iter().map(figures::Plot::html).collect())
}

/// Each identified servo curve, one figure per joint and option.
fn servo(report: &Report, page: &Path) -> Result<String, Error> {
    let mut out = String::new();
    for (i, o) in report.options.iter().enumerate() {
        for p in figures::servo(i, o, page)? {
            out.push_str(&p.html());
        }
    }
    if out.is_empty() {
        return Ok(para(
            "No servo curve was identified: no option of this run fits them, or the poses did not carry them (the model kept is simpler; see \"How much model the poses carry\"), or report.json was written before it held them (version 5).",
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn page(report: &Report) -> String {
        render(report, Path::new("report.html")).unwrap()
    }

    #[test]
    fn every_section_table_and_plot_is_there() {
        let html = page(&fixture::report());
        for (id, heading) in SECTIONS {
            assert!(
                html.contains(&format!("<section id=\"{id}\">\n<h2>{heading}</h2>")),
                "{id}"
            );
            assert!(html.contains(&format!("<a href=\"#{id}\">")), "{id}");
        }
        for id in [
            "headline-table",
            "summary-table",
            "params-0",
            "mechanics-0",
            "suspect-table",
            "selection-table",
            "knots-0",
            "registration-table",
        ] {
            assert!(html.contains(&format!("<table id=\"{id}\">")), "{id}");
        }
        for id in [
            "fig-errors",
            "fig-per-pose-0",
            "fig-workspace-top",
            "fig-workspace-side",
            "fig-servo-0-j2",
        ] {
            let start = html.find(&format!("<figure id=\"{id}\">")).expect(id);
            let figure = &html[start..start + html[start..].find("</figure>").unwrap()];
            assert!(
                figure.contains("<svg ") && figure.contains("<circle"),
                "{id}"
            );
        }
        assert!(html.contains("<li>Push calibration-elasto-kinematic-servo.json"));
        // The held parameter, with why.
        assert!(html.contains("held at nominal: j1.d: confounded with +1.000·base.z"));
        // The first screen: the verdict from the held-out numbers, the file to push.
        assert!(
            html.contains("<p id=\"verdict\">Good: on the 4 measurements held out of the fit (poses it never saw), calibration-elasto-kinematic-servo.json cuts the mean error from 38.75 to 1.03 mm (97.3 % less).</p>"),
            "{html}"
        );
        assert!(
            html.contains("<p id=\"push\">File to push: calibration-elasto-kinematic-servo.json")
        );
        let first_figure = html.find("<figure").unwrap();
        for first in [
            "id=\"verdict\"",
            "id=\"headline-table\"",
            "id=\"push\"",
            "id=\"advice\"",
        ] {
            assert!(html.find(first).unwrap() < first_figure, "{first}");
        }
    }

    /// The headline: held out, fitted and left out, before → after, worked
    /// out from the measurements' errors.
    #[test]
    fn the_headline_gives_before_and_after() {
        let html = page(&fixture::report());
        let start = html.find("<table id=\"headline-table\">").unwrap();
        let table = &html[start..start + html[start..].find("</table>").unwrap()];
        // Fixture: fitted before 31..36 (mean 33.5), after 0.6..1.1 (mean 0.85), left out 0.9..1.4.
        for row in [
            "<td>held out of the fit (0.0663 kg)</td><td>4</td><td>38.75 → 1.03</td><td>79.00 → 2.08</td>",
            "<td>fitted (0.0663 kg)</td><td>6</td><td>33.50 → 0.85</td><td>36.00 → 1.10</td>",
            "<td>fitted, each left out of the fit</td><td>6</td><td>33.50 → 1.15</td><td>36.00 → 1.40</td>",
        ] {
            assert!(table.contains(row), "{row}\n{table}");
        }
    }

    /// Parameters in mm, degrees and degrees per N·m, one group per part of
    /// the arm; the play and spring of each joint on their own.
    #[test]
    fn parameters_are_in_a_person_s_units_grouped_per_joint() {
        let html = page(&fixture::report());
        let start = html.find("<table id=\"params-0\">").unwrap();
        let table = &html[start..start + html[start..].find("</table>").unwrap()];
        let groups: Vec<&str> = table
            .split("<th scope=\"rowgroup\" colspan=\"6\">")
            .skip(1)
            .map(|g| &g[..g.find('<').unwrap()])
            .collect();
        assert_eq!(groups, ["joint 1", "joint 2", "joint 6"], "{table}");
        for row in [
            "<td>j2.d</td><td>+1.000</td><td>1.0000</td><td>±\u{a0}0.010</td><td>mm</td><td>fitted</td>",
            "<td>k2</td><td>+0.1146</td><td>0.11459</td><td>±\u{a0}0.0057</td><td>°/(N·m)</td><td>fitted</td>",
            "<td>j6.backlash</td><td>+0.5730</td><td>0.57296</td><td>±\u{a0}0.057</td><td>°</td><td>fitted</td>",
        ] {
            assert!(table.contains(row), "{row}\n{table}");
        }
        let start = html.find("<table id=\"mechanics-0\">").unwrap();
        let table = &html[start..start + html[start..].find("</table>").unwrap()];
        assert!(
            table.contains("<td>joint 2</td><td>–</td><td>0.1146 ±\u{a0}0.0057</td><td>–</td>")
                && table
                    .contains("<td>joint 6</td><td>0.5730 ±\u{a0}0.057</td><td>–</td><td>–</td>")
                && !table.contains("<td>joint 3</td>"),
            "{table}"
        );
        let mut weak = fixture::report();
        weak.options[0].fit.weak = vec![fixture::key("k2")];
        assert!(page(&weak).contains("<td>k2</td><td>+0.1146</td><td>0.11459</td><td>±\u{a0}0.0057</td><td>°/(N·m)</td><td>fitted, poorly determined</td>"));
    }

    #[test]
    fn the_page_loads_nothing_and_needs_no_script() {
        let html = page(&fixture::report());
        for external in [
            "http:", "https:", "src=", "url(", "@import", "<script", "<link", "<img", "<iframe",
        ] {
            assert!(!html.contains(external), "the page holds `{external}`");
        }
    }

    #[test]
    fn text_from_files_is_escaped() {
        let mut report = fixture::report();
        report.arm = "<script>alert(1)</script>".into();
        report.measurements = serde_json::json!({"source": "m&<img src=x onerror=alert(1)>.csv"});
        let html = page(&report);
        assert!(
            !html.contains("<script>alert") && !html.contains("<img"),
            "{html}"
        );
        assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt;"));
        assert!(html.contains("m&amp;&lt;img src=x onerror=alert(1)&gt;.csv"));
    }

    #[test]
    fn a_run_without_held_out_poses_or_knots_or_registration_says_so() {
        let mut report = fixture::report();
        let o = &mut report.options[0];
        o.validation = None;
        o.knots = None;
        o.servo_curves.clear();
        report.registration = None;
        let html = page(&report);
        // The fit's own errors are still drawn, with nothing held out.
        assert!(!html.contains("<figure id=\"fig-errors\">"));
        for id in ["fig-per-pose-0", "fig-workspace-top", "fig-workspace-side"] {
            assert!(html.contains(&format!("<figure id=\"{id}\">")), "{id}");
        }
        assert!(html.contains("no measurement was held out of the fit"));
        assert!(html.contains("No measured pose was held out of the fit"));
        assert!(html.contains("<p id=\"verdict\">Not known yet: no measured pose was held out"));
        assert!(html.contains("<p id=\"push\">No file to push yet"));
        assert!(html.contains("No servo curve was identified"));
        assert!(html.contains("No option of this run fits servo curves"));
        assert!(html.contains("The arm was not registered"));
        assert!(html.contains("<li>Every measured pose was fitted"));
    }

    /// A camera's calibration shows where the camera stands, the lens told
    /// and refined, and the pixels; a tracker's says no camera measured.
    #[test]
    fn the_camera_is_shown_in_pixels_and_millimetres() {
        use lrmcal_engine::calib::results::report::{
            CameraReport, LensReport, PixelErrors, PixelsBeforeAfter,
        };
        let mut report = fixture::report();
        assert!(page(&report).contains("No camera measured"));
        let px = |median_px: f64| PixelErrors {
            count: 480,
            median_px,
            rms_px: 1.5 * median_px,
            p95_px: 3.0 * median_px,
            max_px: 5.0 * median_px,
        };
        let lens = |fx: f64| LensReport {
            fx,
            fy: fx,
            cx: 641.0,
            cy: 358.0,
            distortion: [-0.1, 0.06, 0.001, -0.0005, 0.0],
        };
        let o = &mut report.options[0];
        o.camera = Some(CameraReport {
            mount: lrmcal_core::camera::Mount::EyeToHand,
            xyz_mm: [612.3, -48.0, 251.7],
            rpy_deg: [-91.0, 0.5, 88.25],
            quaternion_xyzw: [0.5, -0.5, 0.5, -0.5],
            lens: lens(936.4),
            lens_told: lens(910.0),
            lens_refined: true,
            fit_px: px(0.3),
        });
        o.validation.as_mut().unwrap().pixels = Some(PixelsBeforeAfter {
            before: px(22.9),
            after: px(0.22),
        });
        let html = page(&report);
        assert!(html.contains("id=\"camera-table-0\""));
        for text in [
            "(612.3, -48.0, 251.7) mm",
            "lens refined with the arm",
            "fx 936.4",
            "fx 910.0",
            "median 0.30, rms 0.45",
            "median 22.90, rms 34.35, largest 114.50 px (480 corners) → median 0.22",
        ] {
            assert!(html.contains(text), "{text}");
        }
        assert!(!html.contains("No camera measured"));
    }

    #[test]
    fn the_knots_say_how_they_were_chosen() {
        let mut report = fixture::report();
        let html = page(&report);
        assert!(html.contains("the spacing whose fit best predicts each fitted pose left out"));
        // Under the prior: the correlation length the measurements chose.
        report.options[0].fit.servo_correlation_deg = Some(100.0);
        let html = page(&report);
        assert!(html.contains("their errors correlated over 100° (of 25°, 50°, 100°)"));
        assert!(!html.contains("the spacing whose fit best predicts"));
    }

    /// A report written before the measurements' positions, the fit's own
    /// errors and the servo curves were in it still makes a page: the
    /// held-out errors drawn, the rest said missing.
    #[test]
    fn an_older_report_still_makes_a_page() {
        let mut report = fixture::report();
        let o = &mut report.options[0];
        o.fit.per_pose.clear();
        o.servo_curves.clear();
        for p in &mut o.validation.as_mut().unwrap().per_pose {
            p.xyz_mm = None;
        }
        let html = page(&report);
        assert!(html.contains("<figure id=\"fig-per-pose-0\">"));
        assert!(html.contains("the fitted measurements&#39; errors are not in this report"));
        assert!(!html.contains("fig-workspace"));
        assert!(html.contains("The report has no measured positions to draw"));
        assert!(html.contains("No servo curve was identified"));
        assert!(html.contains("<td>fitted (RMS)</td><td>6</td><td>40.00 → 0.90</td>"));
    }

    #[test]
    fn suspect_measurements_are_listed() {
        let mut report = fixture::report();
        report.options[0]
            .fit
            .outliers
            .push(lrmcal_engine::calib::results::report::OutlierReport {
                pose: 12,
                load_kg: 0.0663,
                residual_mm: 9.5,
                weight: 0.2,
            });
        let html = page(&report);
        let start = html.find("<table id=\"suspect-table\">").unwrap();
        let table = &html[start..start + html[start..].find("</table>").unwrap()];
        assert!(table.contains("<td>12</td><td>0.0663</td><td>elasto-kinematic-servo</td><td>fit: down-weighted</td><td>9.50</td><td>0.20</td>"), "{table}");
        assert!(!html.contains("No measurement was named"));
        assert!(html.contains("<li>1 measurement looks wrong"));
    }
}
