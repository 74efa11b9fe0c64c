//! Curves with quantile bands against a grade axis (the sweep's and the
//! paper's Fig. 4).

use super::band_legend::{legend, legend_rows};
pub use super::band_spec::{BandChart, BandStyle, Curve, HLine, Marker, Panel};
use super::frame::{mesh_look, titled_page};
use super::{ensure_fonts, plot_err, DrawResult, Format, SERIES};
use crate::error::Result;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// A [`BandChart`] with its [`BandStyle`].
#[derive(Debug, Clone)]
pub struct StyledBand {
    pub chart: BandChart,
    pub style: BandStyle,
}

impl StyledBand {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        self.chart.render_styled(format, &self.style)
    }
}

/// The axes of one panel: the x range (log or linear) and the y range as
/// drawn (log10 of the values on a log axis), with the round values that
/// label a log y axis.
struct Axes<'a> {
    x_range: (f64, f64),
    log_x: bool,
    y: (f64, f64),
    y_ticks: Option<Vec<f64>>,
    ticks: &'a [f64],
    style: &'a BandStyle,
}

impl BandChart {
    /// The chart with the default [`BandStyle`].
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        self.render_styled(format, &BandStyle::default())
    }

    /// The chart drawn in `style`.
    pub fn render_styled(&self, format: Format, style: &BandStyle) -> Result<Vec<u8>> {
        let curves = || self.panels.iter().flat_map(|p| p.curves.iter());
        let xs: Vec<f64> = curves()
            .flat_map(|c| c.x.iter().cloned())
            .chain(self.markers.iter().map(|m| m.x))
            .collect();
        let (mut x0, mut x1) = xs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        if !x0.is_finite() {
            (x0, x1) = (0.5, 8.0);
        }
        let y_range = |p: &Panel| self.y_range(p, style);
        let mut ticks: Vec<f64> = xs.clone();
        ticks.sort_by(f64::total_cmp);
        ticks.dedup();
        let n = self.panels.len().max(1) as u32;
        let width = (620 * n).max(1100);
        let rows = self
            .panels
            .iter()
            .map(|p| legend_rows(self, p, width / n, style))
            .max()
            .unwrap_or(0) as u32;
        let size = (width, 640 + 28 * rows + 16);
        render!(format, size, |root| {
            titled_page(&root, &self.title, 24).and_then(|area| {
                let parts = area.split_evenly((1, n as usize));
                for (panel, part) in self.panels.iter().zip(parts.iter()) {
                    let (y, y_ticks) = y_range(panel);
                    let drawn = if style.log_y {
                        log10_panel(panel, 10f64.powf(y.0))
                    } else {
                        panel.clone()
                    };
                    let pad = (x1 - x0).max(1e-9) * 0.04;
                    let r = match self.log_x {
                        true => (x0 / 1.2)..(x1 * 1.2),
                        false => (x0 - pad)..(x1 + pad),
                    };
                    let axes = Axes {
                        x_range: (r.start, r.end),
                        log_x: self.log_x,
                        y,
                        y_ticks,
                        ticks: &ticks,
                        style,
                    };
                    match self.log_x {
                        true => draw_band(part, self, &drawn, r.log_scale(), &axes)?,
                        false => draw_band(part, self, &drawn, r, &axes)?,
                    }
                }
                Ok(())
            })
        })
    }

    /// A panel's y range as drawn, on the range of its own values and the
    /// reference lines (an estimator an order of magnitude better than
    /// another is not drawn flat along the axis of the worse one's range):
    /// from 0 on a linear axis; on a log axis log10 of the smallest and
    /// largest positive values with a margin, and the round values to label.
    fn y_range(&self, p: &Panel, style: &BandStyle) -> ((f64, f64), Option<Vec<f64>>) {
        let values = || {
            p.curves
                .iter()
                .flat_map(|c| c.hi.iter().chain(&c.mid))
                .chain(self.hlines.iter().map(|h| &h.y))
                .chain(self.markers.iter().map(|m| &m.y))
                .cloned()
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        let top = values().fold(0.0, f64::max);
        if style.log_y {
            let low = p
                .curves
                .iter()
                .flat_map(|c| c.lo.iter().chain(&c.mid))
                .cloned()
                .filter(|v| v.is_finite() && *v > 0.0)
                .chain(values())
                .fold(f64::INFINITY, f64::min);
            let scale = super::ColourScale::log(low / 1.25, top * 1.25);
            let (a, b) = scale.range();
            return ((a.log10(), b.log10()), Some(scale.ticks()));
        }
        let y1 = top * 1.12;
        ((0.0, if y1 > 0.0 { y1 } else { 1.0 }), None)
    }
}

