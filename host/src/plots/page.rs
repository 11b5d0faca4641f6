//! The report page's own figures, drawn from plain numbers like the others
//! of `crate::plots`: the error of every measurement on a log scale
//! ([`PerPose`]: the fitted ones before and after and left out, the held-out
//! ones before and after), the measured points in two views of the
//! workspace coloured by their error ([`Workspace`]), and a servo curve with
//! its uncertainty band and its knots ([`ServoCurve`]).

use plotters::coord::Shift;
use plotters::prelude::*;

use super::Figure;

/// How a series' points are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// A filled circle (fitted measurements).
    Circle,
    /// A triangle (measurements held out of the fit).
    Triangle,
}

/// A series of (x, y) points with its marker and colour.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkedSeries {
    /// Legend label.
    pub label: String,
    /// Points; those with `y` not above 0 cannot be drawn on a log scale and are left out.
    pub points: Vec<(f64, f64)>,
    /// How each point is drawn.
    pub marker: Marker,
    /// Colour, RGB.
    pub colour: (u8, u8, u8),
}

/// Points on a logarithmic `y` axis, one series per kind of error: errors
/// of 50 mm and 0.5 mm are both read on one figure.
#[derive(Clone, Copy, Debug)]
pub struct PerPose<'a> {
    /// Caption.
    pub title: &'a str,
    /// The x axis' label.
    pub x_desc: &'a str,
    /// The y axis' label.
    pub y_desc: &'a str,
    /// The series.
    pub series: &'a [MarkedSeries],
}

/// Draws one point of `marker`'s shape.
fn point<DB: DrawingBackend, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    marker: Marker,
    at: (X::ValueType, Y::ValueType),
    style: ShapeStyle,
) -> Result<(), String>
where
    X: Ranged,
    Y: Ranged,
    X::ValueType: Clone + 'static,
    Y::ValueType: Clone + 'static,
{
    let drawn = match marker {
        Marker::Circle => chart.draw_series([Circle::new(at, 3, style)]).map(|_| ()),
        Marker::Triangle => chart
            .draw_series([TriangleMarker::new(at, 5, style)])
            .map(|_| ()),
    };
    drawn.map_err(|e| e.to_string())
}

impl Figure for PerPose<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        root.fill(&WHITE).map_err(e)?;
        let drawable = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite() && y > 0.0;
        let all: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(drawable)
            .collect();
        let (x0, x1) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
        let (y0, y1) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        let (x0, x1) = if x1 > x0 {
            let pad = 0.02 * (x1 - x0);
            (x0 - pad, x1 + pad)
        } else if x0.is_finite() {
            (x0 - 1.0, x0 + 1.0)
        } else {
            (0.0, 1.0)
        };
        // Room above the points for the legend.
        let (y0, y1) = if y0.is_finite() {
            (y0 / 1.5, y1 * 1.5 * (y1 / y0).max(10.0).powf(0.45))
        } else {
            (0.1, 10.0)
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(self.title, ("sans-serif", 24))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(self.x_desc)
            .y_desc(self.y_desc)
            .y_label_formatter(&|y| format!("{y}"))
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(e)?;
        for s in self.series {
            let (r, g, b) = s.colour;
            let style = RGBColor(r, g, b).mix(0.8).filled();
            let marker = s.marker;
            let points: Vec<(f64, f64)> = s.points.iter().copied().filter(drawable).collect();
            let drawn = match marker {
                Marker::Circle => {
                    chart.draw_series(points.iter().map(|p| Circle::new(*p, 3, style)))
                }
                Marker::Triangle => {
                    chart.draw_series(points.iter().map(|p| TriangleMarker::new(*p, 5, style)))
                }
            }
            .map_err(e)?;
            drawn.label(s.label.as_str()).legend(move |(x, y)| {
                EmptyElement::at((x + 10, y))
                    + match marker {
                        Marker::Circle => Circle::new((0, 0), 4, style).into_dyn(),
                        Marker::Triangle => TriangleMarker::new((0, 0), 5, style).into_dyn(),
                    }
            });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 15))
            .draw()
            .map_err(e)?;
        root.present().map_err(e)
    }
}

