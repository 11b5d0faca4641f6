//! The figures a person looks at first, each written as SVG and PNG files
//! ([`write`]) or drawn into an SVG string for a page ([`svg`]): the error
//! distribution per option before/after (box and points, like the paper's
//! figure 2), the error of every validation pose, and O1 against the number
//! of selected poses. [`demo_figures`] shapes a run's report into them; the
//! figures ([`Boxes`], [`Lines`]) take plain series. The report page's own
//! figures (errors per measurement, the workspace, servo curves) are in [`page`].
//!
//! The PNG's text is drawn with DejaVu Sans embedded in the binary (the
//! `dejavu` crate), so plotting needs no system fonts; an SVG names the
//! generic `sans-serif` family and leaves the glyphs to its viewer.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use lrmcal_engine::calib::ModelOption;
use lrmcal_engine::calib::results::figures::{ErrorPoint, O1Point};
use lrmcal_engine::calib::results::report::{OptionReport, ValidationReport};
use lrmcal_engine::sim::positioning::Positioning;

use crate::Error;

pub mod page;

const SIZE: (u32, u32) = (960, 600);
static FONT: Once = Once::new();

/// Registers the embedded font once per process.
fn register_font() {
    FONT.call_once(|| {
        // The bytes are a valid TTF shipped by the `dejavu` crate; if they were
        // not, text would be missing from the plots, nothing worse.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// One box of the distribution plot: a label and its values (mm).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution {
    /// Category label.
    pub label: String,
    /// Values, mm.
    pub values_mm: Vec<f64>,
}

/// Something drawable on any plotters backend.
pub trait Figure {
    /// Draws the figure on `root` and presents it; plotters' message on failure.
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Draws `figure` into `<stem>.svg` and `<stem>.png`; returns both paths.
pub fn write(stem: &Path, figure: &impl Figure) -> Result<Vec<PathBuf>, Error> {
    register_font();
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    let fail = |path: &Path, message: String| Error::Plot {
        path: path.to_owned(),
        message,
    };
    figure
        .draw(SVGBackend::new(&svg, SIZE).into_drawing_area())
        .map_err(|m| fail(&svg, m))?;
    figure
        .draw(BitMapBackend::new(&png, SIZE).into_drawing_area())
        .map_err(|m| fail(&png, m))?;
    Ok(vec![svg, png])
}

/// Draws `figure` as SVG text, the same figure [`write`] puts in its `.svg`
/// file; `page` names the file it is drawn for, in an error.
pub fn svg(figure: &impl Figure, page: &Path) -> Result<String, Error> {
    // Text is laid out with the font's metrics, in SVG too.
    register_font();
    let mut text = String::new();
    figure
        .draw(SVGBackend::with_string(&mut text, SIZE).into_drawing_area())
        .map_err(|message| Error::Plot {
            path: page.to_owned(),
            message,
        })?;
    Ok(text)
}

fn quantile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let x = p * (sorted.len() - 1) as f64;
    let (lo, hi) = (x.floor() as usize, x.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (x - lo as f64)
}

/// A deterministic jitter in [-1, 1] so the points of a box do not overlap.
fn jitter(i: usize) -> f64 {
    ((i as f64 * 0.618_033_988_75).fract() * 2.0) - 1.0
}

/// Box (quartiles, whiskers to min/max, median line) plus every point, per category.
#[derive(Clone, Copy, Debug)]
pub struct Boxes<'a> {
    /// Caption.
    pub title: &'a str,
    /// One box per category, left to right.
    pub boxes: &'a [Distribution],
}

impl Figure for Boxes<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let Boxes { title, boxes } = *self;
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        root.fill(&WHITE).map_err(e)?;
        let top = boxes
            .iter()
            .flat_map(|b| b.values_mm.iter().copied())
            .fold(1.0, f64::max)
            * 1.05;
        let n = boxes.len();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5..(n as f64 - 0.5), 0.0..top)
            .map_err(e)?;
        let labels: Vec<String> = boxes.iter().map(|b| b.label.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n.max(1))
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 {
                    labels.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc("3D error norm (mm)")
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(e)?;
        for (i, b) in boxes.iter().enumerate() {
            let mut v = b.values_mm.clone();
            v.sort_by(f64::total_cmp);
            let x = i as f64;
            let (q1, med, q3) = (quantile(&v, 0.25), quantile(&v, 0.5), quantile(&v, 0.75));
            let (lo, hi) = (
                v.first().copied().unwrap_or(0.0),
                v.last().copied().unwrap_or(0.0),
            );
            let colour = Palette99::pick(i).to_rgba();
            chart
                .draw_series(v.iter().enumerate().map(|(k, y)| {
                    Circle::new((x + 0.3 * jitter(k), *y), 2, colour.mix(0.45).filled())
                }))
                .map_err(e)?;
            chart
                .draw_series([Rectangle::new(
                    [(x - 0.2, q1), (x + 0.2, q3)],
                    BLACK.stroke_width(2),
                )])
                .map_err(e)?;
            chart
                .draw_series([
                    PathElement::new(vec![(x - 0.2, med), (x + 0.2, med)], RED.stroke_width(3)),
                    PathElement::new(vec![(x, q3), (x, hi)], BLACK.stroke_width(1)),
                    PathElement::new(vec![(x, q1), (x, lo)], BLACK.stroke_width(1)),
                    PathElement::new(vec![(x - 0.08, hi), (x + 0.08, hi)], BLACK.stroke_width(1)),
                    PathElement::new(vec![(x - 0.08, lo), (x + 0.08, lo)], BLACK.stroke_width(1)),
                ])
                .map_err(e)?;
        }
        root.present().map_err(e)
    }
}

