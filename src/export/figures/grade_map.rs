//! Encoder × scale heat map of the decision metric.

use super::frame::{self, legend_strip, titled_page};
use super::{
    colour_bar, ensure_fonts, plot_err, x_tick_labels, BarMark, ColourScale, DrawResult, Format,
};
use crate::error::Result;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One panel of a [`GradeMap`]: values[s][e] for scale grade s, encoder grade e.
#[derive(Debug, Clone)]
pub struct GradeMapPanel {
    pub title: String,
    pub values: Vec<Vec<f64>>,
    pub feasible: Vec<Vec<bool>>,
}

/// Encoder grade × scale grade heat map of a decision metric, feasible
/// region outlined. The colours are logarithmic (cells from 0.03 to 6 mm
/// are told apart), the colour bar is in the metric's unit and marks the
/// target.
#[derive(Debug, Clone)]
pub struct GradeMap {
    pub title: String,
    pub metric: String,
    pub encoder_arcsec: Vec<f64>,
    pub scale_um: Vec<f64>,
    pub panels: Vec<GradeMapPanel>,
    /// The target the metric must meet (marked on the colour bar).
    pub threshold: f64,
}

impl GradeMap {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        let n = self.panels.len().max(1);
        let size = ((600 * n as u32).max(700) + 280, 680);
        render!(format, size, |root| draw_grade_map(
            &root,
            self,
            self.scale()
        ))
    }

    /// The colour scale: logarithmic over the cells' values (at most four
    /// decades), so a cell of 0.05 mm and one of 0.2 mm differ in colour
    /// even when others reach several mm.
    pub fn scale(&self) -> ColourScale {
        let values: Vec<f64> = self
            .panels
            .iter()
            .flat_map(|p| p.values.iter().flatten())
            .cloned()
            .collect();
        ColourScale::log_of(&values, 4.0)
    }

    /// The colour bar's label: short enough for the bar's height (the
    /// metric in words is in the title and the legend), with its unit and
    /// the scale.
    fn bar_label(&self) -> String {
        let unit = if self.metric.ends_with("(mm)") {
            " (mm)"
        } else {
            ""
        };
        format!("the deciding value{unit}, log colour scale")
    }
}

fn draw_grade_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    spec: &GradeMap,
    scale: ColourScale,
) -> DrawResult {
    let root = titled_page(root, &spec.title, 19)?;
    let w = root.dim_in_pixel().0;
    // The legend sits in a strip below the panels, clear of the cells.
    let (root, legend) = legend_strip(&root, 40);
    let (panels_area, bar) = root.split_horizontally(w - 280);
    let parts = panels_area.split_evenly((1, spec.panels.len().max(1)));
    let ne = spec.encoder_arcsec.len();
    let ns = spec.scale_um.len();
    for (panel, area) in spec.panels.iter().zip(parts.iter()) {
        let mut chart = frame::panel(area, &panel.title, 70)
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
                        scale.colour(v).filled(),
                    )))
                    .map_err(e)?;
                let col = if scale.t(v) > 0.6 { BLACK } else { WHITE };
                chart
                    .draw_series(std::iter::once(Text::new(
                        // A cell without a value (a limit that does not
                        // exist at this many machines) says so, not "NaN".
                        match v.is_finite() {
                            true => format!("{v:.3}"),
                            false => "n/a".to_string(),
                        },
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
            format!(
                "outlined in red: the grades that meet the target; colours: {}, on a log scale",
                spec.metric
            ),
            (130, 9),
            ("sans-serif", 15).into_font(),
        ))
        .map_err(|e| e.to_string())?;
    let mark = BarMark {
        value: spec.threshold,
        label: format!("target\n{}", spec.threshold),
    };
    colour_bar(&bar, scale, &spec.bar_label(), Some(&mark))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn map(values: Vec<Vec<f64>>) -> GradeMap {
        let feasible = values.iter().map(|r| vec![false; r.len()]).collect();
        GradeMap {
            title: "t".into(),
            metric: "dV p95 over the workspace, 95 % of machines (mm)".into(),
            encoder_arcsec: vec![1.0, 10.0],
            scale_um: vec![0.5, 5.0],
            panels: vec![GradeMapPanel {
                title: "GLS".into(),
                values,
                feasible,
            }],
            threshold: 0.25,
        }
    }

    /// A cell without a value reads "n/a", never "NaN".
    #[test]
    fn a_cell_without_a_value_says_so() {
        let m = map(vec![vec![0.05, f64::NAN], vec![3.0, 6.0]]);
        let svg = String::from_utf8(m.render(Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("n/a") && !svg.contains("NaN"), "{svg}");
    }

    /// Cells of 0.05 and 0.2 mm beside cells of 6 mm get clearly
    /// different colours (a linear scale to 6 mm gave them one colour),
    /// and the colour bar is labelled at round values in mm.
    #[test]
    fn colours_are_logarithmic_and_ticks_round_mm() {
        let m = map(vec![vec![0.05, 0.2], vec![3.0, 6.0]]);
        let s = m.scale();
        assert!(s.is_log());
        let (a, b) = (s.t(0.05), s.t(0.2));
        assert!(b - a > 0.2, "0.05 mm at {a}, 0.2 mm at {b}");
        assert!(
            ((b - a) - (s.t(6.0) - s.t(1.5))).abs() < 1e-9,
            "equal ratios, equal steps"
        );
        assert_ne!(s.colour(0.05), s.colour(0.2));
        let ticks = s.ticks();
        for v in [0.1, 1.0] {
            assert!(ticks.iter().any(|t| (t - v).abs() < 1e-12), "{ticks:?}");
        }
        let svg = String::from_utf8(m.render(Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("(mm), log colour scale"));
        assert!(
            crate::export::figures::svg_has_text(&svg, "target")
                && crate::export::figures::svg_has_text(&svg, "0.25")
        );
        assert!(
            crate::export::figures::svg_has_text(&svg, "0.10")
                && crate::export::figures::svg_has_text(&svg, "1.00")
        );
    }
}