/// A panel with every y value replaced by its log10 (values below `floor`
/// at the floor), to draw on a linear axis labelled in the values.
fn log10_panel(panel: &Panel, floor: f64) -> Panel {
    let f = |v: &Vec<f64>| -> Vec<f64> {
        v.iter()
            .map(|y| {
                if y.is_finite() {
                    y.max(floor).log10()
                } else {
                    *y
                }
            })
            .collect()
    };
    Panel {
        title: panel.title.clone(),
        curves: panel
            .curves
            .iter()
            .map(|c| Curve {
                mid: f(&c.mid),
                lo: f(&c.lo),
                hi: f(&c.hi),
                ..c.clone()
            })
            .collect(),
    }
}

/// The y at which `v` is drawn on `axes` (log10 on a log axis).
fn y_at(axes: &Axes, v: f64) -> f64 {
    if axes.y_ticks.is_some() {
        v.max(10f64.powf(axes.y.0)).log10()
    } else {
        v
    }
}

fn draw_band<DB, X>(
    root: &DrawingArea<DB, Shift>,
    spec: &BandChart,
    panel: &Panel,
    x_spec: X,
    axes: &Axes,
) -> DrawResult
where
    DB: DrawingBackend,
    X: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    X::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
{
    let (y0, y1) = axes.y;
    let ticks = axes.ticks;
    // The legend goes below the plot, never over the data.
    let (w, h) = root.dim_in_pixel();
    let legend_h = 28 * legend_rows(spec, panel, w, axes.style) as u32 + 16;
    let (plot, legend_area) = root.split_vertically(h.saturating_sub(legend_h));
    let legend_area = &legend_area;
    let root = &plot;
    let mut chart = ChartBuilder::on(root)
        .caption(&panel.title, ("sans-serif", 20, FontStyle::Bold))
        .margin(18)
        .x_label_area_size(55)
        .y_label_area_size(80)
        .build_cartesian_2d(x_spec, y0..y1)
        .map_err(|e| e.to_string())?;
    let fmt_x = |v: &f64| {
        if (v - v.round()).abs() < 1e-9 {
            format!("{v:.0}")
        } else {
            format!("{v}")
        }
    };
    {
        let mut mesh = chart.configure_mesh();
        mesh_look(&mut mesh, 17, 244)
            .x_desc(&spec.x_desc)
            .y_desc(&spec.y_desc)
            .x_label_formatter(&fmt_x)
            .bold_line_style(RGBColor(210, 210, 210));
        // Label the grades themselves, whatever the axis (a log axis labels
        // only decades, a linear one of a single grade repeats it).
        mesh.x_label_formatter(&|_| String::new()).disable_x_mesh();
        if axes.y_ticks.is_some() {
            // A log axis is labelled at round values below, not at the
            // mesh's evenly spaced exponents.
            mesh.y_label_formatter(&|_| String::new()).disable_y_mesh();
        }
        mesh.draw().map_err(|e| e.to_string())?;
    }
    if let Some(values) = &axes.y_ticks {
        log_y_labels(root, &mut chart, values, axes.x_range)?;
    }
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    {
        chart
            .draw_series(
                ticks
                    .iter()
                    .map(|&x| PathElement::new(vec![(x, y0), (x, y1)], RGBColor(215, 215, 215))),
            )
            .map_err(e)?;
        let base = root.get_base_pixel();
        let style = ("sans-serif", 17).into_font().color(&BLACK).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Top,
            ),
        );
        for &x in ticks {
            let (px, py) = chart.backend_coord(&(x, y0));
            root.draw(&Text::new(
                fmt_x(&x),
                (px - base.0, py - base.1 + 8),
                style.clone(),
            ))
            .map_err(e)?;
        }
    }
    curves(&mut chart, panel, axes.style.band_edges)?;
    reference_lines(&mut chart, spec, panel, axes)?;
    legend(legend_area, spec, panel, axes.style)?;
    Ok(())
}

