//! The correction map of a real machine: the position error the identified
//! model predicts for nominal commands over the map plane — what
//! compensation corrects. No true machine is involved.

use super::frame::titled_page;
use super::{
    colour_bar, ensure_fonts, heat_panel_with, plot_err, Arrow, ColourScale, DrawResult, Format,
    PlaneMap,
};
use crate::error::Result;
use nalgebra::Vector3;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Arrows about this many grid cells apart.
const ARROWS_ACROSS: f64 = 10.0;

/// One panel of `map.before_mm` with its own colour scale (mm), and the
/// direction of the error in the plane: an arrow of attained − target
/// (`vectors`, the map's points' position errors) on a coarse lattice of
/// the points, the longest as long as the lattice's spacing.
pub fn correction(plane: &PlaneMap, vectors: &[Vector3<f64>], format: Format) -> Result<Vec<u8>> {
    let arrows = arrows(plane, vectors);
    render!(format, (900, 816), |root| draw(&root, plane, &arrows))
}

/// The arrows: the points on every k-th grid line in x and y (about
/// [`ARROWS_ACROSS`] across the workspace), each vector's (x, y) part
/// scaled so that the longest is k cells long.
pub(crate) fn arrows(plane: &PlaneMap, vectors: &[Vector3<f64>]) -> Vec<Arrow> {
    let step = plane.step;
    if step.is_nan() || step <= 0.0 {
        return Vec::new();
    }
    let k = ((2.0 * plane.radius / step / ARROWS_ACROSS).round() as i64).max(1);
    let on = |v: f64| ((v / step).round() as i64).rem_euclid(k) == 0;
    let chosen: Vec<(Vector3<f64>, Vector3<f64>)> = plane
        .map
        .points
        .iter()
        .zip(vectors)
        .filter(|(p, _)| on(p.x) && on(p.y))
        .map(|(p, v)| (*p, *v))
        .collect();
    let longest = chosen
        .iter()
        .map(|(_, v)| v.xy().norm())
        .filter(|l| l.is_finite())
        .fold(0.0, f64::max);
    if longest <= 0.0 {
        return Vec::new();
    }
    let s = k as f64 * step * 0.9 / longest;
    chosen
        .iter()
        .map(|(p, v)| (p.x, p.y, v.x * s, v.y * s))
        .collect()
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plane: &PlaneMap,
    arrows: &[Arrow],
) -> DrawResult {
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
        "size: max {:.3}, min {:.3}, mean {:.3} mm; arrows: direction in the plane",
        s.max_mm, s.min_mm, s.mean_mm
    );
    let area = titled_page(root, &title, 20)?;
    let h = area.dim_in_pixel().1;
    let (page, foot) = area.split_vertically(h.saturating_sub(50));
    let (left, bar) = page.split_horizontally(740);
    heat_panel_with(
        &left,
        &panel,
        map,
        &map.before_mm,
        (step, radius),
        scale,
        arrows,
    )?;
    for (k, line) in [
        "colour: the size of the position error the identified model predicts for nominal commands (mm)",
        "arrows: its (x, y) part, attained − target (compensation moves the other way); x, y, z in correction_map.csv",
    ]
    .iter()
    .enumerate()
    {
        foot.draw(&Text::new(
            line.to_string(),
            (20, 6 + 20 * k as i32),
            ("sans-serif", 14).into_font(),
        ))
        .map_err(|e| e.to_string())?;
    }
    colour_bar(&bar, scale, "correction (mm)", None)
}

#[cfg(test)]
mod arrow_tests {
    use super::*;
    use crate::compensate::VolumetricMap;

    /// The arrows point along each error's (x, y) part, on every k-th grid
    /// line (about ten across), the longest k cells × 0.9 long; the figure
    /// says what colour and arrows mean.
    #[test]
    fn arrows_point_along_the_error_on_a_coarse_lattice() {
        let step = 20.0;
        let mut points = Vec::new();
        for i in -20..=20 {
            for j in -20..=20 {
                points.push(Vector3::new(i as f64 * step, j as f64 * step, 750.0));
            }
        }
        let vectors: Vec<Vector3<f64>> = points
            .iter()
            .map(|p| Vector3::new(0.1 + 1e-4 * p.y, -0.2, 0.05))
            .collect();
        let map = VolumetricMap {
            before_mm: vectors.iter().map(|v| v.norm()).collect(),
            after_mm: vec![0.0; points.len()],
            points,
        };
        let plane = PlaneMap {
            map: &map,
            step,
            radius: 400.0,
            plane_z: 750.0,
        };
        let a = arrows(&plane, &vectors);
        // k = round(800 / 20 / 10) = 4: every 4th line of 41, 11 × 11.
        assert_eq!(a.len(), 121);
        let longest = a.iter().map(|x| x.2.hypot(x.3)).fold(0.0, f64::max);
        assert!((longest - 0.9 * 4.0 * step).abs() < 1e-9);
        for &(x, y, dx, dy) in &a {
            assert_eq!(((x / step).round() as i64).rem_euclid(4), 0);
            let v = Vector3::new(0.1 + 1e-4 * y, -0.2, 0.0);
            // Parallel and in the same sense.
            assert!((dx * v.y - dy * v.x).abs() < 1e-9 && dx * v.x + dy * v.y > 0.0);
        }
        let svg = String::from_utf8(correction(&plane, &vectors, Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("arrows: its (x, y) part, attained"));
        assert!(!svg.contains("NaN"));
    }
}