/// A named series of (x, y) points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
}

/// Points (when `lines` is false) or lines with markers, one colour per series, with a legend.
#[derive(Clone, Copy, Debug)]
pub struct Lines<'a> {
    /// Caption.
    pub title: &'a str,
    /// The x axis' label.
    pub x_desc: &'a str,
    /// The y axis' label.
    pub y_desc: &'a str,
    /// The series, one colour each.
    pub series: &'a [Series],
    /// Whether to join each series' points.
    pub lines: bool,
}

impl Figure for Lines<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let Lines {
            title,
            x_desc,
            y_desc,
            series,
            lines,
        } = *self;
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        root.fill(&WHITE).map_err(e)?;
        let all = series.iter().flat_map(|s| s.points.iter().copied());
        let (x0, x1, y1) = all.fold(
            (f64::INFINITY, f64::NEG_INFINITY, 0.0f64),
            |(a, b, c), (x, y)| (a.min(x), b.max(x), c.max(y)),
        );
        let (x0, x1) = if x0.is_finite() && x1 > x0 {
            (x0, x1)
        } else {
            (0.0, 1.0)
        };
        let y1 = if y1 > 0.0 { y1 * 1.08 } else { 1.0 };
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, 0.0..y1)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(e)?;
        for (i, s) in series.iter().enumerate() {
            let colour = Palette99::pick(i).to_rgba();
            if lines {
                chart
                    .draw_series(LineSeries::new(
                        s.points.iter().copied(),
                        colour.stroke_width(2),
                    ))
                    .map_err(e)?;
            }
            chart
                .draw_series(s.points.iter().map(|p| Circle::new(*p, 3, colour.filled())))
                .map_err(e)?
                .label(s.label.as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 15))
            .draw()
            .map_err(e)?;
        root.present().map_err(e)
    }
}

