//! Figures: one file per figure, each returning the encoded bytes (PNG or
//! SVG) so the caller can write them atomically. Text uses the embedded
//! DejaVu Sans font (no system fonts needed; licence in `LICENSE-DejaVu`).
//! A new figure is a new file here with one `pub use` line below.

use crate::compensate::VolumetricMap;
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// A map over the plane z = `plane_z` on a square grid of `step` within
/// `radius` of the axis (mm): what Fig. 3 and the correction map draw.
#[derive(Debug, Clone, Copy)]
pub struct PlaneMap<'a> {
    pub map: &'a VolumetricMap,
    pub step: f64,
    pub radius: f64,
    pub plane_z: f64,
}

impl<'a> PlaneMap<'a> {
    /// `map` on the configuration's grid and plane.
    pub fn of(cfg: &crate::config::Config, map: &'a VolumetricMap) -> Self {
        PlaneMap {
            map,
            step: cfg.grid_step_mm,
            radius: cfg.workspace.radius_mm,
            plane_z: cfg.plane_z_mm,
        }
    }
}

/// Image format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

pub(crate) fn ensure_fonts() -> Result<()> {
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

/// The largest bold title size, at most `max` and at least 12 px, at which
/// `title` fits a figure `width` pixels wide with a margin (a long title is
/// made smaller, never cut at the edges).
pub(crate) fn title_size(width: u32, title: &str, max: u32) -> u32 {
    let _ = ensure_fonts();
    let fits = |size: u32| {
        ("sans-serif", size as f64, FontStyle::Bold)
            .into_font()
            .box_size(title)
            .map(|(w, _)| w + 24 <= width)
            .unwrap_or(true)
    };
    (12..=max.max(12)).rev().find(|&s| fits(s)).unwrap_or(12)
}

pub(crate) fn plot_err<E: std::fmt::Display>(e: E) -> Error {
    Error::Internal(format!("drawing a figure failed: {e}"))
}

pub(crate) type DrawResult = std::result::Result<(), String>;

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

mod band;
mod band_legend;
mod band_spec;
mod budget;
mod correction;
mod fig3;
mod frame;
mod grade_map;
mod layers;
mod parameters;
mod price;

pub use band::{BandChart, BandStyle, Curve, HLine, Marker, Panel, StyledBand};
pub use budget::{BudgetBar, BudgetChart};
pub use correction::correction;
pub use fig3::fig3;
pub use grade_map::{GradeMap, GradeMapPanel};
pub use layers::{layers, layers_of};
pub use parameters::{ParamChart, ParamSeries};
pub use price::{PriceChart, PricePoint, PRICE_DESC};

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

pub(crate) const SERIES: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// How values map onto the colour map: linearly or logarithmically over a
/// range (the figure's unit, mm for dV). Values outside the range take the
/// end colours; a value that is not finite takes the bottom colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourScale {
    lo: f64,
    hi: f64,
    log: bool,
}

impl ColourScale {
    /// Linear from `lo` to `hi` (at least 1e-9 wide).
    pub fn linear(lo: f64, hi: f64) -> Self {
        let lo = if lo.is_finite() { lo } else { 0.0 };
        let hi = if hi.is_finite() { hi } else { lo };
        ColourScale {
            lo,
            hi: hi.max(lo + 1e-9),
            log: false,
        }
    }

    /// Logarithmic from `lo` to `hi` (lo > 0; at least 1 % wide).
    pub fn log(lo: f64, hi: f64) -> Self {
        let lo = if lo.is_finite() && lo > 0.0 { lo } else { 1e-6 };
        let hi = if hi.is_finite() { hi } else { lo };
        ColourScale {
            lo,
            hi: hi.max(lo * 1.01),
            log: true,
        }
    }

    /// Linear over the range of the finite `values`.
    pub fn span_of(values: &[f64]) -> Self {
        let (lo, hi) = finite_range(values.iter().cloned());
        Self::linear(lo, hi)
    }

    /// Linear from 0 to the largest finite value: a map of sizes (dV) whose
    /// colours say how large, not only how it varies (a constant offset
    /// shows as one bright colour, a few micrometres of variation as
    /// little).
    pub fn zero_to_max(values: &[f64]) -> Self {
        let (_, hi) = finite_range(values.iter().cloned());
        Self::linear(0.0, hi)
    }

    /// Logarithmic over the finite positive `values`, the bottom at most
    /// `decades` below the top (so one value near zero does not flatten
    /// the rest).
    pub fn log_of(values: &[f64], decades: f64) -> Self {
        let (lo, hi) = finite_range(values.iter().cloned().filter(|v| *v > 0.0));
        Self::log(lo.max(hi * 10f64.powf(-decades)), hi)
    }

