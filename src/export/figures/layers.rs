//! dV per layer of the workspace grid (docs/method.md §12): small multiples, one
//! column per plane from the top face to the bottom face, before
//! compensation on the top row and after on the bottom row. Each row has its
//! own colour scale, so the after-maps show their structure instead of one
//! flat colour on the before-map's scale.

use super::frame::titled_page;
use super::{colour_bar, ensure_fonts, heat_panel, plot_err, ColourScale, DrawResult, Format};
use crate::compensate::VolumetricMap;
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Width of one panel, px.
const PANEL_PX: u32 = 380;

/// The small multiples of a workspace map whose points are `layers` planes
/// of equal size, in order.
pub fn layers(
    map: &VolumetricMap,
    layers: usize,
    step: f64,
    radius: f64,
    format: Format,
) -> Result<Vec<u8>> {
    layers_of(
        map,
        layers,
        step,
        radius,
        ("Volumetric error dV", "dV"),
        format,
    )
}

/// [`layers`] of another quantity in mm: (its name in the title, its short
/// name on the colour bars).
pub fn layers_of(
    map: &VolumetricMap,
    layers: usize,
    step: f64,
    radius: f64,
    words: (&str, &str),
    format: Format,
) -> Result<Vec<u8>> {
    let w = PANEL_PX * layers.max(1) as u32 + 190;
    render!(format, (w, 2 * PANEL_PX + 70), |root| draw(
        &root, map, layers, step, radius, words
    ))
}

/// The points and values of layer `k`.
fn layer(map: &VolumetricMap, layers: usize, k: usize) -> VolumetricMap {
    let n = map.points.len() / layers.max(1);
    let r = k * n..(k + 1) * n;
    VolumetricMap {
        points: map.points[r.clone()].to_vec(),
        before_mm: map.before_mm[r.clone()].to_vec(),
        after_mm: map.after_mm[r].to_vec(),
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &VolumetricMap,
    layers: usize,
    step: f64,
    radius: f64,
    (what, short): (&str, &str),
) -> DrawResult {
    // Each row on the range of its own values: the after-maps show structure.
    let (vb, va) = (
        ColourScale::span_of(&map.before_mm),
        ColourScale::span_of(&map.after_mm),
    );
    let title = format!(
        "{what} per layer of the workspace (grid {step} mm, {} points); top row before, bottom row after compensation",
        map.points.len()
    );
    // This title is long (the what, the grid, the rows): sized to 96 % of
    // the page, as the bold face renders a few per cent wider than it
    // measures and a title at the page's width loses its last letters.
    let narrower = root.dim_in_pixel().0 * 24 / 25;
    let root = titled_page(root, &title, super::title_size(narrower, &title, 22))?;
    let (w, _) = root.dim_in_pixel();
    let (panels, bars) = root.split_horizontally(w - 190);
    let (top, bottom) = panels.split_vertically(PANEL_PX);
    let (bar_top, bar_bottom) = bars.split_vertically(PANEL_PX);
    let tops = top.split_evenly((1, layers.max(1)));
    let bottoms = bottom.split_evenly((1, layers.max(1)));
    for k in 0..layers {
        let l = layer(map, layers, k);
        let z = l.points.first().map_or(0.0, |p| p.z);
        let (b, a) = (l.before(), l.after());
        let (tb, ta) = (panel_title(z, &b), panel_title(z, &a));
        heat_panel(&tops[k], &tb, &l, &l.before_mm, step, radius, vb)?;
        heat_panel(&bottoms[k], &ta, &l, &l.after_mm, step, radius, va)?;
    }
    colour_bar(&bar_top, vb, &format!("{short} before (mm)"), None)?;
    colour_bar(&bar_bottom, va, &format!("{short} after (mm)"), None)
}

/// A layer panel's title: the plane's z and its max and mean dV, in mm.
fn panel_title(z: f64, s: &crate::compensate::Stats) -> String {
    format!(
        "z = {z:.0} mm: max {:.3}, mean {:.3} mm",
        s.max_mm, s.mean_mm
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// Every panel title carries its unit: the plane's z in mm and dV in mm.
    #[test]
    fn layer_titles_give_z_and_dv_in_mm() {
        let points = [650.0, 750.0]
            .iter()
            .flat_map(|&z| (0..3).map(move |k| Vector3::new(100.0 * k as f64, 0.0, z)))
            .collect();
        let map = VolumetricMap {
            points,
            before_mm: vec![0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
            after_mm: vec![0.01, 0.02, 0.03, 0.04, 0.05, 0.06],
        };
        let svg = String::from_utf8(layers(&map, 2, 100.0, 400.0, Format::Svg).unwrap()).unwrap();
        for t in [
            "z = 650 mm: max 0.700, mean 0.600 mm",
            "z = 750 mm: max 1.000, mean 0.900 mm",
            "z = 650 mm: max 0.030, mean 0.020 mm",
            "z = 750 mm: max 0.060, mean 0.050 mm",
        ] {
            assert!(svg.contains(t), "no panel titled {t}");
        }
    }
}
