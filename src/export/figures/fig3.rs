//! Fig. 3 of the paper: dV over the map plane, before and after compensation.

use super::frame::titled_page;
use super::{
    colour_bar, ensure_fonts, heat_panel, plot_err, ColourScale, DrawResult, Format, PlaneMap,
};
use crate::compensate::VolumetricMap;
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Width of one half (map and its colour bar), px.
const HALF_PX: u32 = 790;
/// Width of a colour bar, px.
const BAR_PX: u32 = 165;

/// Fig. 3: dV over the map plane before and after compensation. Each panel
/// has its own colour scale from 0 to its largest value (mm): the after-map
/// is not one flat colour at the bottom of the before-map's range, and its
/// few micrometres of variation are not stretched over the whole bar while
/// a constant offset hides (an offset of 0.14 mm shows bright); the title
/// and the bars say so, and the panel titles give max/min/mean.
pub fn fig3(plane: &PlaneMap, format: Format) -> Result<Vec<u8>> {
    render!(format, (2 * HALF_PX, 720), |root| draw_fig3(&root, plane))
}

/// The colour scales of the before and the after panel: each linear from 0
/// to its own largest value.
pub(crate) fn scales(map: &VolumetricMap) -> (ColourScale, ColourScale) {
    (
        ColourScale::zero_to_max(&map.before_mm),
        ColourScale::zero_to_max(&map.after_mm),
    )
}

fn draw_fig3<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plane: &PlaneMap) -> DrawResult {
    let (map, step, radius, plane_z) = (plane.map, plane.step, plane.radius, plane.plane_z);
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
        "Volumetric error dV, plane z = {plane_z} mm, grid {step} mm ({} points) — each panel on its own colour scale from 0",
        map.points.len()
    );
    let (sb, sa) = scales(map);
    let (left, right) = titled_page(root, &title, 26)?.split_horizontally(HALF_PX);
    let (panel, bar) = left.split_horizontally(HALF_PX - BAR_PX);
    heat_panel(&panel, &t_before, map, &map.before_mm, step, radius, sb)?;
    colour_bar(
        &bar,
        sb,
        "dV before compensation (mm), own scale from 0",
        None,
    )?;
    let (panel, bar) = right.split_horizontally(HALF_PX - BAR_PX);
    heat_panel(&panel, &t_after, map, &map.after_mm, step, radius, sa)?;
    colour_bar(
        &bar,
        sa,
        "dV after compensation (mm), own scale from 0",
        None,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn map() -> VolumetricMap {
        let points = (0..4).map(|k| Vector3::new(k as f64, 0.0, 750.0)).collect();
        VolumetricMap {
            points,
            before_mm: vec![0.655, 0.8, 0.9, 1.028],
            after_mm: vec![0.127, 0.13, 0.14, 0.153],
        }
    }

    /// Each panel runs from 0 to its own largest value: the after-panel is
    /// not flat at the bottom of the before-map's range (3 % of it), and an
    /// offset of 0.127–0.153 mm shows in the top fifth of its bar, not as
    /// the whole bar's range (which made 26 µm look like everything).
    #[test]
    fn each_panel_runs_from_zero_to_its_largest_value() {
        let (sb, sa) = scales(&map());
        assert_eq!((sa.t(0.0), sa.t(0.153)), (0.0, 1.0));
        assert!(sa.t(0.127) > 0.8, "{}", sa.t(0.127));
        assert_eq!((sb.t(0.0), sb.t(1.028)), (0.0, 1.0));
        assert!(sb.t(0.655) > 0.6);
    }

    /// The title and both colour bars say that each panel has its own scale.
    #[test]
    fn the_figure_says_each_panel_has_its_own_scale() {
        let svg = String::from_utf8(
            fig3(
                &PlaneMap {
                    map: &map(),
                    step: 20.0,
                    radius: 400.0,
                    plane_z: 750.0,
                },
                Format::Svg,
            )
            .unwrap(),
        )
        .unwrap();
        assert!(svg.contains("each panel on its own colour scale from 0"));
        assert!(svg.contains("dV before compensation (mm), own scale from 0"));
        assert!(svg.contains("dV after compensation (mm), own scale from 0"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }
}