    /// Is the scale logarithmic?
    pub fn is_log(&self) -> bool {
        self.log
    }

    /// The (bottom, top) of the scale.
    pub fn range(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    /// Position of `v` on the scale, 0 (bottom) to 1 (top).
    pub fn t(&self, v: f64) -> f64 {
        let t = if self.log {
            (v.max(self.lo).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The colour of `v`.
    pub fn colour(&self, v: f64) -> RGBColor {
        viridis(self.t(v))
    }

    /// Round values (1, 2, 5 × 10^k) to label the scale with: about 3 to 8
    /// of them on a linear scale; on a log scale the decades, with 2 and 5
    /// added while there are fewer than 4 (a scale under a decade is
    /// labelled linearly).
    pub fn ticks(&self) -> Vec<f64> {
        let (lo, hi) = (self.lo, self.hi);
        let inside = |v: &f64| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9);
        if self.log && hi / lo >= 10.0 {
            let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
            for mantissas in [&[1.0][..], &[1.0, 2.0, 5.0], &[1.0, 2.0, 3.0, 5.0, 7.0]] {
                let t: Vec<f64> = (k0..=k1)
                    .flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)))
                    .filter(inside)
                    .collect();
                if t.len() >= 4 {
                    return t;
                }
            }
        }
        let step = nice_step((hi - lo) / 7.0);
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        (first..=last).map(|k| k as f64 * step).collect()
    }
}

/// The smallest 1, 2 or 5 × 10^k at least `raw`.
fn nice_step(raw: f64) -> f64 {
    let raw = if raw.is_finite() && raw > 0.0 {
        raw
    } else {
        1.0
    };
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * p)
}

/// (min, max) of the finite values; (0, 1) when there are none.
fn finite_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

/// A tick label with as many decimals as the smallest step between ticks
/// needs (0.02 → 2, 0.005 → 3), at least two when below 10.
fn tick_label(v: f64, ticks: &[f64]) -> String {
    let step = ticks
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .chain(ticks.iter().map(|t| t.abs()).filter(|t| *t > 0.0))
        .fold(f64::INFINITY, f64::min);
    let need = if step.is_finite() && step > 0.0 {
        (-step.log10() - 1e-9).ceil().max(0.0) as usize
    } else {
        2
    };
    let floor = if v.abs() < 10.0 { 2 } else { 0 };
    format!("{v:.*}", need.max(floor).min(6))
}

pub(crate) fn heat_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    map: &VolumetricMap,
    values: &[f64],
    step: f64,
    radius: f64,
    scale: ColourScale,
) -> DrawResult {
    heat_panel_with(area, title, map, values, (step, radius), scale, &[])
}

/// An arrow on a map: from (x, y) by (dx, dy), in plot units (mm).
pub(crate) type Arrow = (f64, f64, f64, f64);

