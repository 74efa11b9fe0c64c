//! Views: study results turned into chart inputs (which rows, which
//! series, which labels), kept apart from the drawing in [`super::figures`].

use super::figures::{self as plot, BandChart, Curve, HLine, Panel};
use crate::config::{ErrorDraw, Study};
use crate::model::PARAM_NAMES;
use crate::montecarlo::SweepResult;

/// The sweep's Fig. 4: μ/μ0 median and 5–95 % band against encoder grade.
pub fn sweep_chart(study: &Study, result: &SweepResult) -> BandChart {
    let mut panels = Vec::new();
    for &method in &study.sweep.methods {
        let mut curves = Vec::new();
        for &scale in &study.sweep.scale_um {
            let mut rows: Vec<_> = result
                .summary
                .iter()
                .filter(|r| r.method == method && r.scale_um == scale)
                .collect();
            rows.sort_by(|a, b| a.encoder_arcsec.total_cmp(&b.encoder_arcsec));
            curves.push(Curve {
                label: format!("median, scale {scale} µm"),
                band_label: format!("5–95 %, scale {scale} µm"),
                x: rows.iter().map(|r| r.encoder_arcsec).collect(),
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
                study.decision.metric, study.decision.threshold
            ),
            dashed: true,
            color: plotters::style::RGBColor(200, 30, 30),
        });
    }
    let (lo, hi) = study
        .sweep
        .encoder_arcsec
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    let errors = match study.sweep.errors {
        ErrorDraw::Random => {
            format!("random errors ±{} mm", study.sweep.error_bound_mm)
        }
        ErrorDraw::Fixed => "fixed [errors]".into(),
    };
    BandChart {
        title: format!(
            "μ/μ0 after self-calibration against encoder grade ({} trials, {errors})",
            result.trials
        ),
        x_desc: "encoder grade (arc-seconds)".into(),
        y_desc: "μ / μ0 (residual / uncalibrated)".into(),
        panels,
        hlines,
        markers: vec![],
        log_x: hi / lo >= 10.0,
    }
}

/// Encoder × scale heat map of the decision metric, one panel per method
/// (only when both grade lists have at least two entries).
pub fn grade_map_chart(study: &Study, result: &SweepResult) -> Option<plot::GradeMap> {
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
        title: format!(
            "{metric} by sensor grades (target {metric} ≤ {}, {} trials)",
            study.decision.threshold, result.trials
        ),
        metric: metric.name().to_string(),
        encoder_arcsec: enc_sorted,
        scale_um: sc_sorted,
        panels,
    })
}

/// Predicted against Monte-Carlo standard deviation per parameter, one panel
/// per method, for the finest, a middle and the coarsest encoder grade at the
/// first scale grade.
pub fn parameter_chart(study: &Study, result: &SweepResult) -> plot::ParamChart {
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
                    let rows: Vec<_> = result
                        .parameters
                        .iter()
                        .filter(|p| p.method == *m && p.encoder_arcsec == e && p.scale_um == scale)
                        .collect();
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
        title: format!("Parameter uncertainty: Monte-Carlo spread (●) against linear covariance (✕), {} trials", result.trials),
        names: PARAM_NAMES.iter().map(|s| s.to_string()).collect(),
        panels,
    }
}
