//! Parameter uncertainty: Monte-Carlo spread against linear prediction.

use super::frame::{mesh_look, panel, titled_page};
use super::{ensure_fonts, plot_err, x_tick_labels, DrawResult, Format, SERIES};
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Per-parameter standard deviations: Monte-Carlo spread against the linear
/// prediction, one series per grade.
#[derive(Debug, Clone)]
pub struct ParamSeries {
    pub label: String,
    pub mc: Vec<f64>,
    pub predicted: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct ParamChart {
    pub title: String,
    pub names: Vec<String>,
    pub panels: Vec<(String, Vec<ParamSeries>)>,
}

impl ParamChart {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        let vals = || {
            self.panels
                .iter()
                .flat_map(|p| p.1.iter())
                .flat_map(|s| s.mc.iter().chain(&s.predicted))
                .cloned()
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        let lo = vals().fold(f64::INFINITY, f64::min);
        let hi = vals().fold(0.0, f64::max);
        let (lo, hi) = if lo.is_finite() && hi > 0.0 {
            (lo / 2.0, hi * 2.0)
        } else {
            (1e-4, 1.0)
        };
        let n = self.panels.len().max(1) as u32;
        render!(format, ((700 * n).max(900), 680), |root| draw_params(
            &root, self, lo, hi
        ))
    }
}

fn draw_params<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    spec: &ParamChart,
    lo: f64,
    hi: f64,
) -> DrawResult {
    let parts = titled_page(root, &spec.title, 22)?.split_evenly((1, spec.panels.len().max(1)));
    let np = spec.names.len();
    for ((title, series), area) in spec.panels.iter().zip(parts.iter()) {
        let mut chart = panel(area, title, 80)
            .build_cartesian_2d(-0.6..(np as f64 - 0.4), (lo..hi).log_scale())
            .map_err(|e| e.to_string())?;
        mesh_look(&mut chart.configure_mesh(), 15, 244)
            .disable_x_mesh()
            .x_desc("parameter")
            .y_desc("standard deviation of the estimate (mm)")
            .x_label_formatter(&|_| String::new())
            // Plain decimals (0.001, 0.01, 0.1 mm), not "1e-3".
            .y_label_formatter(&|v| {
                let d = (-v.log10()).ceil().max(0.0) as usize;
                format!("{v:.*}", d.min(8))
            })
            .draw()
            .map_err(|e| e.to_string())?;
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let m = series.len().max(1) as f64;
        for (i, s) in series.iter().enumerate() {
            let col = SERIES[i % SERIES.len()];
            let off = (i as f64 - (m - 1.0) / 2.0) * 0.12;
            chart
                .draw_series(
                    s.mc.iter()
                        .enumerate()
                        .filter(|(_, v)| v.is_finite() && **v > 0.0)
                        .map(|(k, v)| Circle::new((k as f64 + off, *v), 5, col.filled())),
                )
                .map_err(e)?
                .label(format!("{}: Monte-Carlo", s.label))
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, col.filled()));
            chart
                .draw_series(
                    s.predicted
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| v.is_finite() && **v > 0.0)
                        .map(|(k, v)| Cross::new((k as f64 + off, *v), 7, col.stroke_width(2))),
                )
                .map_err(e)?
                .label(format!("{}: linear prediction", s.label))
                .legend(move |(x, y)| Cross::new((x + 10, y), 6, col.stroke_width(2)));
        }
        let ticks: Vec<(f64, String)> = spec
            .names
            .iter()
            .enumerate()
            .map(|(k, n)| (k as f64, n.clone()))
            .collect();
        x_tick_labels(area, &chart, &ticks, lo, 13)?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(RGBColor(160, 160, 160))
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}
