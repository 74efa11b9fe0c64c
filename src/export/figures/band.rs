//! Curves with quantile bands against a grade axis (the sweep's and the
//! paper's Fig. 4).

use super::{ensure_fonts, plot_err, DrawResult, Format, SERIES};
use crate::error::Result;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// One curve with a band (e.g. median and 5–95 % quantiles).
#[derive(Debug, Clone)]
pub struct Curve {
    pub label: String,
    pub band_label: String,
    pub x: Vec<f64>,
    pub mid: Vec<f64>,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

/// A horizontal reference line.
#[derive(Debug, Clone)]
pub struct HLine {
    pub y: f64,
    pub label: String,
    pub dashed: bool,
    pub color: RGBColor,
}

/// A marked point.
#[derive(Debug, Clone)]
pub struct Marker {
    pub x: f64,
    pub y: f64,
    pub label: String,
}

/// One panel of a [`BandChart`].
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub curves: Vec<Curve>,
}

/// Curves with bands against a grade axis: Fig. 4 and its variants. Several
/// panels share the y axis (e.g. one per estimator).
#[derive(Debug, Clone)]
pub struct BandChart {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub panels: Vec<Panel>,
    pub hlines: Vec<HLine>,
    pub markers: Vec<Marker>,
    /// Logarithmic x axis (use when the grades span a decade or more).
    pub log_x: bool,
}

impl BandChart {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
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
        // Each panel on the range of its own values (and the reference
        // lines): an estimator an order of magnitude better than another
        // is not drawn flat along the axis of the worse one's range.
        let top = |p: &Panel| {
            let y = p
                .curves
                .iter()
                .flat_map(|c| c.hi.iter().chain(&c.mid))
                .chain(self.hlines.iter().map(|h| &h.y))
                .chain(self.markers.iter().map(|m| &m.y))
                .cloned()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max)
                * 1.12;
            if y > 0.0 {
                y
            } else {
                1.0
            }
        };
        let mut ticks: Vec<f64> = xs.clone();
        ticks.sort_by(f64::total_cmp);
        ticks.dedup();
        let n = self.panels.len().max(1) as u32;
        let width = (620 * n).max(1100);
        let rows = self
            .panels
            .iter()
            .map(|p| legend_rows(self, p, width / n))
            .max()
            .unwrap_or(0) as u32;
        let size = (width, 640 + 28 * rows + 16);
        render!(format, size, |root| {
            root.fill(&WHITE)
                .map_err(|e| e.to_string())
                .and_then(|_| {
                    root.titled(
                        &self.title,
                        (
                            "sans-serif",
                            super::title_size(root.dim_in_pixel().0, &self.title, 24),
                            FontStyle::Bold,
                        ),
                    )
                    .map_err(|e| e.to_string())
                })
                .and_then(|area| {
                    let parts = area.split_evenly((1, n as usize));
                    for (panel, part) in self.panels.iter().zip(parts.iter()) {
                        let y1 = top(panel);
                        if self.log_x {
                            let r = (x0 / 1.2)..(x1 * 1.2);
                            draw_band(
                                part,
                                self,
                                panel,
                                r.clone().log_scale(),
                                (r.start, r.end),
                                y1,
                                true,
                                &ticks,
                            )?;
                        } else {
                            let pad = (x1 - x0).max(1e-9) * 0.04;
                            let r = (x0 - pad)..(x1 + pad);
                            draw_band(
                                part,
                                self,
                                panel,
                                r.clone(),
                                (r.start, r.end),
                                y1,
                                false,
                                &ticks,
                            )?;
                        }
                    }
                    Ok(())
                })
        })
    }
}

