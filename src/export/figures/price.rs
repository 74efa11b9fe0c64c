//! Price against accuracy: every combination of a catalogue study, the
//! region that meets the target shaded, the choice labelled.

use super::frame::{legend_strip, mesh_look, titled_page};
use super::{ensure_fonts, plot_err, DrawResult, Format, SERIES};
use crate::error::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// The price axis: what a price is and its unit (the catalogue's prices are
/// in the user's currency, whatever it is).
pub const PRICE_DESC: &str =
    "total sensor price, 2 encoders + 1 scale (catalogue prices, in the catalogue's currency units)";

/// One combination: total price, the deciding value, pose count, feasibility.
#[derive(Debug, Clone)]
pub struct PricePoint {
    pub price: f64,
    pub value: f64,
    pub pose_count: usize,
    pub feasible: bool,
    pub label: String,
    /// Index of the estimator (circle, triangle, square, diamond: see [`marker`]).
    pub method: usize,
}

#[derive(Debug, Clone)]
pub struct PriceChart {
    pub title: String,
    /// What the price axis sums ([`PRICE_DESC`] for the Tricept's sensors).
    pub x_desc: String,
    pub y_desc: String,
    pub threshold: f64,
    pub points: Vec<PricePoint>,
    /// Index of the chosen point (or, when nothing meets the target, of
    /// the closest combination, labelled as such).
    pub chosen: Option<usize>,
    /// The marked point misses the target (nothing meets it).
    pub chosen_misses: bool,
    /// Estimator names, in marker order.
    pub methods: Vec<String>,
    /// What else the target asks, after its value in the legend (e.g.
    /// " and orientation ≤ 20″"; empty when nothing).
    pub also: String,
}

impl PriceChart {
    pub fn render(&self, format: Format) -> Result<Vec<u8>> {
        render!(format, (1100, 790), |root| draw(&root, self))
    }
}

/// 1, 2 and 5 times the powers of ten within [lo, hi] (both > 0).
pub(crate) fn round_log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let mut out = Vec::new();
    let mut decade = 10f64.powi(lo.log10().floor() as i32);
    while decade <= hi {
        for m in [1.0, 2.0, 5.0] {
            let v = m * decade;
            if v >= lo && v <= hi {
                out.push(v);
            }
        }
        decade *= 10.0;
    }
    out
}

