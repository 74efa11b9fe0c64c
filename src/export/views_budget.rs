//! The error budget's figure (budget.png): which combinations, their parts
//! by sensor, and by error term where the study split it.

use super::super::figures as plot;
use super::combination_label;
use crate::config::ConfigStudy;
use crate::montecarlo::SweepResult;

/// Bars of the error budget drawn at most.
const BUDGET_BARS: usize = 40;

/// The error budget of the combinations of the first-ranked one's
/// estimator, the chosen one first: in the deciding metric, against its
/// target, where the study budgeted it (`decision_budget.csv`), else in mean
/// μ (the first 40 by rank). One estimator's bars, so that a weaker
/// estimator's long bars do not set the scale.
pub fn budget_chart(study: &ConfigStudy, result: &SweepResult) -> plot::BudgetChart {
    let method = result.ranking.first().map(|r| r.method);
    let ranked: Vec<&crate::metrics::RankedRow> = result
        .ranking
        .iter()
        .filter(|r| Some(r.method) == method)
        .collect();
    let same = |r: &crate::metrics::RankedRow, b: &crate::metrics::BudgetRow| {
        r.encoder == b.encoder
            && r.scale == b.scale
            && r.pose_count == b.pose_count
            && r.method == b.method
            && r.encoder_arcsec.to_bits() == b.encoder_arcsec.to_bits()
            && r.scale_um.to_bits() == b.scale_um.to_bits()
    };
    let bar = |r: &crate::metrics::RankedRow, b: &crate::metrics::BudgetRow| plot::BudgetBar {
        label: combination_label(study, r),
        parts: vec![b.floor_mm, b.psi_encoder_mm, b.theta_encoder_mm, b.scale_mm],
        chosen: r.chosen && result.ranking.first().is_some_and(|f| same(f, b)),
    };
    let term_bar = |r: &crate::metrics::RankedRow, b: &crate::metrics::BudgetRow| {
        b.terms.map(|t| {
            let mut parts = vec![b.floor_mm];
            parts.extend(t.shares());
            plot::BudgetBar {
                label: combination_label(study, r),
                parts,
                chosen: r.chosen && result.ranking.first().is_some_and(|f| same(f, b)),
            }
        })
    };
    let d = &study.decision;
    // The point metric the ranking reports (the budget's measure).
    let metric = result.ranking.first().map_or(d.metric, |r| r.metric);
    let (bars, x_desc, threshold, measure, total): (
        Vec<plot::BudgetBar>,
        String,
        _,
        String,
        usize,
    ) = if result.decision_budget.is_empty() {
        let shown = ranked.len().min(BUDGET_BARS);
        (
            ranked[..shown]
                .iter()
                .filter_map(|r| result.budget.get(r.row).map(|b| bar(r, b)))
                .collect(),
            "mean μ after calibration (mm)".to_string(),
            None,
            "in mean μ".to_string(),
            ranked.len(),
        )
    } else {
        (
            result
                .decision_budget
                .iter()
                .filter_map(|b| ranked.iter().find(|r| same(r, b)).map(|r| bar(r, b)))
                .collect(),
            metric.describe().to_string(),
            Some(d.threshold),
            "in the deciding metric".to_string(),
            ranked.len(),
        )
    };
    let more = if total > bars.len() {
        format!(" (first {} of {total} by rank)", bars.len())
    } else {
        String::new()
    };
    // The split by error term of the same bars, where every budgeted bar
    // has one.
    let term_bars: Vec<plot::BudgetBar> = result
        .decision_budget
        .iter()
        .filter_map(|b| {
            ranked
                .iter()
                .find(|r| same(r, b))
                .and_then(|r| term_bar(r, b))
        })
        .collect();
    let floor = "no sensor can fix (linearisation, unidentifiable)";
    let by_term = (!term_bars.is_empty() && term_bars.len() == bars.len()).then(|| {
        Box::new(plot::BudgetChart {
            title: format!(
                "The same, split by error term, each read exactly in every sensor{more}"
            ),
            x_desc: x_desc.clone(),
            threshold,
            parts: std::iter::once(floor)
                .chain(crate::metrics::BUDGET_TERMS)
                .collect(),
            bars: term_bars,
            split_by: "error term",
            by_term: None,
        })
    });
    plot::BudgetChart {
        title: format!(
            "Where the error after calibration comes from, {measure}, {}, {} machines{more}",
            method.map_or("", |m| m.name()).to_uppercase(),
            result.trials
        ),
        x_desc,
        threshold,
        parts: vec![floor, "ψ4 encoder", "θ4 encoder", "scale"],
        bars,
        split_by: "sensor",
        by_term,
    }
}