/// Grid lines and labels of a log y axis at `values` (drawn at their
/// log10), the labels left of the axis.
fn log_y_labels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &mut ChartContext<'_, DB, Cartesian2d<impl Ranged<ValueType = f64>, RangedCoordf64>>,
    values: &[f64],
    x_range: (f64, f64),
) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    chart
        .draw_series(values.iter().map(|v| {
            PathElement::new(
                vec![(x_range.0, v.log10()), (x_range.1, v.log10())],
                RGBColor(225, 225, 225),
            )
        }))
        .map_err(e)?;
    let base = root.get_base_pixel();
    let style =
        ("sans-serif", 17)
            .into_font()
            .color(&BLACK)
            .pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Right,
                plotters::style::text_anchor::VPos::Center,
            ));
    for v in values {
        let (px, py) = chart.backend_coord(&(x_range.0, v.log10()));
        root.draw(&Text::new(
            super::tick_label(*v, values),
            (px - base.0 - 8, py - base.1),
            style.clone(),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// The horizontal reference lines (dashed or solid, spanning the x range)
/// and the markers of a panel, with their legend entries.
fn reference_lines<DB, XC>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<XC, RangedCoordf64>>,
    spec: &BandChart,
    panel: &Panel,
    axes: &Axes,
) -> DrawResult
where
    DB: DrawingBackend,
    XC: Ranged<ValueType = f64>,
{
    let (x_range, log_x) = (axes.x_range, axes.log_x);
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    for h in &spec.hlines {
        let col = h.color;
        let n = if h.dashed { 60 } else { 1 };
        let at = |t: f64| {
            if log_x {
                (x_range.0.ln() + t * (x_range.1.ln() - x_range.0.ln())).exp()
            } else {
                x_range.0 + t * (x_range.1 - x_range.0)
            }
        };
        let segs: Vec<PathElement<(f64, f64)>> = (0..n)
            .map(|k| {
                let (a, b) = if h.dashed {
                    (k as f64 / n as f64, (k as f64 + 0.6) / n as f64)
                } else {
                    (0.0, 1.0)
                };
                let y = y_at(axes, h.y);
                PathElement::new(vec![(at(a), y), (at(b), y)], col.stroke_width(2))
            })
            .collect();
        chart.draw_series(segs).map_err(e)?;
    }
    tags(chart, panel, axes)?;
    for m in &spec.markers {
        let col = RGBColor(0, 0, 0);
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                (m.x, y_at(axes, m.y)),
                9,
                col.filled(),
            )))
            .map_err(e)?;
    }
    Ok(())
}