/// A round tick's label: as many decimals as it needs, no exponent.
fn tick_text(v: f64) -> String {
    let decimals = (-v.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, spec: &PriceChart) -> DrawResult {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let page = titled_page(root, &spec.title, 20)?;
    let (plot, legend) = legend_strip(&page, 80 + 22 * legend_rows(spec, page.dim_in_pixel().0));
    let fin = |v: f64| v.is_finite();
    let pmax = spec
        .points
        .iter()
        .map(|p| p.price)
        .filter(|v| fin(*v))
        .fold(0.0, f64::max);
    let vals = spec
        .points
        .iter()
        .map(|p| p.value)
        .filter(|v| fin(*v) && *v > 0.0);
    let vmax = vals.clone().fold(spec.threshold, f64::max) * 1.3;
    let vmin = vals.fold(spec.threshold, f64::min) * 0.8;
    let xmax = if pmax > 0.0 { pmax * 1.08 } else { 1.0 };
    let mut chart = ChartBuilder::on(&plot)
        .margin(18)
        .x_label_area_size(50)
        .y_label_area_size(85)
        // log10 of the value on a linear axis, labelled in mm: every tick
        // gets a label, whatever the decades spanned.
        .build_cartesian_2d(0.0..xmax, vmin.log10()..vmax.log10())
        .map_err(e)?;
    // Round ticks on the log axis (1, 2, 5 per decade), drawn here: the
    // axis is log10 of the value on a linear scale, whose own ticks fall
    // on values like 0.63 and 1.6.
    mesh_look(&mut chart.configure_mesh(), 14, 240)
        .x_desc(spec.x_desc.as_str())
        .y_desc(format!("{} (log scale)", spec.y_desc))
        .y_labels(0)
        .disable_y_mesh()
        .x_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(e)?;
    let ticks = round_log_ticks(vmin, vmax);
    for &v in &ticks {
        chart
            .draw_series([PathElement::new(
                vec![(0.0, v.log10()), (xmax, v.log10())],
                RGBColor(200, 200, 200).stroke_width(1),
            )])
            .map_err(e)?;
        let (px, py) = chart.backend_coord(&(0.0, v.log10()));
        let style = ("sans-serif", 14).into_font().into_text_style(root).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Right,
                plotters::style::text_anchor::VPos::Center,
            ),
        );
        root.draw(&Text::new(tick_text(v), (px - 8, py), style))
            .map_err(e)?;
    }
    // The feasible region: at or below the target.
    chart
        .draw_series([Rectangle::new(
            [(0.0, vmin.log10()), (xmax, spec.threshold.log10())],
            RGBColor(44, 160, 44).mix(0.12).filled(),
        )])
        .map_err(e)?;
    chart
        .draw_series([PathElement::new(
            vec![
                (0.0, spec.threshold.log10()),
                (xmax, spec.threshold.log10()),
            ],
            RGBColor(44, 120, 44).stroke_width(2),
        )])
        .map_err(e)?;
    let mut counts: Vec<usize> = spec.points.iter().map(|p| p.pose_count).collect();
    counts.sort_unstable();
    counts.dedup();
    for p in spec
        .points
        .iter()
        .filter(|p| fin(p.price) && fin(p.value) && p.value > 0.0)
    {
        let k = counts.iter().position(|&c| c == p.pose_count).unwrap_or(0);
        let col = SERIES[k % SERIES.len()];
        let style = if p.feasible {
            col.filled()
        } else {
            col.stroke_width(2)
        };
        let at = (p.price, p.value.log10());
        let dx = dodge(p.method, spec.methods.len());
        if p.feasible {
            chart
                .draw_series([
                    EmptyElement::at(at) + Polygon::new(shifted(outline(p.method), dx), style)
                ])
                .map_err(e)?;
        } else {
            chart
                .draw_series([
                    EmptyElement::at(at) + PathElement::new(shifted(closed(p.method), dx), style)
                ])
                .map_err(e)?;
        }
    }
    if let Some(c) = spec.chosen.and_then(|i| spec.points.get(i)) {
        let dx = dodge(c.method, spec.methods.len());
        chart
            .draw_series([EmptyElement::at((c.price, c.value.log10()))
                + Circle::new((dx, 0), 11, BLACK.stroke_width(2))])
            .map_err(e)?;
        let (px, py) = chart.backend_coord(&(c.price, c.value.log10()));
        let (w, h) = plot.dim_in_pixel();
        let text = if spec.chosen_misses {
            format!("closest, misses the target: {}", c.label)
        } else {
            format!("chosen: {}", c.label)
        };
        // DejaVu Sans Bold at 15 px: about 7.4 pixels a character.
        let width = (7.4 * text.chars().count() as f64).ceil() as i32;
        // The plot's origin in the page's pixels: the points' pixels are
        // the page's, the label's the plot's.
        let (ox, oy) = (plot.get_base_pixel().0, plot.get_base_pixel().1);
        let marks: Vec<(i32, i32)> = spec
            .points
            .iter()
            .filter(|p| fin(p.price) && fin(p.value) && p.value > 0.0)
            .map(|p| {
                let (x, y) = chart.backend_coord(&(p.price, p.value.log10()));
                (x + dodge(p.method, spec.methods.len()) - ox, y - oy)
            })
            .collect();
        let centre = (px + dx - ox, py - oy);
        let (x, y) = label_place(centre, (width, 18), (w as i32, h as i32), &marks);
        // A leader from the label's near end to the circle, so that a label
        // moved off its point is still read as that point's.
        let near = match x > centre.0 {
            true => (x - 3, y + 9),
            false => (x + width + 3, y + 9),
        };
        let (vx, vy) = ((centre.0 - near.0) as f64, (centre.1 - near.1) as f64);
        let len = (vx * vx + vy * vy).sqrt();
        if len > 13.0 {
            let stop = (
                centre.0 - (11.0 * vx / len).round() as i32,
                centre.1 - (11.0 * vy / len).round() as i32,
            );
            plot.draw(&PathElement::new(vec![near, stop], BLACK.stroke_width(1)))
                .map_err(e)?;
        }
        plot.draw(&Text::new(
            text,
            (x, y),
            ("sans-serif", 15, FontStyle::Bold).into_font(),
        ))
        .map_err(e)?;
    }
    let font = ("sans-serif", 15).into_font();
    // The pose counts' colours first, as square swatches (a circle is an
    // estimator's marker), in a row of their own.
    let mut x = 24;
    for (k, c) in counts.iter().enumerate() {
        let col = SERIES[k % SERIES.len()];
        legend
            .draw(&Rectangle::new([(x, 16), (x + 12, 28)], col.filled()))
            .map_err(e)?;
        let t = format!("{c} poses");
        legend
            .draw(&Text::new(t, (x + 18, 14), font.clone()))
            .map_err(e)?;
        x += count_step(*c);
    }
    // The markers below them, in columns as wide as the widest entry, a
    // row wrapping where the next would pass the strip's right edge
    // ([`legend_rows`]).
    let (width, _) = legend.dim_in_pixel();
    let column = marker_column(spec);
    let mut y = 22;
    x = 24;
    for (k, m) in spec.methods.iter().enumerate() {
        if x > 24 && x + column > width as i32 {
            x = 24;
            y += 22;
        }
        let step = column;
        let at = (x + 6, 22 + y);
        legend
            .draw(&(EmptyElement::at(at) + PathElement::new(closed(k), BLACK.stroke_width(2))))
            .map_err(e)?;
        legend
            .draw(&Text::new(m.clone(), (x + 18, 14 + y), font.clone()))
            .map_err(e)?;
        x += step;
    }
    legend
        .draw(&Text::new(
            format!(
                "filled: meets the target ≤ {t}{u}{}; hollow: misses it; green band: ≤ {t}{u}",
                spec.also,
                t = spec.threshold,
                u = unit_of(&spec.y_desc),
            ),
            (24, 44 + y),
            font,
        ))
        .map_err(e)?;
    Ok(())
}

