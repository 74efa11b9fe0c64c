//! dV per layer of the workspace grid (SPEC §12): small multiples, one
//! column per plane from the top face to the bottom face, before
//! compensation on the top row and after on the bottom row. Each row has its
//! own colour scale, so the after-maps show their structure instead of one
//! flat colour on the before-map's scale.

use super::{colour_bar, ensure_fonts, heat_panel, plot_err, DrawResult, Format};
use crate::compensate::VolumetricMap;
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

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
    let w = PANEL_PX * layers.max(1) as u32 + 190;
    render!(format, (w, 2 * PANEL_PX + 70), |root| draw(
        &root, map, layers, step, radius
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
) -> DrawResult {
    // Each row on the range of its own values: the after-maps show structure.
    let range = |v: &[f64]| {
        let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = v.iter().cloned().fold(0.0, f64::max);
        (lo.min(hi), hi.max(lo + 1e-9))
    };
    let (vb, va) = (range(&map.before_mm), range(&map.after_mm));
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let title = format!(
        "Volumetric error dV per layer of the workspace (grid {step} mm, {} points); top row before, bottom row after compensation",
        map.points.len()
    );
    let size = super::title_size(root.dim_in_pixel().0, &title, 22);
    let root = root
        .titled(&title, ("sans-serif", size, FontStyle::Bold))
        .map_err(|e| e.to_string())?;
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
        let tb = format!("z {z:.0}: max {:.3}, mean {:.3}", b.max_mm, b.mean_mm);
        let ta = format!("z {z:.0}: max {:.3}, mean {:.3}", a.max_mm, a.mean_mm);
        heat_panel(&tops[k], &tb, &l, &l.before_mm, step, radius, vb)?;
        heat_panel(&bottoms[k], &ta, &l, &l.after_mm, step, radius, va)?;
    }
    colour_bar(&bar_top, vb, "dV before (mm)")?;
    colour_bar(&bar_bottom, va, "dV after (mm)")
}
