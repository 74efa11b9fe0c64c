//! Figures: one function per figure, each returning the encoded bytes (PNG
//! or SVG) so the caller can write them atomically. Text uses the embedded
//! DejaVu Sans font (no system fonts needed; licence in `LICENSE-DejaVu`).

use crate::compensate::VolumetricMap;
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Image format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

fn ensure_fonts() -> Result<()> {
    static ONCE: std::sync::OnceLock<std::result::Result<(), String>> = std::sync::OnceLock::new();
    ONCE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .map_err(|_| "the embedded font is invalid".to_string())?;
        plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold())
            .map_err(|_| "the embedded font is invalid".to_string())
    })
    .clone()
    .map_err(Error::Internal)
}

fn plot_err<E: std::fmt::Display>(e: E) -> Error {
    Error::Internal(format!("drawing a figure failed: {e}"))
}

type DrawResult = std::result::Result<(), String>;

/// Render `$draw(&root)` (a call generic over the backend) to PNG or SVG bytes.
macro_rules! render {
    ($format:expr, $size:expr, |$root:ident| $draw:expr) => {{
        ensure_fonts()?;
        let size: (u32, u32) = $size;
        match $format {
            Format::Png => {
                let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
                {
                    let $root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
                    $draw.map_err(plot_err)?;
                    $root.present().map_err(plot_err)?;
                }
                let mut out = Vec::new();
                use image::ImageEncoder;
                image::codecs::png::PngEncoder::new(&mut out)
                    .write_image(&buf, size.0, size.1, image::ColorType::Rgb8)
                    .map_err(plot_err)?;
                Ok(out)
            }
            Format::Svg => {
                let mut s = String::new();
                {
                    let $root = SVGBackend::with_string(&mut s, size).into_drawing_area();
                    $draw.map_err(plot_err)?;
                    $root.present().map_err(plot_err)?;
                }
                Ok(s.into_bytes())
            }
        }
    }};
}

