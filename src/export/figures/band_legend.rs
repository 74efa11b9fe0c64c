//! The legend of a band chart: its entries, how many columns fit the
//! panel's width, and drawing it below the plot (never over the data).

use super::band_spec::{BandChart, BandStyle, Panel};
use super::{DrawResult, SERIES};
use plotters::coord::Shift;
use plotters::prelude::*;

/// The legend entries of a panel: each curve's band (or its dashed upper
/// edge) and median, the reference lines, the markers.
pub(super) fn legend_entries(
    spec: &BandChart,
    panel: &Panel,
    style: &BandStyle,
) -> Vec<(Swatch, String)> {
    let mut out = Vec::new();
    for (i, c) in panel.curves.iter().enumerate() {
        let col = SERIES[i % SERIES.len()];
        out.push((Swatch::Line(col), c.label.clone()));
        let band = if style.band_edges && c.x.len() > 1 {
            Swatch::Dashed(col)
        } else {
            Swatch::Band(col)
        };
        out.push((band, c.band_label.clone()));
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
pub(super) fn label_width(label: &str) -> usize {
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
pub(super) fn legend_columns(
    spec: &BandChart,
    panel: &Panel,
    width: u32,
    style: &BandStyle,
) -> usize {
    let widest = legend_entries(spec, panel, style)
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
pub(super) fn legend_rows(spec: &BandChart, panel: &Panel, width: u32, style: &BandStyle) -> usize {
    legend_entries(spec, panel, style)
        .len()
        .div_ceil(legend_columns(spec, panel, width, style))
}

/// The legend in its own area below the plot, two entries a row (one when
/// the labels are long).
pub(super) fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    spec: &BandChart,
    panel: &Panel,
    style: &BandStyle,
) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (w, _) = area.dim_in_pixel();
    let cols = legend_columns(spec, panel, w, style) as i32;
    let col_w = (w as i32 - 40) / 2;
    let font = ("sans-serif", 15).into_font().color(&BLACK);
    for (k, (swatch, label)) in legend_entries(spec, panel, style).iter().enumerate() {
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

/// How one legend entry is drawn.
pub(super) enum Swatch {
    Band(RGBColor),
    Line(RGBColor),
    Dashed(RGBColor),
    Triangle,
}
