//! The error budget: per combination, the deciding metric (or mean μ) split
//! into what no sensor can fix and each sensor's share (horizontal stacked
//! bars, the target as a dashed line, legend below); where the study split
//! it by error term too, a second panel below with each term's share.

use super::frame::{legend_strip, mesh_look, titled_page};
use super::{ensure_fonts, plot_err, DrawResult, Format};
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One bar: its label and the stacked parts (mm), in [`BudgetChart::parts`] order.
#[derive(Debug, Clone)]
pub struct BudgetBar {
    pub label: String,
    pub parts: Vec<f64>,
    /// Drawn in bold: the chosen combination.
    pub chosen: bool,
}

#[derive(Debug, Clone)]
pub struct BudgetChart {
    pub title: String,
    /// The x axis: the measure in words, with its unit.
    pub x_desc: String,
    /// The target on that axis, drawn as a dashed line (None: no line).
    pub threshold: Option<f64>,
    pub parts: Vec<&'static str>,
    pub bars: Vec<BudgetBar>,
    /// What the parts after the first are: "sensor" or "error term" (the
    /// legend's note says how that part is split).
    pub split_by: &'static str,
    /// The same bars split by error term, drawn as a second panel below
    /// (its own title, legend and note).
    pub by_term: Option<Box<BudgetChart>>,
}

/// The floor, then the sensors (ψ4 encoder, θ4 encoder, scale).
const SENSOR_COLOURS: [RGBColor; 4] = [
    RGBColor(150, 150, 150),
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
];

/// The floor, then the error terms, in colours none of the sensors has
/// (two panels must not share a colour for different things).
const TERM_COLOURS: [RGBColor; 5] = [
    RGBColor(150, 150, 150),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(148, 103, 189),
    RGBColor(188, 189, 34),
];

impl BudgetChart {
    fn colour(&self, k: usize) -> RGBColor {
        let c: &[RGBColor] = match self.split_by {
            "sensor" => &SENSOR_COLOURS,
            _ => &TERM_COLOURS,
        };
        c[k % c.len()]
    }
}

