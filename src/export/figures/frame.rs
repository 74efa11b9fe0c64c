//! What every figure sets up alike: a white page under a bold title, the
//! strip for a legend below the plot, the panels' chart builder, and the
//! mesh's text and light grid.

use super::title_size;
use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::Ranged;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// A white page with `title` in bold across its top, as large as fits up to
/// `max` px: the area under the title.
pub(crate) fn titled_page<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    max: u32,
) -> Result<DrawingArea<DB, Shift>, String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let size = title_size(root.dim_in_pixel().0, title, max);
    root.titled(title, ("sans-serif", size, FontStyle::Bold))
        .map_err(|e| e.to_string())
}

/// `area` split into the plot and a strip `px` high below it for the legend.
pub(crate) fn legend_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    px: u32,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let (_, h) = area.dim_in_pixel();
    area.split_vertically(h.saturating_sub(px))
}

/// A panel's chart: `caption` in bold 19 px, margin 16 px, room for the x
/// axis' labels and `y_label_px` for the y axis'.
pub(crate) fn panel<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    y_label_px: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.caption(caption, ("sans-serif", 19, FontStyle::Bold))
        .margin(16)
        .x_label_area_size(55)
        .y_label_area_size(y_label_px);
    b
}

/// The mesh's axis labels `px` high, their descriptions 2 px higher, and its
/// light grid lines grey at `grey`.
pub(crate) fn mesh_look<'m, 'a, 'b, X: Ranged, Y: Ranged, DB: DrawingBackend>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
    px: u32,
    grey: u8,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB> {
    mesh.label_style(("sans-serif", px))
        .axis_desc_style(("sans-serif", px + 2))
        .light_line_style(RGBColor(grey, grey, grey))
}