/// One box per option of the validation error after calibration, after a box
/// of the error before (taken from the first option: every option validates
/// on the same held-out measurements); on the cross-load validations when
/// `cross_load`.
pub fn validation_boxes(options: &[OptionReport], cross_load: bool) -> Vec<Distribution> {
    fn pick(o: &OptionReport, cross_load: bool) -> Option<&ValidationReport> {
        if cross_load {
            o.cross_load.as_ref()
        } else {
            o.validation.as_ref()
        }
    }
    let mm = |v: &ValidationReport, after: bool| -> Vec<f64> {
        v.per_pose
            .iter()
            .map(|p| if after { p.after_mm } else { p.before_mm })
            .collect()
    };
    let before = options
        .first()
        .and_then(|o| pick(o, cross_load))
        .map(|v| Distribution {
            label: "uncalibrated".into(),
            values_mm: mm(v, false),
        });
    let after = options.iter().filter_map(|o| {
        pick(o, cross_load).map(|v| Distribution {
            label: o.option.name().into(),
            values_mm: mm(v, true),
        })
    });
    before.into_iter().chain(after).collect()
}

/// The error of every held-out pose of `option` before and after, mm against the pose id.
pub fn per_pose_series(option: &OptionReport) -> Vec<Series> {
    let points = |after: bool| -> Vec<(f64, f64)> {
        option
            .validation
            .iter()
            .flat_map(|v| &v.per_pose)
            .map(|p| (p.pose as f64, if after { p.after_mm } else { p.before_mm }))
            .collect()
    };
    vec![
        Series {
            label: "uncalibrated".into(),
            points: points(false),
        },
        Series {
            label: "calibrated".into(),
            points: points(true),
        },
    ]
}

/// One series per option of O1 against the number of poses, the options
/// that have points in table order.
pub fn o1_series(points: &[O1Point]) -> Vec<Series> {
    ModelOption::EVERY
        .iter()
        .filter(|&&o| points.iter().any(|p| p.option == o))
        .map(|&o| Series {
            label: o.name().into(),
            points: points
                .iter()
                .filter(|p| p.option == o)
                .map(|p| (p.poses as f64, p.o1))
                .collect(),
        })
        .collect()
}

/// Two series per option of the error sweep, mean error (mm) off the grid
/// and on it against the number of poses, in the order the options come;
/// sizes without a calibration are left out.
pub fn error_series(points: &[ErrorPoint]) -> Vec<Series> {
    let mut options: Vec<ModelOption> = Vec::new();
    for p in points {
        if !options.contains(&p.option) {
            options.push(p.option);
        }
    }
    let series = |o: ModelOption, off_grid: bool| Series {
        label: format!("{o}, {}", if off_grid { "off the grid" } else { "grid" }),
        points: points
            .iter()
            .filter(|p| p.option == o)
            .filter_map(|p| {
                let e = p.errors.as_ref()?;
                let stats = if off_grid { &e.off_grid } else { &e.grid };
                Some((p.poses as f64, stats.mean_m * 1e3))
            })
            .collect(),
    };
    options
        .into_iter()
        .flat_map(|o| [series(o, true), series(o, false)])
        .collect()
}

/// The demo's positioning comparison as a box plot, `<dir>/positioning.svg` and `.png`; returns the files.
pub fn positioning(
    dir: &Path,
    rows: &[Positioning],
    payload_kg: f64,
) -> Result<Vec<PathBuf>, Error> {
    let boxes: Vec<Distribution> = rows
        .iter()
        .map(|r| Distribution {
            label: r.label.clone(),
            values_mm: r.errors_m.iter().map(|e| e * 1e3).collect(),
        })
        .collect();
    let count = rows.first().map_or(0, |r| r.errors_m.len());
    let title =
        format!("Error at the tool through the board, {count} random targets, {payload_kg} kg");
    write(
        &dir.join("positioning"),
        &Boxes {
            title: &title,
            boxes: &boxes,
        },
    )
}