/// Viridis colour map, t in [0, 1].
pub fn viridis(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 9] = [
        (68.0, 1.0, 84.0),
        (71.0, 44.0, 122.0),
        (59.0, 81.0, 139.0),
        (44.0, 113.0, 142.0),
        (33.0, 144.0, 141.0),
        (39.0, 173.0, 129.0),
        (92.0, 200.0, 99.0),
        (170.0, 220.0, 50.0),
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
    let mix = |p: f64, q: f64| (p + f * (q - p)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

const SERIES: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

fn heat_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    map: &VolumetricMap,
    values: &[f64],
    step: f64,
    radius: f64,
    vmax: f64,
) -> DrawResult {
    let lim = radius + step;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 22, FontStyle::Bold))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(-lim..lim, -lim..lim)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x (mm)")
        .y_desc("y (mm)")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(|e| e.to_string())?;
    let h = step / 2.0;
    chart
        .draw_series(map.points.iter().zip(values).map(|(p, v)| {
            Rectangle::new(
                [(p.x - h, p.y - h), (p.x + h, p.y + h)],
                viridis(v / vmax).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(std::iter::once(PathElement::new(
            (0..=180)
                .map(|k| {
                    let t = k as f64 * std::f64::consts::TAU / 180.0;
                    (radius * t.cos(), radius * t.sin())
                })
                .collect::<Vec<_>>(),
            BLACK.stroke_width(1),
        )))
        .map_err(|e| e.to_string())?;
    Ok(())
}

fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    vmax: f64,
    label: &str,
) -> DrawResult {
    let mut chart = ChartBuilder::on(area)
        .margin_top(60)
        .margin_bottom(57)
        .margin_right(40)
        .y_label_area_size(85)
        .build_cartesian_2d(0.0..1.0, 0.0..vmax)
        .map_err(|e| e.to_string())?;
    let n = 200;
    chart
        .draw_series((0..n).map(|k| {
            let a = vmax * k as f64 / n as f64;
            let b = vmax * (k + 1) as f64 / n as f64;
            Rectangle::new([(0.0, a), (1.0, b)], viridis((a + b) / 2.0 / vmax).filled())
        }))
        .map_err(|e| e.to_string())?;
    // Axis after the bar, so the tick labels are never covered.
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .y_label_formatter(&|v| format!("{v:.2}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Fig. 3: dV over the map plane before and after compensation, one shared
/// colour scale (mm), with max/min/mean in the panel titles.
pub fn fig3(
    map: &VolumetricMap,
    step: f64,
    radius: f64,
    plane_z: f64,
    format: Format,
) -> Result<Vec<u8>> {
    render!(format, (1420, 720), |root| draw_fig3(
        &root, map, step, radius, plane_z
    ))
}

fn draw_fig3<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &VolumetricMap,
    step: f64,
    radius: f64,
    plane_z: f64,
) -> DrawResult {
    let vmax = map
        .before_mm
        .iter()
        .chain(&map.after_mm)
        .cloned()
        .fold(0.0, f64::max)
        .max(1e-12);
    let (b, a) = (map.before(), map.after());
    let t_before = format!(
        "Before: max {:.3}, min {:.3}, mean {:.3} mm",
        b.max_mm, b.min_mm, b.mean_mm
    );
    let t_after = format!(
        "After: max {:.3}, min {:.3}, mean {:.3} mm",
        a.max_mm, a.min_mm, a.mean_mm
    );
    let title = format!(
        "Volumetric error dV, plane z = {plane_z} mm, grid {step} mm ({} points)",
        map.points.len()
    );
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root
        .titled(&title, ("sans-serif", 26, FontStyle::Bold))
        .map_err(|e| e.to_string())?;
    let (panels, bar) = root.split_horizontally(1250);
    let (left, right) = panels.split_horizontally(625);
    heat_panel(&left, &t_before, map, &map.before_mm, step, radius, vmax)?;
    heat_panel(&right, &t_after, map, &map.after_mm, step, radius, vmax)?;
    colour_bar(&bar, vmax, "dV (mm)")
}

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
        let y1 = curves()
            .flat_map(|c| c.hi.iter().chain(&c.mid))
            .chain(self.hlines.iter().map(|h| &h.y))
            .chain(self.markers.iter().map(|m| &m.y))
            .cloned()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            * 1.12;
        let y1 = if y1 > 0.0 { y1 } else { 1.0 };
        let mut ticks: Vec<f64> = xs.clone();
        ticks.sort_by(f64::total_cmp);
        ticks.dedup();
        let n = self.panels.len().max(1) as u32;
        let size = ((620 * n).max(1100), 720);
        render!(format, size, |root| {
            root.fill(&WHITE)
                .map_err(|e| e.to_string())
                .and_then(|_| {
                    root.titled(&self.title, ("sans-serif", 24, FontStyle::Bold))
                        .map_err(|e| e.to_string())
                })
                .and_then(|area| {
                    let parts = area.split_evenly((1, n as usize));
                    for (panel, part) in self.panels.iter().zip(parts.iter()) {
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
        if log_x {
            // A log axis labels only decades; label the grades themselves.
            mesh.x_label_formatter(&|_| String::new()).disable_x_mesh();
        }
        mesh.draw().map_err(|e| e.to_string())?;
    }
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    if log_x {
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
    // Bands first, so lines draw on top.
    for (i, c) in panel.curves.iter().enumerate() {
        let col = SERIES[i % SERIES.len()];
        let poly: Vec<(f64, f64)> =
            c.x.iter()
                .zip(&c.hi)
                .map(|(x, y)| (*x, *y))
                .chain(c.x.iter().zip(&c.lo).rev().map(|(x, y)| (*x, *y)))
                .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(poly, col.mix(0.18).filled())))
            .map_err(e)?
            .label(c.band_label.clone())
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 6), (x + 20, y + 6)], col.mix(0.25).filled())
            });
    }
    for (i, c) in panel.curves.iter().enumerate() {
        let col = SERIES[i % SERIES.len()];
        chart
            .draw_series(LineSeries::new(
                c.x.iter().cloned().zip(c.mid.iter().cloned()),
                col.stroke_width(3),
            ))
            .map_err(e)?
            .label(c.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(3)));
        chart
            .draw_series(
                c.x.iter()
                    .zip(&c.mid)
                    .map(|(x, y)| Circle::new((*x, *y), 4, col.filled())),
            )
            .map_err(e)?;
    }
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
        let dashed = h.dashed;
        chart
            .draw_series(segs)
            .map_err(e)?
            .label(h.label.clone())
            .legend(move |(x, y)| {
                if dashed {
                    PathElement::new(vec![(x, y), (x + 8, y)], col.stroke_width(2))
                } else {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                }
            });
    }
    for m in &spec.markers {
        let col = RGBColor(0, 0, 0);
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                (m.x, m.y),
                9,
                col.filled(),
            )))
            .map_err(e)?
            .label(m.label.clone())
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 7, col.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::MiddleRight)
        .background_style(WHITE.mix(0.7))
        .border_style(RGBColor(160, 160, 160))
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(e)?;
    Ok(())
}