/// Pixels a pose count's legend entry takes.
fn count_step(count: usize) -> i32 {
    40 + 9 * format!("{count} poses").chars().count() as i32
}

/// Pixels a marker's legend entry takes.
fn marker_step(name: &str) -> i32 {
    40 + 9 * name.chars().count() as i32
}

/// The legend's rows of entries beyond the first on a strip `width` wide:
/// the pose counts' row, then the markers' rows (columns as wide as the
/// widest entry).
fn legend_rows(spec: &PriceChart, width: u32) -> u32 {
    let column = marker_column(spec);
    let per_row = ((width as i32 - 24) / column.max(1)).max(1) as usize;
    spec.methods.len().div_ceil(per_row) as u32
}

/// The width of the legend's marker columns: the widest entry's.
fn marker_column(spec: &PriceChart) -> i32 {
    spec.methods
        .iter()
        .map(|m| marker_step(m))
        .max()
        .unwrap_or(0)
}

/// Pixels a marker is moved sideways so that estimators at one price do
/// not hide each other: marker `k` of `n`, centred on the price.
fn dodge(k: usize, n: usize) -> i32 {
    (2 * k as i32 - (n as i32 - 1)) * 5
}

/// `points` moved `dx` pixels sideways.
fn shifted(points: Vec<(i32, i32)>, dx: i32) -> Vec<(i32, i32)> {
    points.into_iter().map(|(x, y)| (x + dx, y)).collect()
}

/// Where the chosen point's label goes (its top-left corner, plot pixels):
/// right and above, right and below, left and above or left and below the
/// point at `(px, py)`, whichever keeps `size` inside the plot (`bounds`)
/// and covers the fewest of the other markers (`marks`), the first on a
/// tie.
fn label_place(
    (px, py): (i32, i32),
    (w, h): (i32, i32),
    bounds: (i32, i32),
    marks: &[(i32, i32)],
) -> (i32, i32) {
    let candidates = [
        (px + 16, py - 26),
        (px + 16, py + 12),
        (px - 16 - w, py - 26),
        (px - 16 - w, py + 12),
    ];
    let inside = |&(x, y): &(i32, i32)| x >= 0 && y >= 0 && x + w <= bounds.0 && y + h <= bounds.1;
    // A marker is about 8 pixels from its centre either way.
    let covered = |&(x, y): &(i32, i32)| {
        marks
            .iter()
            .filter(|&&(mx, my)| mx + 8 >= x && mx - 8 <= x + w && my + 8 >= y && my - 8 <= y + h)
            .count()
    };
    candidates
        .iter()
        .filter(|c| inside(c))
        .min_by_key(|c| covered(c))
        .or(candidates.first())
        .copied()
        .unwrap_or((px, py))
}

/// The unit of a value described as "… (mm)", with a leading space; none
/// for a ratio.
fn unit_of(desc: &str) -> &'static str {
    if desc.ends_with("(mm)") {
        " mm"
    } else {
        ""
    }
}