/// The demo's figures in `dir` (`errors`, `errors-cross-load`, `per-pose` of
/// the elasto-kinematic option, `o1-vs-poses`, and `errors-vs-poses` when
/// the error sweep ran) from the report's `options`; returns the files written.
pub fn demo_figures(
    dir: &Path,
    options: &[OptionReport],
    o1: &[O1Point],
    errors: &[ErrorPoint],
) -> Result<Vec<PathBuf>, Error> {
    let load = options.first().map_or(0.0, |o| o.identify_load_kg);
    let mut files = Vec::new();
    let boxes = |title: &str, cross_load| -> Result<Vec<PathBuf>, Error> {
        let boxes = validation_boxes(options, cross_load);
        let stem = if cross_load {
            "errors-cross-load"
        } else {
            "errors"
        };
        write(
            &dir.join(stem),
            &Boxes {
                title,
                boxes: &boxes,
            },
        )
    };
    files.extend(boxes(
        &format!("Validation error, {load} kg, poses not used for identification"),
        false,
    )?);
    files.extend(boxes(
        &format!("Cross-load: identified with {load} kg, validated without load"),
        true,
    )?);
    if let Some(ek) = options.iter().find(|o| {
        matches!(
            o.option,
            ModelOption::PaperElastoKinematic | ModelOption::ElastoKinematic
        )
    }) {
        let title = format!("Error per validation pose ({})", ek.option);
        files.extend(write(
            &dir.join("per-pose"),
            &Lines {
                title: &title,
                x_desc: "pose id",
                y_desc: "3D error norm (mm)",
                series: &per_pose_series(ek),
                lines: false,
            },
        )?);
    }
    files.extend(write(
        &dir.join("o1-vs-poses"),
        &Lines {
            title: "O1 of DETMAX selections",
            x_desc: "number of poses",
            y_desc: "O1",
            series: &o1_series(o1),
            lines: true,
        },
    )?);
    if !errors.is_empty() {
        files.extend(write(
            &dir.join("errors-vs-poses"),
            &Lines {
                title: &format!("Mean error against the number of poses fitted, {load} kg"),
                x_desc: "number of poses (DETMAX)",
                y_desc: "mean 3D error (mm)",
                series: &error_series(errors),
                lines: true,
            },
        )?);
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_png_with_text() {
        let dir = tempfile::tempdir().unwrap();
        let boxes = vec![
            Distribution {
                label: "uncalibrated".into(),
                values_mm: vec![30.0, 25.0, 41.0, 33.0],
            },
            Distribution {
                label: "calibrated".into(),
                values_mm: vec![5.0, 4.0, 7.5, 6.0],
            },
        ];
        let figure = Boxes {
            title: "Validation error",
            boxes: &boxes,
        };
        let files = write(&dir.path().join("errors"), &figure).unwrap();
        let page = svg(&figure, Path::new("page.html")).unwrap();
        assert_eq!(std::fs::read_to_string(&files[0]).unwrap(), page);
        let svg = std::fs::read_to_string(&files[0]).unwrap();
        assert!(
            svg.contains("uncalibrated") && svg.contains("<rect"),
            "{svg}"
        );
        let png = std::fs::read(&files[1]).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let series = vec![Series {
            label: "DETMAX".into(),
            points: vec![(10.0, 0.3), (50.0, 0.7)],
        }];
        let figure = Lines {
            title: "O1",
            x_desc: "poses",
            y_desc: "O1",
            series: &series,
            lines: true,
        };
        let files = write(&dir.path().join("o1"), &figure).unwrap();
        assert!(
            std::fs::read_to_string(&files[0])
                .unwrap()
                .contains("DETMAX")
        );
    }

    #[test]
    fn o1_points_are_grouped_per_option_in_table_order() {
        let p = |option, poses, o1| O1Point { option, poses, o1 };
        let series = o1_series(&[
            p(ModelOption::ElastoKinematic, 50, 0.7),
            p(ModelOption::Kinematic, 10, 0.2),
            p(ModelOption::ElastoKinematic, 60, 0.75),
            p(ModelOption::PaperElastoKinematic, 60, 0.74),
        ]);
        let labels: Vec<&str> = series.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(
            labels,
            ["kinematic", "elasto-kinematic", "paper-elasto-kinematic"]
        );
        assert_eq!(series[0].points, [(10.0, 0.2)]);
        assert_eq!(series[1].points, [(50.0, 0.7), (60.0, 0.75)]);
        assert_eq!(series[2].points, [(60.0, 0.74)]);
    }
}