/// The colour of `t` in [0, 1] on a perceptually even map from dark blue
/// (small) through green to yellow (large), the viridis map's stops.
pub fn colour_of(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// One point of a workspace view: its two coordinates (mm), the value that
/// colours it, and how it is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValuedPoint {
    /// Horizontal coordinate, mm.
    pub a: f64,
    /// Vertical coordinate, mm.
    pub b: f64,
    /// The value its colour shows (an error, mm).
    pub value: f64,
    /// Its shape.
    pub marker: Marker,
}

/// One panel of a [`Workspace`] figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// The panel's heading.
    pub title: String,
    /// The points.
    pub points: Vec<ValuedPoint>,
}

/// Measured points in one view of the workspace, side by side panels (the
/// error before and after, say), each with its own colour scale, same axes
/// and one length per pixel both ways.
#[derive(Clone, Copy, Debug)]
pub struct Workspace<'a> {
    /// Caption.
    pub title: &'a str,
    /// The horizontal axis' label.
    pub a_desc: &'a str,
    /// The vertical axis' label.
    pub b_desc: &'a str,
    /// What the colour shows, for the colour bar.
    pub value_desc: &'a str,
    /// The panels, left to right.
    pub panels: &'a [Panel],
}

/// Width of a panel's colour bar with its labels, pixels.
const BAR_PX: u32 = 90;

impl Figure for Workspace<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        root.fill(&WHITE).map_err(e)?;
        let root = root.titled(self.title, ("sans-serif", 24)).map_err(e)?;
        let finite = |p: &&ValuedPoint| p.a.is_finite() && p.b.is_finite();
        let all: Vec<&ValuedPoint> = self
            .panels
            .iter()
            .flat_map(|p| &p.points)
            .filter(finite)
            .collect();
        let span = |f: fn(&ValuedPoint) -> f64| {
            let (lo, hi) = all
                .iter()
                .map(|p| f(p))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
            if lo.is_finite() {
                (lo, hi)
            } else {
                (-1.0, 1.0)
            }
        };
        let (a0, a1) = span(|p| p.a);
        let (b0, b1) = span(|p| p.b);
        let panels = root.split_evenly((1, self.panels.len().max(1)));
        for (area, panel) in panels.iter().zip(self.panels) {
            let (w, h) = area.dim_in_pixel();
            let (plot, bar) = area.split_horizontally(w.saturating_sub(BAR_PX));
            // The plotting area's size, less labels and margins, sets the
            // ranges so that a millimetre is as long both ways.
            let (pw, ph) = (
                (w.saturating_sub(BAR_PX + 70)).max(1) as f64,
                (h.saturating_sub(100)).max(1) as f64,
            );
            let pad = 0.06 * (a1 - a0).max(b1 - b0).max(1.0);
            let (mut ra, mut rb) = ((a0 - pad, a1 + pad), (b0 - pad, b1 + pad));
            let per_px = ((ra.1 - ra.0) / pw).max((rb.1 - rb.0) / ph);
            let widen = |(lo, hi): (f64, f64), px: f64| {
                let extra = 0.5 * (per_px * px - (hi - lo));
                (lo - extra, hi + extra)
            };
            ra = widen(ra, pw);
            rb = widen(rb, ph);
            let mut chart = ChartBuilder::on(&plot)
                .caption(&panel.title, ("sans-serif", 18))
                .margin(8)
                .x_label_area_size(36)
                .y_label_area_size(56)
                .build_cartesian_2d(ra.0..ra.1, rb.0..rb.1)
                .map_err(e)?;
            chart
                .configure_mesh()
                .x_desc(self.a_desc)
                .y_desc(self.b_desc)
                .x_labels(6)
                .y_labels(6)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(e)?;
            let values: Vec<f64> = panel
                .points
                .iter()
                .map(|p| p.value)
                .filter(|v| v.is_finite())
                .collect();
            let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let (lo, hi) = if lo.is_finite() && hi > lo {
                (lo, hi)
            } else if lo.is_finite() {
                (lo - 0.5, lo + 0.5)
            } else {
                (0.0, 1.0)
            };
            // The largest drawn last, on top of the others.
            let mut points: Vec<&ValuedPoint> = panel.points.iter().filter(finite).collect();
            points.sort_by(|x, y| x.value.total_cmp(&y.value));
            for p in points {
                let colour = colour_of((p.value - lo) / (hi - lo));
                point(
                    &mut chart,
                    p.marker,
                    (p.a, p.b),
                    colour.filled().stroke_width(1),
                )?;
            }
            colour_bar(&bar, lo, hi, self.value_desc)?;
        }
        root.present().map_err(e)
    }
}