/// The outline of estimator `k`'s marker, pixel offsets from its centre: a
/// circle (a 16-gon), a triangle, a square, then a diamond.
fn outline(k: usize) -> Vec<(i32, i32)> {
    match k {
        0 => (0..16)
            .map(|i| {
                let t = i as f64 * std::f64::consts::TAU / 16.0;
                (
                    (6.5 * t.cos()).round() as i32,
                    (6.5 * t.sin()).round() as i32,
                )
            })
            .collect(),
        1 => vec![(0, -8), (7, 5), (-7, 5)],
        2 => vec![(-6, -6), (6, -6), (6, 6), (-6, 6)],
        _ => vec![(0, -8), (7, 0), (0, 8), (-7, 0)],
    }
}

/// [`outline`] closed (its first point again at the end), to stroke.
fn closed(k: usize) -> Vec<(i32, i32)> {
    let mut v = outline(k);
    v.push(v[0]);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The log axis's ticks are round: 1, 2, 5 per decade, labelled without
    /// trailing noise.
    #[test]
    fn the_log_ticks_are_round() {
        let t = round_log_ticks(0.018, 5.5);
        let labels: Vec<String> = t.iter().map(|v| tick_text(*v)).collect();
        assert_eq!(labels, ["0.02", "0.05", "0.1", "0.2", "0.5", "1", "2", "5"],);
        assert!(round_log_ticks(0.0, 1.0).is_empty());
    }

    /// Estimators at one price sit side by side, centred on it; the
    /// chosen label goes where it stays in the plot and hides the fewest
    /// markers, right and above first.
    #[test]
    fn markers_dodge_and_the_label_finds_free_room() {
        assert_eq!(dodge(0, 1), 0);
        assert_eq!((dodge(0, 2), dodge(1, 2)), (-5, 5));
        assert_eq!((dodge(0, 4), dodge(1, 4), dodge(3, 4)), (-15, -5, 15));
        let (point, size, bounds) = ((500, 300), (200, 18), (1000, 600));
        // Free all round: right and above.
        assert_eq!(label_place(point, size, bounds, &[]), (516, 274));
        // A marker right and above: right and below.
        assert_eq!(label_place(point, size, bounds, &[(600, 280)]), (516, 312));
        // Markers on both right-hand sides: left and above.
        let marks = [(600, 280), (600, 320)];
        assert_eq!(label_place(point, size, bounds, &marks), (284, 274));
        // Near the right edge the right-hand places leave the plot.
        assert_eq!(label_place((900, 300), size, bounds, &[]), (684, 274));
        // Near the top: below.
        assert_eq!(label_place((500, 10), size, bounds, &[]), (516, 22));
        // The pose counts' row, then the markers' rows: four estimators'
        // columns fit three to a 1,000-pixel strip.
        let chart = |methods: &[&str]| PriceChart {
            title: String::new(),
            x_desc: String::new(),
            y_desc: String::new(),
            threshold: 1.0,
            points: Vec::new(),
            chosen: None,
            chosen_misses: false,
            methods: methods.iter().map(|m| m.to_string()).collect(),
            also: String::new(),
        };
        let four = ["two a joint (φ and ψ), linear"; 4];
        assert_eq!(marker_step(four[0]), 40 + 9 * 29);
        assert_eq!(legend_rows(&chart(&four), 1000), 2);
        assert_eq!(legend_rows(&chart(&four[..3]), 1000), 1);
        assert_eq!(legend_rows(&chart(&[]), 1000), 0);
    }

    /// The price axis names its unit and the target its unit (mm).
    #[test]
    fn price_and_target_carry_their_units() {
        let point = |price: f64, value: f64, feasible: bool| PricePoint {
            price,
            value,
            pose_count: 9,
            feasible,
            label: "a + b, 9 poses".into(),
            method: 0,
        };
        let chart = PriceChart {
            title: "t".into(),
            x_desc: PRICE_DESC.into(),
            y_desc: "dV p95 over the workspace, 95 % of machines (mm)".into(),
            threshold: 0.25,
            points: vec![point(2800.0, 0.1, true), point(1600.0, 0.5, false)],
            chosen: Some(0),
            chosen_misses: false,
            methods: vec!["GLS".into()],
            also: String::new(),
        };
        let svg = String::from_utf8(chart.render(Format::Svg).unwrap()).unwrap();
        assert!(
            svg.contains("in the catalogue&apos;s currency units"),
            "no price unit"
        );
        assert!(svg.contains("meets the target ≤ 0.25 mm"));
        assert_eq!(unit_of("mean μ/μ0 across machines"), "");
    }
}
