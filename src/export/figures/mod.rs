//! Figures: one file per figure, each returning the encoded bytes (PNG or
//! SVG) so the caller can write them atomically. Text uses the embedded
//! DejaVu Sans font (no system fonts needed; licence in `LICENSE-DejaVu`).
//! A new figure is a new file here with one `pub use` line below.

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
mod budget;
mod correction;
mod fig3;
mod grade_map;
mod layers;
mod parameters;
mod price;

pub use band::{BandChart, Curve, HLine, Marker, Panel};
pub use budget::{BudgetBar, BudgetChart};
pub use correction::correction;
pub use fig3::fig3;
pub use grade_map::{GradeMap, GradeMapPanel};
pub use layers::layers;
pub use parameters::{ParamChart, ParamSeries};
pub use price::{PriceChart, PricePoint};

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

pub(crate) fn heat_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    map: &VolumetricMap,
    values: &[f64],
    step: f64,
    radius: f64,
    (vmin, vmax): (f64, f64),
) -> DrawResult {
    let lim = radius + step;
    let span = (vmax - vmin).max(1e-12);
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
                viridis((v - vmin) / span).filled(),
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

pub(crate) fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (vmin, vmax): (f64, f64),
    label: &str,
) -> DrawResult {
    let span = (vmax - vmin).max(1e-12);
    // Enough decimals that neighbouring ticks differ (0.02 mm → 3 decimals).
    let decimals = (2.0 - span.log10().floor()).clamp(2.0, 6.0) as usize;
    let mut chart = ChartBuilder::on(area)
        .margin_top(60)
        .margin_bottom(57)
        .margin_right(40)
        .y_label_area_size(85)
        .build_cartesian_2d(0.0..1.0, vmin..vmin + span)
        .map_err(|e| e.to_string())?;
    let n = 200;
    chart
        .draw_series((0..n).map(|k| {
            let a = vmin + span * k as f64 / n as f64;
            let b = vmin + span * (k + 1) as f64 / n as f64;
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                viridis(((a + b) / 2.0 - vmin) / span).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
    // Axis after the bar, so the tick labels are never covered.
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .y_label_formatter(&|v| format!("{v:.*}", decimals, v = v))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(|e| e.to_string())?;
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