/// A vertical colour bar from `lo` to `hi` with its labels, in `area`.
fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    lo: f64,
    hi: f64,
    desc: &str,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    let mut chart = ChartBuilder::on(area)
        .margin_top(40)
        .margin_bottom(44)
        .margin_right(8)
        .y_label_area_size(0)
        .right_y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(e)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_desc(desc)
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(e)?;
    const STEPS: usize = 40;
    let step = (hi - lo) / STEPS as f64;
    chart
        .draw_series((0..STEPS).map(|k| {
            let y = lo + step * k as f64;
            Rectangle::new(
                [(0.0, y), (0.45, y + step)],
                colour_of((k as f64 + 0.5) / STEPS as f64).filled(),
            )
        }))
        .map_err(e)?;
    Ok(())
}

/// One joint's servo curve: the offset against the commanded angle with a
/// band of ± one standard deviation, and the knots (filled when fitted,
/// with their ± one standard deviation; open when held).
#[derive(Clone, Copy, Debug)]
pub struct ServoCurve<'a> {
    /// Caption.
    pub title: &'a str,
    /// (commanded °, offset °, standard deviation °) along the curve.
    pub curve: &'a [(f64, f64, f64)],
    /// (commanded °, offset °, standard deviation ° if fitted) at each knot.
    pub knots: &'a [(f64, f64, Option<f64>)],
}