#[allow(clippy::too_many_arguments)]
fn draw_band<DB, X>(
    root: &DrawingArea<DB, Shift>,
    spec: &BandChart,
    panel: &Panel,
    x_spec: X,
    x_range: (f64, f64),
    y1: f64,
    log_x: bool,
    ticks: &[f64],
) -> DrawResult
where
    DB: DrawingBackend,
    X: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    X::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
{
    // The legend goes below the plot, never over the data.
    let (w, h) = root.dim_in_pixel();
    let legend_h = 28 * legend_rows(spec, panel, w) as u32 + 16;
    let (plot, legend_area) = root.split_vertically(h.saturating_sub(legend_h));
    let legend_area = &legend_area;
    let root = &plot;
    let mut chart = ChartBuilder::on(root)
        .caption(&panel.title, ("sans-serif", 20, FontStyle::Bold))
        .margin(18)
        .x_label_area_size(55)
        .y_label_area_size(80)
        .build_cartesian_2d(x_spec, 0.0..y1)
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
        mesh.x_desc(&spec.x_desc)
            .y_desc(&spec.y_desc)
            .x_label_formatter(&fmt_x)
            .label_style(("sans-serif", 17))
            .axis_desc_style(("sans-serif", 19))
            .light_line_style(RGBColor(244, 244, 244))
            .bold_line_style(RGBColor(210, 210, 210));
        // Label the grades themselves, whatever the axis (a log axis labels
        // only decades, a linear one of a single grade repeats it).
        mesh.x_label_formatter(&|_| String::new()).disable_x_mesh();
        mesh.draw().map_err(|e| e.to_string())?;
    }
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    {
        chart
            .draw_series(
                ticks
                    .iter()
                    .map(|&x| PathElement::new(vec![(x, 0.0), (x, y1)], RGBColor(215, 215, 215))),
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
            let (px, py) = chart.backend_coord(&(x, 0.0));
            root.draw(&Text::new(
                fmt_x(&x),
                (px - base.0, py - base.1 + 8),
                style.clone(),
            ))
            .map_err(e)?;
        }
    }
    curves(&mut chart, panel)?;
    reference_lines(&mut chart, spec, x_range, log_x)?;
    legend(legend_area, spec, panel)?;
    Ok(())
}

/// The horizontal reference lines (dashed or solid, spanning the x range)
/// and the markers of a panel, with their legend entries.
fn reference_lines<DB, XC>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<XC, RangedCoordf64>>,
    spec: &BandChart,
    x_range: (f64, f64),
    log_x: bool,
) -> DrawResult
where
    DB: DrawingBackend,
    XC: Ranged<ValueType = f64>,
{
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
                PathElement::new(vec![(at(a), h.y), (at(b), h.y)], col.stroke_width(2))
            })
            .collect();
        chart.draw_series(segs).map_err(e)?;
    }
    for m in &spec.markers {
        let col = RGBColor(0, 0, 0);
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                (m.x, m.y),
                9,
                col.filled(),
            )))
            .map_err(e)?;
    }
    Ok(())
}

/// Each curve's band (5–95 %), then its median line and points on top.
fn curves<DB, XC>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<XC, RangedCoordf64>>,
    panel: &Panel,
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

/// How one legend entry is drawn.
enum Swatch {
    Band(RGBColor),
    Line(RGBColor),
    Dashed(RGBColor),
    Triangle,
}

/// The legend entries of a panel: each curve's band and median, the
/// reference lines, the markers.
fn legend_entries(spec: &BandChart, panel: &Panel) -> Vec<(Swatch, String)> {
    let mut out = Vec::new();
    for (i, c) in panel.curves.iter().enumerate() {
        let col = SERIES[i % SERIES.len()];
        out.push((Swatch::Line(col), c.label.clone()));
        out.push((Swatch::Band(col), c.band_label.clone()));
    }
    for h in &spec.hlines {
        let s = if h.dashed {
            Swatch::Dashed(h.color)
        } else {
            Swatch::Line(h.color)
        };
        out.push((s, h.label.clone()));
    }
    for m in &spec.markers {
        out.push((Swatch::Triangle, m.label.clone()));
    }
    out
}

/// Width in pixels of a legend label in the legend's font (the embedded
/// DejaVu Sans at 15 px; 7 px a character if the font cannot say).
fn label_width(label: &str) -> usize {
    let _ = super::ensure_fonts();
    ("sans-serif", 15)
        .into_font()
        .box_size(label)
        .map(|(w, _)| w as usize)
        .unwrap_or(7 * label.chars().count())
}

/// Legend columns of a panel `width` pixels wide: two entries a row when
/// the widest label fits half the width, else one (a label is never cut at
/// the panel's edge).
fn legend_columns(spec: &BandChart, panel: &Panel, width: u32) -> usize {
    let widest = legend_entries(spec, panel)
        .iter()
        .map(|(_, l)| label_width(l))
        .max()
        .unwrap_or(0);
    let column = (width as usize).saturating_sub(40) / 2;
    if 34 + widest <= column {
        2
    } else {
        1
    }
}

/// Rows of a panel's legend (see [`legend_columns`]).
fn legend_rows(spec: &BandChart, panel: &Panel, width: u32) -> usize {
    legend_entries(spec, panel)
        .len()
        .div_ceil(legend_columns(spec, panel, width))
}

