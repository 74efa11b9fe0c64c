//! Encoder × scale heat map of the decision metric.

use super::{colour_bar, ensure_fonts, plot_err, viridis, x_tick_labels, DrawResult, Format};
use crate::error::Result;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// One panel of a [`GradeMap`]: values[s][e] for scale grade s, encoder grade e.
#[derive(Debug, Clone)]
pub struct GradeMapPanel {
    pub title: String,
    pub values: Vec<Vec<f64>>,
    pub feasible: Vec<Vec<bool>>,
}

/// Encoder grade × scale grade heat map of a decision metric, feasible
/// region outlined.
#[derive(Debug, Clone)]
pub struct GradeMap {
    pub title: String,
    pub metric: String,
    pub encoder_arcsec: Vec<f64>,
    pub scale_um: Vec<f64>,
    pub panels: Vec<GradeMapPanel>,
}

impl GradeMap {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        let n = self.panels.len().max(1);
        let vmax = self
            .panels
            .iter()
            .flat_map(|p| p.values.iter().flatten())
            .cloned()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            .max(1e-12);
        let size = ((600 * n as u32).max(700) + 230, 680);
        render!(format, size, |root| draw_grade_map(&root, self, vmax))
    }
}

fn draw_grade_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    spec: &GradeMap,
    vmax: f64,
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root
        .titled(
            &spec.title,
            (
                "sans-serif",
                super::title_size(root.dim_in_pixel().0, &spec.title, 19),
                FontStyle::Bold,
            ),
        )
        .map_err(|e| e.to_string())?;
    let (w, h) = root.dim_in_pixel();
    // The legend sits in a strip below the panels, clear of the cells.
    let (root, legend) = root.split_vertically(h.saturating_sub(40));
    let (panels_area, bar) = root.split_horizontally(w - 230);
    let parts = panels_area.split_evenly((1, spec.panels.len().max(1)));
    let ne = spec.encoder_arcsec.len();
    let ns = spec.scale_um.len();
    for (panel, area) in spec.panels.iter().zip(parts.iter()) {
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 19, FontStyle::Bold))
            .margin(16)
            .x_label_area_size(55)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..(ne as f64 - 0.5), -0.5..(ns as f64 - 0.5))
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("encoder grade (arc-seconds)")
            .y_desc("scale grade (µm)")
            .x_label_formatter(&|_| String::new())
            .y_label_formatter(&|_| String::new())
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| e.to_string())?;
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        for s in 0..ns {
            for k in 0..ne {
                let v = panel.values[s][k];
                let (x, y) = (k as f64, s as f64);
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                        viridis(v / vmax).filled(),
                    )))
                    .map_err(e)?;
                let col = if v / vmax > 0.6 { BLACK } else { WHITE };
                chart
                    .draw_series(std::iter::once(Text::new(
                        format!("{v:.3}"),
                        (x - 0.22, y + 0.08),
                        ("sans-serif", 15).into_font().color(&col),
                    )))
                    .map_err(e)?;
            }
        }
        let edges = feasible_outline(&panel.feasible, ns, ne);
        let red = RGBColor(230, 30, 30);
        chart
            .draw_series(
                edges
                    .into_iter()
                    .map(|e| PathElement::new(e.to_vec(), red.stroke_width(4))),
            )
            .map_err(e)?;
        grade_labels(area, &chart, spec)?;
    }
    let red = RGBColor(230, 30, 30);
    legend
        .draw(&PathElement::new(
            vec![(90, 18), (120, 18)],
            red.stroke_width(4),
        ))
        .map_err(|e| e.to_string())?;
    legend
        .draw(&Text::new(
            "outlined in red: the grades that meet the target",
            (130, 9),
            ("sans-serif", 15).into_font(),
        ))
        .map_err(|e| e.to_string())?;
    colour_bar(&bar, (0.0, vmax), &spec.metric)
}

/// The outline of the feasible region: every edge between a feasible cell
/// and an infeasible one (or the border), in cell coordinates.
fn feasible_outline(cells: &[Vec<bool>], ns: usize, ne: usize) -> Vec<[(f64, f64); 2]> {
    let feasible = |s: isize, k: isize| {
        s >= 0 && k >= 0 && (s as usize) < ns && (k as usize) < ne && cells[s as usize][k as usize]
    };
    let mut edges = Vec::new();
    for s in 0..ns as isize {
        for k in 0..ne as isize {
            if !feasible(s, k) {
                continue;
            }
            let (x, y) = (k as f64, s as f64);
            if !feasible(s, k - 1) {
                edges.push([(x - 0.5, y - 0.5), (x - 0.5, y + 0.5)]);
            }
            if !feasible(s, k + 1) {
                edges.push([(x + 0.5, y - 0.5), (x + 0.5, y + 0.5)]);
            }
            if !feasible(s - 1, k) {
                edges.push([(x - 0.5, y - 0.5), (x + 0.5, y - 0.5)]);
            }
            if !feasible(s + 1, k) {
                edges.push([(x - 0.5, y + 0.5), (x + 0.5, y + 0.5)]);
            }
        }
    }
    edges
}

/// The grades as tick labels: encoders under the x axis, scales left of y.
fn grade_labels<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    spec: &GradeMap,
) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let fmt = |v: f64| {
        if (v - v.round()).abs() < 1e-9 {
            format!("{v:.0}")
        } else {
            format!("{v}")
        }
    };
    let xt: Vec<(f64, String)> = spec
        .encoder_arcsec
        .iter()
        .enumerate()
        .map(|(k, v)| (k as f64, fmt(*v)))
        .collect();
    x_tick_labels(area, chart, &xt, -0.5, 16)?;
    let base = area.get_base_pixel();
    for (s, v) in spec.scale_um.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(-0.5, s as f64));
        area.draw(&Text::new(
            fmt(*v),
            (px - base.0 - 10, py - base.1),
            ("sans-serif", 16).into_font().color(&BLACK).pos(
                plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Right,
                    plotters::style::text_anchor::VPos::Center,
                ),
            ),
        ))
        .map_err(e)?;
    }
    Ok(())
}
