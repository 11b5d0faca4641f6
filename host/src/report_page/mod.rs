//! `report.html`: one self-contained page per calibration, built from the
//! report (`lrmcal_engine::calib::results::report::Report`) that
//! `report.json` holds, so `identify`, `demo` and `lrmcal report` write the
//! same page for the same report. It shows what was fitted and how well
//! (the summary table and the error plots), the parameters, the suspect
//! measurements, the selection, the knot choice, the registration, and what
//! to do next ([`advice`]).
//!
//! Everything is inline: the CSS, the plots as SVG; the page loads nothing
//! (no script, image, font or style from anywhere) and needs no JavaScript.
//! Text from files passes through [`html::escape`].

pub mod advice;
mod figures;
pub mod html;
mod sections;

#[cfg(test)]
mod fixture;

use std::fmt::Write;
use std::path::{Path, PathBuf};

use lrmcal_engine::calib::results::report::Report;

use crate::commands::helpers::write_text;
use crate::error::Error;
use html::{escape, para};

/// The page's file name in a calibration folder.
pub const PAGE: &str = "report.html";

/// The ids of the page's sections, in order, with their headings.
pub const SECTIONS: [(&str, &str); 9] = [
    ("next", "What to do next"),
    ("summary", "Summary"),
    ("errors", "Errors before and after"),
    ("suspect", "Suspect measurements"),
    ("parameters", "Parameters"),
    ("selection", "Selection and observability"),
    ("model", "How much model the poses carry"),
    ("knots", "Servo curve knots"),
    ("registration", "Registration"),
];

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:0 auto;max-width:1100px;padding:1em;color:#222}\
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}\
nav ul{list-style:none;padding:0;display:flex;flex-wrap:wrap;gap:.4em 1.2em}\
table{border-collapse:collapse;margin:1em 0;font-size:.9em}caption{text-align:left;font-weight:600;padding:.3em 0}\
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:left;vertical-align:top}th{background:#f2f2f2}\
tbody tr:nth-child(even){background:#fafafa}figure{margin:1em 0}svg{max-width:100%;height:auto;border:1px solid #eee}\
figcaption{font-size:.9em;color:#555}#next li{margin:.4em 0}.meta{color:#555}";

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
            "suspect" => sections::suspect(report),
            "parameters" => sections::parameters(report),
            "selection" => sections::selection(report),
            "model" => sections::model(report),
            "knots" => sections::knots(report),
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

/// The advice as a list.
fn next(report: &Report) -> String {
    let items = advice::advice(report);
    if items.is_empty() {
        return para("Nothing to advise: no option was fitted.");
    }
    let mut out = String::from("<ul id=\"advice\">\n");
    for item in items {
        let _ = writeln!(out, "<li>{}</li>", escape(&item));
    }
    out.push_str("</ul>\n");
    out
}

/// The plots, each in a figure with its caption.
fn errors(report: &Report, page: &Path) -> Result<String, Error> {
    let plots: Vec<_> = figures::errors(report, page)?
        .into_iter()
        .chain(figures::experiments(report, page)?)
        .collect();
    if plots.is_empty() {
        return Ok(para(
            "No measured pose was held out of the fit, so there are no validation errors to plot (see the summary for the fit's own residuals).",
        ));
    }
    let mut out = String::new();
    for p in plots {
        let _ = write!(
            out,
            "<figure id=\"{}\">\n{}\n<figcaption>{}</figcaption>\n</figure>\n",
            escape(&p.id),
            p.svg,
            escape(&p.caption)
        );
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
            "summary-table",
            "params-0",
            "suspect-table",
            "selection-table",
            "knots-0",
            "registration-table",
        ] {
            assert!(html.contains(&format!("<table id=\"{id}\">")), "{id}");
        }
        for id in ["fig-errors", "fig-per-pose-0"] {
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
        report.registration = None;
        let html = page(&report);
        assert!(!html.contains("<svg"));
        assert!(html.contains("No measured pose was held out of the fit"));
        assert!(html.contains("No option of this run fits servo curves"));
        assert!(html.contains("The arm was not registered"));
        assert!(html.contains("<li>Every measured pose was fitted"));
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