/// The legend in its own area below the plot, two entries a row (one when
/// the labels are long).
fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    spec: &BandChart,
    panel: &Panel,
) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (w, _) = area.dim_in_pixel();
    let cols = legend_columns(spec, panel, w) as i32;
    let col_w = (w as i32 - 40) / 2;
    let font = ("sans-serif", 15).into_font().color(&BLACK);
    for (k, (swatch, label)) in legend_entries(spec, panel).iter().enumerate() {
        let x = 30 + (k as i32 % cols) * col_w;
        let y = 10 + (k as i32 / cols) * 28 + 8;
        match swatch {
            Swatch::Band(c) => area
                .draw(&Rectangle::new(
                    [(x, y - 6), (x + 24, y + 6)],
                    c.mix(0.3).filled(),
                ))
                .map_err(e)?,
            Swatch::Line(c) => area
                .draw(&PathElement::new(
                    vec![(x, y), (x + 24, y)],
                    c.stroke_width(3),
                ))
                .map_err(e)?,
            Swatch::Dashed(c) => {
                for s in [0, 10, 20] {
                    area.draw(&PathElement::new(
                        vec![(x + s, y), (x + s + 5, y)],
                        c.stroke_width(2),
                    ))
                    .map_err(e)?;
                }
            }
            Swatch::Triangle => area
                .draw(&TriangleMarker::new((x + 12, y), 7, BLACK.filled()))
                .map_err(e)?,
        }
        area.draw(&Text::new(label.as_str(), (x + 34, y - 8), font.clone()))
            .map_err(e)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(band_label: &str) -> (BandChart, Panel) {
        let curve = Curve {
            label: "median".into(),
            band_label: band_label.into(),
            x: vec![1.0],
            mid: vec![1.0],
            lo: vec![1.0],
            hi: vec![1.0],
        };
        let panel = Panel {
            title: String::new(),
            curves: vec![curve.clone(), curve.clone(), curve],
        };
        let spec = BandChart {
            title: String::new(),
            x_desc: String::new(),
            y_desc: String::new(),
            panels: vec![panel.clone()],
            hlines: Vec::new(),
            markers: Vec::new(),
            log_x: false,
        };
        (spec, panel)
    }

    /// A title keeps its size when it fits and shrinks until it does.
    #[test]
    fn titles_shrink_to_fit_the_figure() {
        use crate::export::figures::title_size;
        assert_eq!(title_size(1240, "Fig. 4", 24), 24);
        let long = "μ/μ0 after self-calibration against encoder grade (20000 trials, random errors ±0.5 mm) — 51 poses, products at their grades";
        let s = title_size(1240, long, 24);
        assert!((12..24).contains(&s), "{s}");
        let w = |size: u32| {
            ("sans-serif", size as f64, FontStyle::Bold)
                .into_font()
                .box_size(long)
                .unwrap()
                .0
        };
        assert!(w(s) + 24 <= 1240 && w(s + 1) + 24 > 1240);
        assert_eq!(title_size(100, long, 24), 12);
    }

    /// Labels that fit half a panel share a row; longer ones get a row each
    /// (a two-panel figure is 620 px a panel: 290 px a column).
    #[test]
    fn long_legend_labels_take_a_row_each() {
        let (spec, panel) = chart("5–95 %");
        assert_eq!(legend_columns(&spec, &panel, 620), 2);
        assert_eq!(legend_rows(&spec, &panel, 620), 3);
        let (spec, panel) = chart("median to 95 % of machines, scale 0.5 µm");
        assert_eq!(legend_columns(&spec, &panel, 620), 1);
        assert_eq!(legend_rows(&spec, &panel, 620), 6);
        // The boundary: a label as wide as a column less its swatch.
        let fits = (1..200)
            .take_while(|&n| label_width(&"x".repeat(n)) + 34 <= 290)
            .last()
            .unwrap();
        let (spec, panel) = chart(&"x".repeat(fits));
        assert_eq!(legend_columns(&spec, &panel, 620), 2);
        let (spec, panel) = chart(&"x".repeat(fits + 1));
        assert_eq!(legend_columns(&spec, &panel, 620), 1);
        // The font is measured, not guessed: 40 x are wider than 40 i.
        assert!(label_width(&"x".repeat(40)) > label_width(&"i".repeat(40)));
    }
}
