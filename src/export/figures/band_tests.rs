//! Tests of [`super`]: kept beside it, out of its file.
use super::*;
use crate::export::figures::band_legend::{label_width, legend_columns, legend_entries, Swatch};

fn chart(band_label: &str) -> (BandChart, Panel) {
    let curve = Curve {
        label: "median".into(),
        band_label: band_label.into(),
        x: vec![1.0],
        mid: vec![1.0],
        lo: vec![1.0],
        hi: vec![1.0],
    };
    let panel = Panel {
        title: String::new(),
        curves: vec![curve.clone(), curve.clone(), curve],
    };
    let spec = BandChart {
        title: String::new(),
        x_desc: String::new(),
        y_desc: String::new(),
        panels: vec![panel.clone()],
        hlines: Vec::new(),
        markers: Vec::new(),
        log_x: false,
    };
    (spec, panel)
}

/// Five curves whose bands overlap, and a target far below the top.
fn crowded() -> BandChart {
    let curve = |k: f64| Curve {
        label: format!("median, scale {k} µm"),
        band_label: format!("95 % of machines below, scale {k} µm"),
        x: vec![1.0, 2.0, 5.0],
        mid: vec![0.05 * k, 0.1 * k, 0.3 * k],
        lo: vec![0.04 * k, 0.08 * k, 0.2 * k],
        hi: vec![0.1 * k, 0.3 * k, 1.2 * k],
    };
    BandChart {
        title: "t".into(),
        x_desc: "x".into(),
        y_desc: "dV (mm)".into(),
        panels: vec![Panel {
            title: "GLS".into(),
            curves: [0.5, 1.0, 2.0, 3.0, 5.0].into_iter().map(curve).collect(),
        }],
        hlines: vec![HLine {
            y: 0.25,
            label: "target".into(),
            dashed: true,
            color: RGBColor(200, 30, 30),
        }],
        markers: Vec::new(),
        log_x: true,
    }
}

/// With band edges no band is a filled area (five overlapping fills
/// were one muddy colour) and the legend shows each as a dashed line.
#[test]
fn band_edges_draw_no_filled_band() {
    let spec = crowded();
    let svg = |style: &BandStyle| {
        String::from_utf8(spec.render_styled(Format::Svg, style).unwrap()).unwrap()
    };
    assert!(svg(&BandStyle::default()).contains("<polygon"));
    let edges = BandStyle {
        band_edges: true,
        ..BandStyle::default()
    };
    assert!(!svg(&edges).contains("<polygon"));
    let dashed = legend_entries(&spec, &spec.panels[0], &edges)
        .iter()
        .filter(|(s, _)| matches!(s, Swatch::Dashed(_)))
        .count();
    assert_eq!(dashed, 5 + 1, "five band edges and the target");
}

/// A log y axis is labelled at round values in the values' unit and the
/// target is tagged with its value.
#[test]
fn log_y_axis_labels_round_values_and_tags_the_target() {
    let spec = crowded();
    let style = BandStyle {
        log_y: true,
        band_edges: true,
        tags: vec![(0.25, "target 0.25 mm".into())],
    };
    let ((y0, y1), ticks) = spec.y_range(&spec.panels[0], &style);
    assert!((y0 - (0.02f64 / 1.25).log10()).abs() < 1e-12, "{y0}");
    assert!((y1 - (6.0f64 * 1.25).log10()).abs() < 1e-12, "{y1}");
    let ticks = ticks.unwrap();
    assert!(ticks.contains(&0.1) && ticks.contains(&1.0), "{ticks:?}");
    let svg = String::from_utf8(spec.render_styled(Format::Svg, &style).unwrap()).unwrap();
    assert!(crate::export::figures::svg_has_text(&svg, "target 0.25 mm"));
    assert!(
        crate::export::figures::svg_has_text(&svg, "0.10")
            && crate::export::figures::svg_has_text(&svg, "1.00")
    );
    assert!(!svg.contains("NaN"));
}

/// A polyline crosses a box when a segment passes through it, not
/// only when a vertex lies in it.
#[test]
fn a_line_through_a_box_crosses_it() {
    let line = [(0, 100), (100, 0)];
    assert!(crosses(&line, (40, 60), (40, 60)));
    assert!(!crosses(&line, (40, 60), (0, 20)));
    assert!(!crosses(&line, (200, 260), (0, 100)));
}

/// A title keeps its size when it fits and shrinks until it does.
#[test]
fn titles_shrink_to_fit_the_figure() {
    use crate::export::figures::title_size;
    assert_eq!(title_size(1240, "Fig. 4", 24), 24);
    let long = "μ/μ0 after self-calibration against encoder grade (20000 trials, random errors ±0.5 mm) — 51 poses, products at their grades";
    let s = title_size(1240, long, 24);
    assert!((12..24).contains(&s), "{s}");
    let w = |size: u32| {
        ("sans-serif", size as f64, FontStyle::Bold)
            .into_font()
            .box_size(long)
            .unwrap()
            .0
    };
    assert!(w(s) + 24 <= 1240 && w(s + 1) + 24 > 1240);
    assert_eq!(title_size(100, long, 24), 12);
}

/// Labels that fit half a panel share a row; longer ones get a row each
/// (a two-panel figure is 620 px a panel: 290 px a column).
#[test]
fn long_legend_labels_take_a_row_each() {
    let (spec, panel) = chart("5–95 %");
    assert_eq!(legend_columns(&spec, &panel, 620, &BandStyle::default()), 2);
    assert_eq!(legend_rows(&spec, &panel, 620, &BandStyle::default()), 3);
    let (spec, panel) = chart("median to 95 % of machines, scale 0.5 µm");
    assert_eq!(legend_columns(&spec, &panel, 620, &BandStyle::default()), 1);
    assert_eq!(legend_rows(&spec, &panel, 620, &BandStyle::default()), 6);
    // The boundary: a label as wide as a column less its swatch.
    let fits = (1..200)
        .take_while(|&n| label_width(&"x".repeat(n)) + 34 <= 290)
        .last()
        .unwrap();
    let (spec, panel) = chart(&"x".repeat(fits));
    assert_eq!(legend_columns(&spec, &panel, 620, &BandStyle::default()), 2);
    let (spec, panel) = chart(&"x".repeat(fits + 1));
    assert_eq!(legend_columns(&spec, &panel, 620, &BandStyle::default()), 1);
    // The font is measured, not guessed: 40 x are wider than 40 i.
    assert!(label_width(&"x".repeat(40)) > label_width(&"i".repeat(40)));
}