/// The style's tags: each text at an end of its line, above or below it,
/// wherever no curve (median or band top) passes under the text; right
/// above first.
fn tags<DB, XC>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<XC, RangedCoordf64>>,
    panel: &Panel,
    axes: &Axes,
) -> DrawResult
where
    DB: DrawingBackend,
    XC: Ranged<ValueType = f64>,
{
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let x_range = axes.x_range;
    let at = |f: f64| {
        if axes.log_x {
            (x_range.0.ln() + f * (x_range.1.ln() - x_range.0.ln())).exp()
        } else {
            x_range.0 + f * (x_range.1 - x_range.0)
        }
    };
    // Every curve as pixel polylines.
    let lines: Vec<Vec<(i32, i32)>> = panel
        .curves
        .iter()
        .flat_map(|c| [&c.mid, &c.hi].map(|ys| (&c.x, ys)))
        .map(|(xs, ys)| {
            xs.iter()
                .zip(ys)
                .filter(|(_, y)| y.is_finite())
                .map(|(x, y)| chart.backend_coord(&(*x, *y)))
                .collect()
        })
        .collect();
    let font = ("sans-serif", 16, FontStyle::Bold)
        .into_font()
        .color(&RGBColor(180, 20, 20));
    for (y, text) in &axes.style.tags {
        let y = y_at(axes, *y);
        let width = font.font.box_size(text).map_or(140, |(w, _)| w as i32);
        let candidates = [(true, true), (true, false), (false, true), (false, false)];
        let clear = |&(right, above): &(bool, bool)| {
            let (px, py) = chart.backend_coord(&(at(if right { 0.985 } else { 0.015 }), y));
            let xs = if right {
                (px - width, px)
            } else {
                (px, px + width)
            };
            let ys = if above { (py - 22, py) } else { (py, py + 22) };
            !lines.iter().any(|l| crosses(l, xs, ys))
        };
        let (right, above) = candidates.into_iter().find(clear).unwrap_or((true, true));
        let pos = Pos::new(
            if right { HPos::Right } else { HPos::Left },
            if above { VPos::Bottom } else { VPos::Top },
        );
        chart
            .draw_series(std::iter::once(Text::new(
                text.clone(),
                (at(if right { 0.985 } else { 0.015 }), y),
                font.clone().pos(pos),
            )))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Does the pixel polyline pass through the box `xs` × `ys`? (Each segment
/// is sampled every few pixels across the box's columns.)
fn crosses(line: &[(i32, i32)], xs: (i32, i32), ys: (i32, i32)) -> bool {
    line.windows(2).any(|w| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        let (a, b) = (x0.max(xs.0), x1.min(xs.1));
        (a..=b).step_by(3).chain([b]).any(|x| {
            let f = if x1 == x0 {
                0.0
            } else {
                (x - x0) as f64 / (x1 - x0) as f64
            };
            let y = y0 as f64 + f * (y1 - y0) as f64;
            a <= b && y >= ys.0 as f64 && y <= ys.1 as f64
        })
    })
}

/// Each curve's band (5–95 %), then its median line and points on top.
/// With `edges`, a band is its upper edge, dashed, instead of an area.
fn curves<DB, XC>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<XC, RangedCoordf64>>,
    panel: &Panel,
    edges: bool,
) -> DrawResult
where
    DB: DrawingBackend,
    XC: Ranged<ValueType = f64>,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    // Bands first, so lines draw on top.
    for (i, c) in panel.curves.iter().enumerate() {
        let col = SERIES[i % SERIES.len()];
        let poly: Vec<(f64, f64)> =
            c.x.iter()
                .zip(&c.hi)
                .map(|(x, y)| (*x, *y))
                .chain(c.x.iter().zip(&c.lo).rev().map(|(x, y)| (*x, *y)))
                .collect();
        if c.x.len() == 1 {
            // One grade: the band is a whisker from 5 % to 95 %.
            let (x, lo, hi) = (c.x[0], c.lo[0], c.hi[0]);
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(x, lo), (x, hi)],
                    col.mix(0.6).stroke_width(6),
                )))
                .map_err(e)?;
        } else if edges {
            chart
                .draw_series(DashedLineSeries::new(
                    c.x.iter().cloned().zip(c.hi.iter().cloned()),
                    8,
                    5,
                    col.stroke_width(2),
                ))
                .map_err(e)?;
        } else {
            chart
                .draw_series(std::iter::once(Polygon::new(poly, col.mix(0.18).filled())))
                .map_err(e)?;
        }
    }
    for (i, c) in panel.curves.iter().enumerate() {
        let col = SERIES[i % SERIES.len()];
        chart
            .draw_series(LineSeries::new(
                c.x.iter().cloned().zip(c.mid.iter().cloned()),
                col.stroke_width(3),
            ))
            .map_err(e)?;
        chart
            .draw_series(
                c.x.iter()
                    .zip(&c.mid)
                    .map(|(x, y)| Circle::new((*x, *y), 4, col.filled())),
            )
            .map_err(e)?;
    }
    Ok(())
}

#[cfg(test)]
#[path = "band_tests.rs"]
mod tests;