/// [`heat_panel`] with `arrows` drawn over the cells.
pub(crate) fn heat_panel_with<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    map: &VolumetricMap,
    values: &[f64],
    (step, radius): (f64, f64),
    scale: ColourScale,
    arrows: &[Arrow],
) -> DrawResult {
    let lim = radius + step;
    // A long title (a small multiple's) is made smaller, never cut.
    let size = title_size(area.dim_in_pixel().0, title, 20);
    // The plane is drawn to scale (a circle is round): the same layout is
    // built on a scratch bitmap to measure its plotting area, and the
    // longer side's margins take up the difference.
    let (aw, ah) = area.dim_in_pixel();
    let (pw, ph) = {
        let mut buf = vec![0u8; aw as usize * ah as usize * 3];
        let scratch = BitMapBackend::with_buffer(&mut buf, (aw, ah)).into_drawing_area();
        let probe = ChartBuilder::on(&scratch)
            .caption(title, ("sans-serif", size, FontStyle::Bold))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(-lim..lim, -lim..lim)
            .map_err(|e| e.to_string())?;
        probe.plotting_area().dim_in_pixel()
    };
    let (wide, tall) = (pw.saturating_sub(ph), ph.saturating_sub(pw));
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", size, FontStyle::Bold))
        .margin_left(12 + wide / 2)
        .margin_right(12 + wide - wide / 2)
        .margin_top(12 + tall / 2)
        .margin_bottom(12 + tall - tall / 2)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(-lim..lim, -lim..lim)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        // Few enough labels that they never run together in a small panel.
        .x_labels(5)
        .y_labels(5)
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
                scale.colour(*v).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
    // The workspace's circle as two half circles, each drawn left to
    // right: the bitmap backend leaves gaps in a nearly horizontal stroke
    // drawn right to left (the top of a circle drawn anticlockwise came
    // out dashed).
    let half = |sign: f64| {
        PathElement::new(
            (0..=90)
                .map(|k| {
                    let t = std::f64::consts::PI * (1.0 - k as f64 / 90.0);
                    (radius * t.cos(), sign * radius * t.sin())
                })
                .collect::<Vec<_>>(),
            BLACK.stroke_width(1),
        )
    };
    chart
        .draw_series([half(1.0), half(-1.0)])
        .map_err(|e| e.to_string())?;
    for &(x, y, dx, dy) in arrows {
        let len = (dx * dx + dy * dy).sqrt();
        if !(len.is_finite() && len > 0.0) {
            continue;
        }
        // The shaft, and a head of two strokes at ±25° a third of it long
        // (at most one grid cell).
        let (ux, uy) = (dx / len, dy / len);
        let head = (len / 3.0).min(step);
        let (tx, ty) = (x + dx, y + dy);
        let side = |a: f64| {
            let (c, s) = (a.cos(), a.sin());
            (tx - head * (ux * c - uy * s), ty - head * (ux * s + uy * c))
        };
        let a = 25f64.to_radians();
        chart
            .draw_series([
                PathElement::new(vec![(x, y), (tx, ty)], BLACK.stroke_width(2)),
                PathElement::new(vec![side(a), (tx, ty), side(-a)], BLACK.stroke_width(2)),
            ])
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// A mark across a colour bar: a value (in the scale's unit) and its label.
#[derive(Debug, Clone)]
pub struct BarMark {
    pub value: f64,
    pub label: String,
}

/// A vertical colour bar of `scale`: the colours, round tick values in the
/// scale's unit on the left, `label` along its side, and `mark` (e.g. the
/// target) as a red line across the bar labelled on its right.
pub(crate) fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: ColourScale,
    label: &str,
    mark: Option<&BarMark>,
) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let right = if mark.is_some() { 95 } else { 40 };
    let mut chart = ChartBuilder::on(area)
        .margin_top(60)
        .margin_bottom(57)
        .margin_right(right)
        .y_label_area_size(85)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .map_err(|e| e.to_string())?;
    let n = 200;
    chart
        .draw_series((0..n).map(|k| {
            let (a, b) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
            Rectangle::new([(0.0, a), (1.0, b)], viridis((a + b) / 2.0).filled())
        }))
        .map_err(e)?;
    // The axis (and its description) after the bar; its own labels are
    // replaced by the scale's round values, drawn at their colours.
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(0)
        .y_desc(label)
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(e)?;
    let ticks = scale.ticks();
    let base = area.get_base_pixel();
    let font =
        ("sans-serif", 15)
            .into_font()
            .color(&BLACK)
            .pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Right,
                plotters::style::text_anchor::VPos::Center,
            ));
    for v in &ticks {
        let (px, py) = chart.backend_coord(&(0.0, scale.t(*v)));
        let (x, y) = (px - base.0, py - base.1);
        area.draw(&PathElement::new(vec![(x - 6, y), (x, y)], BLACK))
            .map_err(e)?;
        area.draw(&Text::new(tick_label(*v, &ticks), (x - 9, y), font.clone()))
            .map_err(e)?;
    }
    if let Some(m) = mark {
        let red = RGBColor(220, 20, 20);
        let (x0, y) = chart.backend_coord(&(0.0, scale.t(m.value)));
        let (x1, _) = chart.backend_coord(&(1.0, scale.t(m.value)));
        let (x0, x1, y) = (x0 - base.0, x1 - base.0, y - base.1);
        area.draw(&PathElement::new(
            vec![(x0, y), (x1 + 6, y)],
            red.stroke_width(3),
        ))
        .map_err(e)?;
        let font = ("sans-serif", 14, FontStyle::Bold).into_font().color(&red);
        for (k, line) in m.label.lines().enumerate() {
            area.draw(&Text::new(
                line.to_string(),
                (x1 + 9, y - 8 + 16 * k as i32),
                font.clone(),
            ))
            .map_err(e)?;
        }
    }
    Ok(())
}

/// Draw `labels` centred under the given x positions of a chart's x axis
/// (categorical or hand-picked ticks).
pub(crate) fn x_tick_labels<DB: DrawingBackend, X, Y>(
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

/// Does an SVG figure hold a text element reading exactly `text`?
#[cfg(test)]
pub(crate) fn svg_has_text(svg: &str, text: &str) -> bool {
    svg.contains(&format!(">\n{text}\n</text>"))
}

#[cfg(test)]
mod tests;