impl Figure for ServoCurve<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
        root.fill(&WHITE).map_err(e)?;
        let sd = |s: f64| if s.is_finite() { s } else { 0.0 };
        let ys = self
            .curve
            .iter()
            .flat_map(|&(_, y, s)| [y - sd(s), y + sd(s)])
            .chain(
                self.knots
                    .iter()
                    .flat_map(|&(_, y, s)| [y - sd(s.unwrap_or(0.0)), y + sd(s.unwrap_or(0.0))]),
            )
            .chain([0.0])
            .filter(|v| v.is_finite());
        let (y0, y1) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        let pad = 0.1 * (y1 - y0).max(0.05);
        let xs = self
            .curve
            .iter()
            .map(|p| p.0)
            .chain(self.knots.iter().map(|k| k.0))
            .filter(|v| v.is_finite());
        let (x0, x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        let (x0, x1) = if x1 > x0 {
            (x0 - 3.0, x1 + 3.0)
        } else {
            (-100.0, 100.0)
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(self.title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            // Room above the curve for the legend.
            .build_cartesian_2d(
                x0..x1,
                (y0 - pad)..(y1 + pad + 0.45 * (y1 - y0 + 2.0 * pad)),
            )
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("angle commanded (°)")
            .y_desc("reached − commanded (°)")
            .y_label_formatter(&|y| {
                // No "-0.00" on the zero line.
                let text = format!("{y:.2}");
                if text == "-0.00" { "0.00".into() } else { text }
            })
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(e)?;
        let band_colour = RGBColor(31, 119, 180);
        let mut band: Vec<(f64, f64)> =
            self.curve.iter().map(|&(x, y, s)| (x, y + sd(s))).collect();
        band.extend(self.curve.iter().rev().map(|&(x, y, s)| (x, y - sd(s))));
        chart
            .draw_series([Polygon::new(band, band_colour.mix(0.25).filled())])
            .map_err(e)?
            .label("± one standard deviation")
            .legend(move |(x, y)| {
                Rectangle::new(
                    [(x + 2, y - 5), (x + 18, y + 5)],
                    band_colour.mix(0.25).filled(),
                )
            });
        chart
            .draw_series([PathElement::new(
                vec![(x0, 0.0), (x1, 0.0)],
                BLACK.mix(0.4).stroke_width(1),
            )])
            .map_err(e)?;
        chart
            .draw_series(LineSeries::new(
                self.curve.iter().map(|&(x, y, _)| (x, y)),
                band_colour.stroke_width(2),
            ))
            .map_err(e)?
            .label("the calibrated curve")
            .legend(move |(x, y)| {
                PathElement::new(vec![(x + 2, y), (x + 18, y)], band_colour.stroke_width(2))
            });
        let knot_colour = RGBColor(214, 39, 40);
        for &(x, y, s) in self.knots {
            if let Some(s) = s.filter(|s| s.is_finite()) {
                chart
                    .draw_series([PathElement::new(
                        vec![(x, y - s), (x, y + s)],
                        knot_colour.stroke_width(2),
                    )])
                    .map_err(e)?;
            }
        }
        chart
            .draw_series(
                self.knots
                    .iter()
                    .filter(|k| k.2.is_some())
                    .map(|&(x, y, _)| Circle::new((x, y), 5, knot_colour.filled())),
            )
            .map_err(e)?
            .label("knot, fitted (± one standard deviation)")
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, knot_colour.filled()));
        chart
            .draw_series(
                self.knots
                    .iter()
                    .filter(|k| k.2.is_none())
                    .map(|&(x, y, _)| Circle::new((x, y), 5, knot_colour.stroke_width(2))),
            )
            .map_err(e)?
            .label("knot, held (its offset is the joint's θ)")
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, knot_colour.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(e)?;
        root.present().map_err(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn the_colour_map_runs_from_dark_to_light() {
        assert_eq!(colour_of(0.0), RGBColor(68, 1, 84));
        assert_eq!(colour_of(1.0), RGBColor(253, 231, 37));
        assert_eq!(colour_of(f64::NAN), colour_of(0.0));
        assert_eq!(colour_of(2.0), colour_of(1.0));
    }

    /// Each figure draws every point it is given (a log scale leaves out
    /// only what it cannot show), and draws without a point at all.
    #[test]
    fn every_point_is_drawn() {
        let page = Path::new("page.html");
        let series = [
            MarkedSeries {
                label: "a".into(),
                points: vec![(1.0, 30.0), (2.0, 0.5), (3.0, 0.0)],
                marker: Marker::Circle,
                colour: (1, 2, 3),
            },
            MarkedSeries {
                label: "b".into(),
                points: vec![(4.0, 2.0)],
                marker: Marker::Triangle,
                colour: (4, 5, 6),
            },
        ];
        let svg = crate::plots::svg(
            &PerPose {
                title: "t",
                x_desc: "x",
                y_desc: "y",
                series: &series,
            },
            page,
        )
        .unwrap();
        // Two circles and a triangle, and one of each in the legend.
        assert_eq!(svg.matches("<circle").count(), 3, "{svg}");
        assert_eq!(svg.matches("<polygon").count(), 2, "{svg}");
        let panel = |v: f64| Panel {
            title: "p".into(),
            points: vec![
                ValuedPoint {
                    a: 0.0,
                    b: 0.0,
                    value: v,
                    marker: Marker::Circle,
                },
                ValuedPoint {
                    a: 100.0,
                    b: 50.0,
                    value: 2.0 * v,
                    marker: Marker::Triangle,
                },
            ],
        };
        let svg = crate::plots::svg(
            &Workspace {
                title: "w",
                a_desc: "x (mm)",
                b_desc: "y (mm)",
                value_desc: "mm",
                panels: &[panel(1.0), panel(30.0)],
            },
            page,
        )
        .unwrap();
        assert_eq!(svg.matches("<circle").count(), 2, "{svg}");
        assert_eq!(svg.matches("<polygon").count(), 2, "{svg}");
        let svg = crate::plots::svg(
            &ServoCurve {
                title: "j",
                curve: &[(-100.0, 0.1, 0.02), (0.0, 0.0, 0.0), (100.0, -0.2, 0.05)],
                knots: &[(-100.0, 0.1, Some(0.02)), (0.0, 0.0, None)],
            },
            page,
        )
        .unwrap();
        assert!(
            svg.contains("<polygon") && svg.matches("<circle").count() >= 2,
            "{svg}"
        );
        for empty in [
            crate::plots::svg(
                &PerPose {
                    title: "t",
                    x_desc: "x",
                    y_desc: "y",
                    series: &[],
                },
                page,
            ),
            crate::plots::svg(
                &Workspace {
                    title: "w",
                    a_desc: "a",
                    b_desc: "b",
                    value_desc: "mm",
                    panels: &[],
                },
                page,
            ),
        ] {
            assert!(empty.unwrap().contains("<svg"));
        }
    }
}