/// Draw `labels` centred under the given x positions of a chart's x axis
/// (categorical or hand-picked ticks).
fn x_tick_labels<DB: DrawingBackend, X, Y>(
    root: &DrawingArea<DB, Shift>,
    chart: &ChartContext<DB, Cartesian2d<X, Y>>,
    ticks: &[(f64, String)],
    y_at: Y::ValueType,
    size: u32,
) -> DrawResult
where
    X: Ranged<ValueType = f64>,
    Y: Ranged,
    Y::ValueType: Clone,
{
    let base = root.get_base_pixel();
    let style =
        ("sans-serif", size)
            .into_font()
            .color(&BLACK)
            .pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Top,
            ));
    for (x, label) in ticks {
        let (px, py) = chart.backend_coord(&(*x, y_at.clone()));
        root.draw(&Text::new(
            label.clone(),
            (px - base.0, py - base.1 + 8),
            style.clone(),
        ))
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// One panel of a [`GradeMap`]: values[s][e] for scale grade s, encoder grade e.
#[derive(Debug, Clone)]
pub struct GradeMapPanel {
    pub title: String,
    pub values: Vec<Vec<f64>>,
    pub feasible: Vec<Vec<bool>>,
}

/// Encoder grade × scale grade heat map of a decision metric, feasible
/// region outlined.
#[derive(Debug, Clone)]
pub struct GradeMap {
    pub title: String,
    pub metric: String,
    pub encoder_arcsec: Vec<f64>,
    pub scale_um: Vec<f64>,
    pub panels: Vec<GradeMapPanel>,
}

impl GradeMap {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        let n = self.panels.len().max(1);
        let vmax = self
            .panels
            .iter()
            .flat_map(|p| p.values.iter().flatten())
            .cloned()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            .max(1e-12);
        let size = ((600 * n as u32) + 170, 640);
        render!(format, size, |root| draw_grade_map(&root, self, vmax))
    }
}

fn draw_grade_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    spec: &GradeMap,
    vmax: f64,
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root
        .titled(&spec.title, ("sans-serif", 22, FontStyle::Bold))
        .map_err(|e| e.to_string())?;
    let (w, _) = root.dim_in_pixel();
    let (panels_area, bar) = root.split_horizontally(w - 170);
    let parts = panels_area.split_evenly((1, spec.panels.len().max(1)));
    let ne = spec.encoder_arcsec.len();
    let ns = spec.scale_um.len();
    let fmt = |v: f64| {
        if (v - v.round()).abs() < 1e-9 {
            format!("{v:.0}")
        } else {
            format!("{v}")
        }
    };
    for (panel, area) in spec.panels.iter().zip(parts.iter()) {
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 19, FontStyle::Bold))
            .margin(16)
            .x_label_area_size(55)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..(ne as f64 - 0.5), -0.5..(ns as f64 - 0.5))
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("encoder grade (arc-seconds)")
            .y_desc("scale grade (µm)")
            .x_label_formatter(&|_| String::new())
            .y_label_formatter(&|_| String::new())
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| e.to_string())?;
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        for s in 0..ns {
            for k in 0..ne {
                let v = panel.values[s][k];
                let (x, y) = (k as f64, s as f64);
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                        viridis(v / vmax).filled(),
                    )))
                    .map_err(e)?;
                let col = if v / vmax > 0.6 { BLACK } else { WHITE };
                chart
                    .draw_series(std::iter::once(Text::new(
                        format!("{v:.3}"),
                        (x - 0.22, y + 0.08),
                        ("sans-serif", 15).into_font().color(&col),
                    )))
                    .map_err(e)?;
            }
        }
        // Outline the feasible region: every edge between a feasible cell and
        // an infeasible one (or the border).
        let feasible = |s: isize, k: isize| {
            s >= 0
                && k >= 0
                && (s as usize) < ns
                && (k as usize) < ne
                && panel.feasible[s as usize][k as usize]
        };
        let mut edges = Vec::new();
        for s in 0..ns as isize {
            for k in 0..ne as isize {
                if !feasible(s, k) {
                    continue;
                }
                let (x, y) = (k as f64, s as f64);
                if !feasible(s, k - 1) {
                    edges.push([(x - 0.5, y - 0.5), (x - 0.5, y + 0.5)]);
                }
                if !feasible(s, k + 1) {
                    edges.push([(x + 0.5, y - 0.5), (x + 0.5, y + 0.5)]);
                }
                if !feasible(s - 1, k) {
                    edges.push([(x - 0.5, y - 0.5), (x + 0.5, y - 0.5)]);
                }
                if !feasible(s + 1, k) {
                    edges.push([(x - 0.5, y + 0.5), (x + 0.5, y + 0.5)]);
                }
            }
        }
        let red = RGBColor(230, 30, 30);
        chart
            .draw_series(
                edges
                    .into_iter()
                    .map(|e| PathElement::new(e.to_vec(), red.stroke_width(4))),
            )
            .map_err(e)?
            .label("feasible: meets the target")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(4)));
        let xt: Vec<(f64, String)> = spec
            .encoder_arcsec
            .iter()
            .enumerate()
            .map(|(k, v)| (k as f64, fmt(*v)))
            .collect();
        x_tick_labels(area, &chart, &xt, -0.5, 16)?;
        let base = area.get_base_pixel();
        for (s, v) in spec.scale_um.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(-0.5, s as f64));
            area.draw(&Text::new(
                fmt(*v),
                (px - base.0 - 10, py - base.1),
                ("sans-serif", 16).into_font().color(&BLACK).pos(
                    plotters::style::text_anchor::Pos::new(
                        plotters::style::text_anchor::HPos::Right,
                        plotters::style::text_anchor::VPos::Center,
                    ),
                ),
            ))
            .map_err(e)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(RGBColor(160, 160, 160))
            .label_font(("sans-serif", 15))
            .draw()
            .map_err(e)?;
    }
    colour_bar(&bar, vmax, &spec.metric)
}

