//! Fig. 3 of the paper: dV over the map plane, before and after compensation.

use super::{colour_bar, ensure_fonts, heat_panel, plot_err, DrawResult, Format};
use crate::compensate::VolumetricMap;
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

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
        .titled(
            &title,
            (
                "sans-serif",
                super::title_size(root.dim_in_pixel().0, &title, 26),
                FontStyle::Bold,
            ),
        )
        .map_err(|e| e.to_string())?;
    let (panels, bar) = root.split_horizontally(1250);
    let (left, right) = panels.split_horizontally(625);
    heat_panel(
        &left,
        &t_before,
        map,
        &map.before_mm,
        step,
        radius,
        (0.0, vmax),
    )?;
    heat_panel(
        &right,
        &t_after,
        map,
        &map.after_mm,
        step,
        radius,
        (0.0, vmax),
    )?;
    colour_bar(&bar, (0.0, vmax), "dV (mm)")
}
