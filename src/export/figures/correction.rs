//! The correction map of a real machine: the position error the identified
//! model predicts for nominal commands over the map plane — what
//! compensation corrects. No true machine is involved.

use super::frame::titled_page;
use super::{
    colour_bar, ensure_fonts, heat_panel, plot_err, ColourScale, DrawResult, Format, PlaneMap,
};
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One panel of `map.before_mm` with its own colour scale (mm).
pub fn correction(plane: &PlaneMap, format: Format) -> Result<Vec<u8>> {
    render!(format, (900, 760), |root| draw(&root, plane))
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plane: &PlaneMap) -> DrawResult {
    let (map, step, radius, plane_z) = (plane.map, plane.step, plane.radius, plane.plane_z);
    // The bar spans the data (2.26–2.94 mm on a typical machine), not
    // 0 to the maximum, where every point would share one colour.
    let finite = map.before_mm.iter().cloned().filter(|v| v.is_finite());
    let lo = finite.clone().fold(f64::INFINITY, f64::min);
    let hi = finite.fold(f64::NEG_INFINITY, f64::max);
    let scale = ColourScale::linear(lo, hi);
    let s = map.before();
    let title = format!(
        "Identified model's correction, plane z = {plane_z} mm (real machine: no true errors)"
    );
    let panel = format!(
        "max {:.3}, min {:.3}, mean {:.3} mm",
        s.max_mm, s.min_mm, s.mean_mm
    );
    let (left, bar) = titled_page(root, &title, 20)?.split_horizontally(740);
    heat_panel(&left, &panel, map, &map.before_mm, step, radius, scale)?;
    colour_bar(&bar, scale, "correction (mm)", None)
}
