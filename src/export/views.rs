//! Views: study results turned into chart inputs (which rows, which
//! series, which labels), kept apart from the drawing in [`super::figures`].

use super::figures::{self as plot, BandChart, BandStyle, Curve, HLine, Panel, StyledBand};
use crate::config::{ConfigStudy, ErrorDraw};
use crate::montecarlo::SweepResult;

/// The pose count the figures show: the chosen combination's, or the
/// largest when nothing was chosen; and the words that say which.
fn shown_pose_count(study: &ConfigStudy, result: &SweepResult) -> (usize, String) {
    match result.ranking.iter().find(|r| r.chosen) {
        Some(r) => (
            r.pose_count,
            format!("{} poses (the chosen combination's)", r.pose_count),
        ),
        None => {
            let n = study.sweep.pose_counts.iter().copied().max().unwrap_or(0);
            (n, format!("{n} poses (the largest; nothing chosen)"))
        }
    }
}

/// The grade figures' view of a catalogue or pose-count study: the rows of
/// one pose count ([`shown_pose_count`]: the chosen combination's), the
/// products' accuracy grades as the grade lists (None when the study is a
/// plain grade study already).
fn grade_view(
    study: &ConfigStudy,
    result: &SweepResult,
) -> Option<(ConfigStudy, SweepResult, String)> {
    let sw = &study.sweep;
    if sw.products.is_none() && sw.pose_counts.len() <= 1 {
        return None;
    }
    let (n, shown) = if sw.pose_counts.len() > 1 {
        shown_pose_count(study, result)
    } else {
        let n = sw.pose_counts.first().copied().unwrap_or(0);
        (n, format!("{n} poses"))
    };
    let keep: Vec<usize> = (0..result.summary.len())
        .filter(|&i| result.summary[i].pose_count == n)
        .collect();
    let mut view = study.clone();
    view.sweep.pose_counts = vec![n];

    if let Some(p) = view.sweep.products.take() {
        let distinct = |v: Vec<f64>| {
            let mut out: Vec<f64> = Vec::new();
            for x in v {
                if !out.contains(&x) {
                    out.push(x);
                }
            }
            out
        };
        view.sweep.encoder_arcsec = distinct(p.encoders.iter().map(|e| e.grade).collect());
        view.sweep.scale_um = distinct(p.scales.iter().map(|s| s.grade).collect());
    }
    let mut r = result.clone();
    r.summary = keep.iter().map(|&i| result.summary[i].clone()).collect();
    let per = result.parameters.len() / result.summary.len().max(1);
    r.parameters = keep
        .iter()
        .flat_map(|&i| result.parameters[i * per..(i + 1) * per].iter().cloned())
        .collect();
    let note = format!(
        "{shown}{}",
        if sw.products.is_some() {
            ", products at their grades"
        } else {
            ""
        }
    );
    Some((view, r, note))
}

/// Curves per panel above which bands are drawn as their dashed upper
/// edges: more filled bands overlap into one colour.
const FILLED_BANDS_AT_MOST: usize = 2;

/// The style of a band chart: bands as edges when a panel holds more than
/// [`FILLED_BANDS_AT_MOST`] curves (their legend saying so), the target
/// tagged with its value.
fn band_style(chart: &mut BandChart, target: Option<String>) -> BandStyle {
    let band_edges = chart
        .panels
        .iter()
        .any(|p| p.curves.len() > FILLED_BANDS_AT_MOST);
    if band_edges {
        for c in chart.panels.iter_mut().flat_map(|p| p.curves.iter_mut()) {
            let what = c.band_label.split_once(", ").map_or("", |(_, w)| w);
            c.band_label = format!("95 % of machines below, {what}");
        }
    }
    let tags = target
        .into_iter()
        .filter_map(|t| {
            let h = chart
                .hlines
                .iter()
                .find(|h| h.label.starts_with("target"))?;
            Some((h.y, t))
        })
        .collect();
    BandStyle {
        log_y: false,
        band_edges,
        tags,
    }
}

/// The sweep's Fig. 4: μ/μ0 median and 5–95 % band against encoder grade
/// (bands as their dashed upper edges when a panel has many curves).
pub fn sweep_chart(study: &ConfigStudy, result: &SweepResult) -> StyledBand {
    let mut chart = sweep_band(study, result);
    let d = &study.decision;
    let target = d
        .metric
        .is_ratio()
        .then(|| format!("target {}", d.threshold));
    let style = band_style(&mut chart, target);
    StyledBand { chart, style }
}

