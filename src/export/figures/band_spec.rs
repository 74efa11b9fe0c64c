//! What a band chart shows (its curves, panels, reference lines, marks)
//! and how it is styled: the data that `band.rs` draws and
//! `band_legend.rs` lists, so neither imports the other's types.

use plotters::style::RGBColor;

/// One curve with a band (e.g. median and 5–95 % quantiles).
#[derive(Debug, Clone)]
pub struct Curve {
    pub label: String,
    pub band_label: String,
    pub x: Vec<f64>,
    pub mid: Vec<f64>,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

/// A horizontal reference line.
#[derive(Debug, Clone)]
pub struct HLine {
    pub y: f64,
    pub label: String,
    pub dashed: bool,
    pub color: RGBColor,
}

/// A marked point.
#[derive(Debug, Clone)]
pub struct Marker {
    pub x: f64,
    pub y: f64,
    pub label: String,
}

/// One panel of a [`BandChart`].
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub curves: Vec<Curve>,
}

/// Curves with bands against a grade axis: Fig. 4 and its variants. Several
/// panels share the y axis (e.g. one per estimator).
#[derive(Debug, Clone)]
pub struct BandChart {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub panels: Vec<Panel>,
    pub hlines: Vec<HLine>,
    pub markers: Vec<Marker>,
    /// Logarithmic x axis (use when the grades span a decade or more).
    pub log_x: bool,
}

/// How a [`BandChart`] is drawn beyond its data (the defaults draw it as
/// the paper's Fig. 4: linear y, filled bands).
#[derive(Debug, Clone, Default)]
pub struct BandStyle {
    /// Logarithmic y axis labelled at round values (for values spanning a
    /// decade or more, so a small target is not a few pixels above zero).
    pub log_y: bool,
    /// Each band drawn as its upper edge (a dashed line of the curve's
    /// colour) instead of a filled area: for panels of many curves, whose
    /// filled bands would overlap into one colour.
    pub band_edges: bool,
    /// Labels written on the plot just above the right end of a reference
    /// line: (y, text), e.g. the target's value and unit.
    pub tags: Vec<(f64, String)>,
}