impl BudgetChart {
    /// One panel's height, px.
    fn height(&self) -> u32 {
        220 + 30 * self.bars.len().max(1) as u32
    }

    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        let h = self.height() + self.by_term.as_ref().map_or(0, |t| t.height());
        render!(format, (1100, h), |root| draw_panels(&root, self))
    }
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    spec: &BudgetChart,
) -> DrawResult {
    match &spec.by_term {
        None => draw(root, spec),
        Some(t) => {
            let (top, bottom) = root.split_vertically(spec.height());
            draw(&top, spec)?;
            draw(&bottom, t)
        }
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, spec: &BudgetChart) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (plot, legend) = legend_strip(&titled_page(root, &spec.title, 20)?, 80);
    let n = spec.bars.len().max(1);
    let max = spec
        .bars
        .iter()
        .map(|b| b.parts.iter().filter(|v| v.is_finite()).sum::<f64>())
        .fold(0.0, f64::max)
        .max(spec.threshold.filter(|t| t.is_finite()).unwrap_or(0.0));
    let xmax = if max > 0.0 { max * 1.08 } else { 1.0 };
    let mut chart = ChartBuilder::on(&plot)
        .margin(14)
        .x_label_area_size(45)
        .y_label_area_size(330)
        .build_cartesian_2d(0.0..xmax, -0.5..(n as f64 - 0.5))
        .map_err(e)?;
    let labels: Vec<String> = spec.bars.iter().map(|b| b.label.clone()).collect();
    mesh_look(&mut chart.configure_mesh(), 14, 240)
        .disable_y_mesh()
        .x_desc(spec.x_desc.as_str())
        .y_labels(n)
        .y_label_formatter(&|y| {
            let k = y.round();
            if (y - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < labels.len() {
                labels[n - 1 - k as usize].clone()
            } else {
                String::new()
            }
        })
        .x_label_formatter(&|v| format!("{v:.3}"))
        .draw()
        .map_err(e)?;
    for (i, bar) in spec.bars.iter().enumerate() {
        let y = (n - 1 - i) as f64;
        let mut x0 = 0.0;
        for (k, &v) in bar.parts.iter().enumerate() {
            if !(v.is_finite() && v > 0.0) {
                continue;
            }
            let style = spec.colour(k).filled();
            chart
                .draw_series([Rectangle::new([(x0, y - 0.35), (x0 + v, y + 0.35)], style)])
                .map_err(e)?;
            x0 += v;
        }
        if bar.chosen {
            chart
                .draw_series([Rectangle::new(
                    [(0.0, y - 0.42), (x0, y + 0.42)],
                    BLACK.stroke_width(2),
                )])
                .map_err(e)?;
        }
    }
    if let Some(t) = spec.threshold.filter(|t| t.is_finite() && *t > 0.0) {
        let red = RGBColor(200, 30, 30);
        chart
            .draw_series(DashedLineSeries::new(
                [(t, -0.5), (t, n as f64 - 0.5)],
                8,
                5,
                red.stroke_width(2),
            ))
            .map_err(e)?;
    }
    // Legend below the plot, clear of the bars.
    let font = ("sans-serif", 15).into_font();
    let mut x = 30;
    for (k, name) in spec.parts.iter().enumerate() {
        legend
            .draw(&Rectangle::new(
                [(x, 14), (x + 22, 30)],
                spec.colour(k).filled(),
            ))
            .map_err(e)?;
        legend
            .draw(&Text::new(name.to_string(), (x + 30, 14), font.clone()))
            .map_err(e)?;
        x += 50 + 8 * name.chars().count() as i32;
    }
    legend
        .draw(&Text::new(note(spec), (30, 46), font.clone()))
        .map_err(e)?;
    Ok(())
}

/// The line under the legend: how the sensors' part is split, and what the
/// black outline means when a bar has one (only when a combination was
/// chosen).
fn note(spec: &BudgetChart) -> String {
    let split = match spec.split_by {
        "sensor" => {
            "the sensors' part is split in proportion to what each sensor, made perfect, would save"
        }
        _ => "the sensors' part is split in proportion to what each term, read exactly, would save",
    };
    let target = if spec.threshold.is_some_and(|t| t.is_finite() && t > 0.0) {
        "; red dashes: the target"
    } else {
        ""
    };
    if spec.bars.iter().any(|b| b.chosen) {
        format!("black outline: the chosen combination; {split}{target}")
    } else {
        format!("nothing was chosen; {split}{target}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(chosen: bool) -> BudgetChart {
        let bar = |chosen: bool| BudgetBar {
            label: "a + b, 9 poses".into(),
            parts: vec![0.01, 0.02, 0.01, 0.03],
            chosen,
        };
        BudgetChart {
            title: "t".into(),
            x_desc: "mean μ after calibration (mm)".into(),
            threshold: None,
            parts: vec!["floor", "ψ4 encoder", "θ4 encoder", "scale"],
            bars: vec![bar(chosen), bar(false)],
            split_by: "sensor",
            by_term: None,
        }
    }

    /// The legend mentions the chosen outline only when a bar has it.
    #[test]
    fn the_chosen_outline_is_in_the_legend_only_when_drawn() {
        let svg = |c: bool| String::from_utf8(chart(c).render(Format::Svg).unwrap()).unwrap();
        assert!(svg(true).contains("black outline: the chosen combination"));
        let none = svg(false);
        assert!(
            !none.contains("chosen combination"),
            "legend names an outline nobody has"
        );
        assert!(none.contains("nothing was chosen"));
    }

    /// A split by error term is drawn as a second panel with its own
    /// legend and note.
    #[test]
    fn the_term_split_is_a_second_panel() {
        let mut c = chart(true);
        let mut t = chart(true);
        t.title = "by error term".into();
        t.parts = vec![
            "floor",
            "curve",
            "eccentricity",
            "interpolation error",
            "jitter",
        ];
        t.split_by = "error term";
        c.by_term = Some(Box::new(t));
        let svg = String::from_utf8(c.render(Format::Svg).unwrap()).unwrap();
        assert!(svg.contains("by error term"));
        assert!(svg.contains("interpolation error"));
        assert!(svg.contains("what each term, read exactly, would save"));
        assert!(svg.contains("what each sensor, made perfect, would save"));
        let one = String::from_utf8(chart(true).render(Format::Svg).unwrap()).unwrap();
        assert!(!one.contains("error term"));
    }
}