/// The data of [`sweep_chart`].
fn sweep_band(study: &ConfigStudy, result: &SweepResult) -> BandChart {
    if let Some((s, r, note)) = grade_view(study, result) {
        let mut c = sweep_band(&s, &r);
        c.title = format!("{} — {note}", c.title);
        return c;
    }
    let sw = &study.sweep;
    // The grade axis is the encoder's, unless the study has one encoder
    // grade and several scale grades: then the scale's.
    let by_scale = sw.encoder_arcsec.len() == 1 && sw.scale_um.len() > 1;
    let mut panels = Vec::new();
    for &method in &sw.methods {
        let mut curves = Vec::new();
        let (series, other) = if by_scale {
            (&sw.encoder_arcsec, "encoder")
        } else {
            (&sw.scale_um, "scale")
        };
        for &fixed in series {
            let mut rows: Vec<_> = result
                .summary
                .iter()
                .filter(|r| {
                    r.method == method
                        && if by_scale {
                            r.encoder_arcsec == fixed
                        } else {
                            r.scale_um == fixed
                        }
                })
                .collect();
            let x = |r: &&crate::metrics::GradeSummary| {
                if by_scale {
                    r.scale_um
                } else {
                    r.encoder_arcsec
                }
            };
            rows.sort_by(|a, b| x(a).total_cmp(&x(b)));
            let unit = if by_scale { "″" } else { " µm" };
            curves.push(Curve {
                label: format!("median, {other} {fixed}{unit}"),
                band_label: format!("5–95 % of machines, {other} {fixed}{unit}"),
                x: rows.iter().map(x).collect(),
                mid: rows.iter().map(|r| r.ratio_median).collect(),
                lo: rows.iter().map(|r| r.ratio_p05).collect(),
                hi: rows.iter().map(|r| r.ratio_p95).collect(),
            });
        }
        panels.push(Panel {
            title: method.title().to_string(),
            curves,
        });
    }
    let mut hlines = vec![HLine {
        y: 1.0,
        label: "μ/μ0 = 1: no better than no calibration".into(),
        dashed: true,
        color: plotters::style::RGBColor(0, 0, 0),
    }];
    if study.decision.metric.is_ratio() {
        hlines.push(HLine {
            y: study.decision.threshold,
            label: format!(
                "target: {} ≤ {}",
                study.decision.metric.describe(),
                study.decision.threshold
            ),
            dashed: true,
            color: plotters::style::RGBColor(200, 30, 30),
        });
    }
    let axis = if by_scale {
        &sw.scale_um
    } else {
        &sw.encoder_arcsec
    };
    let (lo, hi) = axis
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    let (what, x_desc) = if by_scale {
        ("linear-scale grade", "linear-scale grade (µm)")
    } else {
        ("encoder grade", "encoder grade (arc-seconds)")
    };
    let errors = match study.sweep.errors {
        ErrorDraw::Random => {
            format!("random errors ±{} mm", study.sweep.error_bound_mm)
        }
        ErrorDraw::Fixed => "fixed [errors]".into(),
    };
    BandChart {
        title: format!(
            "μ/μ0 after self-calibration against {what} ({} trials, {errors})",
            result.trials
        ),
        x_desc: x_desc.into(),
        y_desc: "μ / μ0 (residual / uncalibrated)".into(),
        panels,
        hlines,
        markers: vec![],
        log_x: hi / lo >= 10.0,
    }
}

/// Encoder × scale heat map of the decision metric, one panel per method
/// (only when both grade lists have at least two entries).
pub fn grade_map_chart(study: &ConfigStudy, result: &SweepResult) -> Option<plot::GradeMap> {
    if let Some((s, r, note)) = grade_view(study, result) {
        return grade_map_chart(&s, &r).map(|mut m| {
            m.title = format!("{} — {note}", m.title);
            m
        });
    }
    let enc = &study.sweep.encoder_arcsec;
    let sc = &study.sweep.scale_um;
    if enc.len() < 2 || sc.len() < 2 {
        return None;
    }
    let mut enc_sorted = enc.clone();
    enc_sorted.sort_by(f64::total_cmp);
    let mut sc_sorted = sc.clone();
    sc_sorted.sort_by(f64::total_cmp);
    let metric = study.decision.metric;
    let panels = study
        .sweep
        .methods
        .iter()
        .map(|m| {
            let cell = |s: f64, e: f64| {
                result
                    .summary
                    .iter()
                    .find(|r| r.method == *m && r.scale_um == s && r.encoder_arcsec == e)
            };
            plot::GradeMapPanel {
                title: m.name().to_uppercase(),
                values: sc_sorted
                    .iter()
                    .map(|&s| {
                        enc_sorted
                            .iter()
                            .map(|&e| cell(s, e).and_then(|r| metric.value(r)).unwrap_or(f64::NAN))
                            .collect()
                    })
                    .collect(),
                feasible: sc_sorted
                    .iter()
                    .map(|&s| {
                        enc_sorted
                            .iter()
                            .map(|&e| cell(s, e).is_some_and(|r| r.meets_target))
                            .collect()
                    })
                    .collect(),
            }
        })
        .collect();
    Some(plot::GradeMap {
        threshold: study.decision.threshold,
        title: format!(
            "Does {} meet ≤ {}? ({} trials)",
            metric.describe(),
            study.decision.threshold,
            result.trials
        ),
        metric: metric.describe().to_string(),
        encoder_arcsec: enc_sorted,
        scale_um: sc_sorted,
        panels,
    })
}