/// Per-parameter standard deviations: Monte-Carlo spread against the linear
/// prediction, one series per grade.
#[derive(Debug, Clone)]
pub struct ParamSeries {
    pub label: String,
    pub mc: Vec<f64>,
    pub predicted: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct ParamChart {
    pub title: String,
    pub names: Vec<String>,
    pub panels: Vec<(String, Vec<ParamSeries>)>,
}

impl ParamChart {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        let vals = || {
            self.panels
                .iter()
                .flat_map(|p| p.1.iter())
                .flat_map(|s| s.mc.iter().chain(&s.predicted))
                .cloned()
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        let lo = vals().fold(f64::INFINITY, f64::min);
        let hi = vals().fold(0.0, f64::max);
        let (lo, hi) = if lo.is_finite() && hi > 0.0 {
            (lo / 2.0, hi * 2.0)
        } else {
            (1e-4, 1.0)
        };
        let n = self.panels.len().max(1) as u32;
        render!(format, ((700 * n).max(900), 680), |root| draw_params(
            &root, self, lo, hi
        ))
    }
}

fn draw_params<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    spec: &ParamChart,
    lo: f64,
    hi: f64,
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root
        .titled(&spec.title, ("sans-serif", 22, FontStyle::Bold))
        .map_err(|e| e.to_string())?;
    let parts = root.split_evenly((1, spec.panels.len().max(1)));
    let np = spec.names.len();
    for ((title, series), area) in spec.panels.iter().zip(parts.iter()) {
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 19, FontStyle::Bold))
            .margin(16)
            .x_label_area_size(55)
            .y_label_area_size(80)
            .build_cartesian_2d(-0.6..(np as f64 - 0.4), (lo..hi).log_scale())
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_desc("parameter")
            .y_desc("standard deviation of the estimate (mm)")
            .x_label_formatter(&|_| String::new())
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .light_line_style(RGBColor(244, 244, 244))
            .draw()
            .map_err(|e| e.to_string())?;
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let m = series.len().max(1) as f64;
        for (i, s) in series.iter().enumerate() {
            let col = SERIES[i % SERIES.len()];
            let off = (i as f64 - (m - 1.0) / 2.0) * 0.12;
            chart
                .draw_series(
                    s.mc.iter()
                        .enumerate()
                        .filter(|(_, v)| v.is_finite() && **v > 0.0)
                        .map(|(k, v)| Circle::new((k as f64 + off, *v), 5, col.filled())),
                )
                .map_err(e)?
                .label(format!("{}: Monte-Carlo", s.label))
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, col.filled()));
            chart
                .draw_series(
                    s.predicted
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| v.is_finite() && **v > 0.0)
                        .map(|(k, v)| Cross::new((k as f64 + off, *v), 7, col.stroke_width(2))),
                )
                .map_err(e)?
                .label(format!("{}: linear prediction", s.label))
                .legend(move |(x, y)| Cross::new((x + 10, y), 6, col.stroke_width(2)));
        }
        let ticks: Vec<(f64, String)> = spec
            .names
            .iter()
            .enumerate()
            .map(|(k, n)| (k as f64, n.clone()))
            .collect();
        x_tick_labels(area, &chart, &ticks, lo, 13)?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(RGBColor(160, 160, 160))
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}