/// Workspace accuracy against grade (sweeps with `volumetric = true`): per
/// machine the 95th percentile of dV after compensation over the workspace
/// grid; the median across machines and the band up to its 95th percentile.
/// The y axis is logarithmic when the values span a decade or more (a
/// 0.2 mm target is then readable beside machines at several mm), and the
/// target is tagged with its value in mm.
pub fn workspace_chart(study: &ConfigStudy, result: &SweepResult) -> Option<StyledBand> {
    let mut chart = workspace_band(study, result)?;
    let d = &study.decision;
    let target = d
        .metric
        .needs_volumetric()
        .then(|| format!("target {} mm", d.threshold));
    let mut style = band_style(&mut chart, target);
    style.log_y = spans_a_decade(&chart);
    Some(StyledBand { chart, style })
}

/// Do the chart's positive values (medians, band tops, reference lines)
/// span a factor of 10 or more?
fn spans_a_decade(chart: &BandChart) -> bool {
    let values: Vec<f64> = chart
        .panels
        .iter()
        .flat_map(|p| p.curves.iter())
        .flat_map(|c| c.mid.iter().chain(&c.hi))
        .chain(chart.hlines.iter().map(|h| &h.y))
        .cloned()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let lo = values.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = values.iter().cloned().fold(0.0, f64::max);
    lo.is_finite() && hi >= 10.0 * lo
}

/// The data of [`workspace_chart`].
fn workspace_band(study: &ConfigStudy, result: &SweepResult) -> Option<BandChart> {
    if let Some((s, r, note)) = grade_view(study, result) {
        return workspace_band(&s, &r).map(|mut c| {
            c.title = format!("{} — {note}", c.title);
            c
        });
    }
    study.sweep.volumetric_step_mm?;
    let mut chart = sweep_band(study, result);
    let by_scale = study.sweep.encoder_arcsec.len() == 1 && study.sweep.scale_um.len() > 1;
    for (panel, &method) in chart.panels.iter_mut().zip(&study.sweep.methods) {
        for c in panel.curves.iter_mut() {
            let rows: Vec<_> =
                c.x.iter()
                    .map(|&x| {
                        result.summary.iter().find(|r| {
                            r.method == method
                                && if by_scale {
                                    r.scale_um == x
                                } else {
                                    r.encoder_arcsec == x
                                }
                                && c.label.ends_with(&if by_scale {
                                    format!("encoder {}″", r.encoder_arcsec)
                                } else {
                                    format!("scale {} µm", r.scale_um)
                                })
                        })
                    })
                    .collect();
            let get = |f: fn(&crate::metrics::GradeSummary) -> Option<f64>| -> Vec<f64> {
                rows.iter()
                    .map(|r| r.and_then(f).unwrap_or(f64::NAN))
                    .collect()
            };
            c.mid = get(|r| r.dv.dv_after_p95_median);
            c.lo = c.mid.clone();
            c.hi = get(|r| r.dv.dv_after_p95_p95);
            c.band_label = c
                .band_label
                .replace("5–95 % of machines", "median to 95 % of machines");
        }
    }
    chart.hlines.clear();
    if study.decision.metric.needs_volumetric() {
        chart.hlines.push(HLine {
            y: study.decision.threshold,
            label: format!(
                "target: {} ≤ {}",
                study.decision.metric.describe(),
                study.decision.threshold
            ),
            dashed: true,
            color: plotters::style::RGBColor(200, 30, 30),
        });
    }
    chart.title = format!(
        "Workspace accuracy after compensation ({} trials)",
        result.trials
    );
    chart.y_desc = "dV after compensation, 95th percentile over the workspace (mm)".into();
    Some(chart)
}

/// Predicted against Monte-Carlo standard deviation per parameter, one panel
/// per method, for the finest, a middle and the coarsest encoder grade at the
/// first scale grade.
pub fn parameter_chart(study: &ConfigStudy, result: &SweepResult) -> plot::ParamChart {
    if let Some((s, r, note)) = grade_view(study, result) {
        let mut c = parameter_chart(&s, &r);
        c.title = format!("{} — {note}", c.title);
        return c;
    }
    let mut enc = study.sweep.encoder_arcsec.clone();
    enc.sort_by(f64::total_cmp);
    let mut pick = vec![enc[0]];
    if enc.len() > 2 {
        pick.push(enc[enc.len() / 2]);
    }
    if enc.len() > 1 {
        pick.push(enc[enc.len() - 1]);
    }
    let scale = study.sweep.scale_um[0];
    let panels = study
        .sweep
        .methods
        .iter()
        .map(|m| {
            let series = pick
                .iter()
                .map(|&e| {
                    let mut rows: Vec<_> = result
                        .parameters
                        .iter()
                        .filter(|p| p.method == *m && p.encoder_arcsec == e && p.scale_um == scale)
                        .collect();
                    // Products of one grade (a one- and a two-head kit):
                    // the first one's parameters, not both end to end.
                    if let Some(first) = rows
                        .first()
                        .map(|p| (p.encoder.clone(), p.scale.clone(), p.pose_count))
                    {
                        rows.retain(|p| {
                            (p.encoder.clone(), p.scale.clone(), p.pose_count) == first
                        });
                    }
                    plot::ParamSeries {
                        label: format!("{e}″"),
                        // An unidentifiable parameter's spread is just the prior: not shown.
                        mc: rows
                            .iter()
                            .map(|p| {
                                if p.identifiable {
                                    p.mc_std_mm
                                } else {
                                    f64::NAN
                                }
                            })
                            .collect(),
                        predicted: rows.iter().map(|p| p.predicted_std_mm).collect(),
                    }
                })
                .collect();
            (
                format!("{}, scale {scale} µm", m.name().to_uppercase()),
                series,
            )
        })
        .collect();
    plot::ParamChart {
        title: format!(
            "Parameter uncertainty: Monte-Carlo spread (●) against linear covariance (✕); encoder grades {} at scale {scale} µm, {} trials",
            pick.iter().map(|e| format!("{e}″")).collect::<Vec<_>>().join(", "),
            result.trials
        ),
        names: parameter_names(result),
        panels,
    }
}

/// The mechanism's error names, in order, as the study's rows give them:
/// the rows of the first combination (each summary row has as many
/// parameter rows, in the mechanism's order, as `grade_view` reads them).
fn parameter_names(result: &SweepResult) -> Vec<String> {
    let per = result.parameters.len() / result.summary.len().max(1);
    result.parameters[..per]
        .iter()
        .map(|p| p.parameter.to_string())
        .collect()
}

/// A combination's name on a figure: its products or grades, pose count
/// and (with several estimators) the estimator.
pub(super) fn combination_label(study: &ConfigStudy, r: &crate::metrics::RankedRow) -> String {
    let method = if study.sweep.methods.len() > 1 {
        format!(", {}", r.method.name())
    } else {
        String::new()
    };
    format!("{}, {} poses{method}", r.sensors(), r.pose_count)
}

#[path = "views_budget.rs"]
mod budget;
pub use budget::budget_chart;

/// Total price against the deciding value for a catalogue study (None
/// without prices).
pub fn price_chart(study: &ConfigStudy, result: &SweepResult) -> Option<plot::PriceChart> {
    study.sweep.products.as_ref()?;
    let d = &study.decision;
    let points: Vec<plot::PricePoint> = result
        .ranking
        .iter()
        .map(|r| plot::PricePoint {
            price: r.price.unwrap_or(f64::NAN),
            value: d.metric.value(&result.summary[r.row]).unwrap_or(f64::NAN),
            pose_count: r.pose_count,
            feasible: r.feasible,
            label: combination_label(study, r),
            method: study
                .sweep
                .methods
                .iter()
                .position(|m| *m == r.method)
                .unwrap_or(0),
        })
        .collect();
    Some(plot::PriceChart {
        title: format!(
            "Sensor price against accuracy, {} machines per combination",
            result.trials
        ),
        x_desc: plot::PRICE_DESC.to_string(),
        y_desc: d.metric.describe().to_string(),
        threshold: d.threshold,
        // The first-ranked combination: the choice, or the closest one.
        chosen: result.ranking.first().map(|_| 0),
        chosen_misses: result.ranking.first().is_some_and(|r| !r.chosen),
        methods: study
            .sweep
            .methods
            .iter()
            .map(|m| m.name().to_uppercase())
            .collect(),
        points,
        also: String::new(),
    })
}
