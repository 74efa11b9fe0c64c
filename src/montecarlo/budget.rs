//! The error budget in the deciding metric (`decision_budget.csv`): for the
//! first-ranked combinations of the first-ranked estimator, the same study
//! restricted to that one combination, run again on the same machines and
//! draws with every sensor read exactly (the floor) and with each sensor
//! alone read exactly. The estimator keeps weighting the sensors by their
//! datasheets: the rows say what a perfect sensor would save in the metric
//! the verdict decides on, not what a different purchase would reach.
//!
//! The restricted study reproduces the main study's value of the
//! combination to rounding (same seed, same streams, same pose subset); the
//! budget is computed only for metrics in millimetres (not μ/μ0), and not
//! for Gauss–Newton studies (four more studies of iterated calibrations per
//! combination would cost more than the study itself).

use super::runner::run_alone;
use super::summary::SweepResult;
use crate::config::{Config, ConfigStudy, Truth};
use crate::error::Result;
use crate::metrics::{BudgetRow, DecisionMetric, RankedRow, TermSplit};
use crate::sensors::ErrorTerm;

/// Combinations budgeted in the deciding metric, by rank.
pub const DECISION_BUDGET_ROWS: usize = 8;

/// `study` restricted to the combination of `r` (its products or grades,
/// pose count and estimator), the datasheet truth only, no follow-up
/// studies, `trials` machines and the sensors of `perfect` read exactly.
/// None when the combination cannot be found in the study.
/// `truth`: how the sensors read (the datasheet, or one error term read
/// exactly).
pub fn restricted(
    study: &ConfigStudy,
    r: &RankedRow,
    trials: u64,
    perfect: [bool; 3],
    truth: Truth,
) -> Option<ConfigStudy> {
    let mut sub = study.clone();
    let sw = &mut sub.sweep;
    match &mut sw.products {
        Some(p) => {
            let e = p.encoders.iter().position(|x| x.name == r.encoder)?;
            let s = p.scales.iter().position(|x| x.name == r.scale)?;
            let model = *p.models.get(s * p.encoders.len() + e)?;
            p.encoders = vec![p.encoders[e].clone()];
            p.scales = vec![p.scales[s].clone()];
            p.models = vec![model];
        }
        None => {
            sw.encoder_arcsec = vec![r.encoder_arcsec];
            sw.scale_um = vec![r.scale_um];
        }
    }
    sw.methods = vec![r.method];
    sw.pose_counts = vec![r.pose_count];
    sw.truth = vec![truth];
    sw.second_class_tolerance_deg = Vec::new();
    sw.perfect_sensors = perfect;
    sw.follow_up = true;
    sw.trials = trials;
    Some(sub)
}

/// The deciding metric's value of the one combination of a restricted run
/// (its what-if row when its sensors read otherwise than the datasheet).
fn value_of(metric: DecisionMetric, r: &SweepResult) -> Option<f64> {
    r.summary
        .first()
        .or(r.truth.first())
        .and_then(|s| metric.value(s))
}

/// Add the deciding metric's budget of the first [`DECISION_BUDGET_ROWS`]
/// combinations of the first-ranked estimator to `result.decision_budget`
/// (nothing for a μ/μ0 metric or a Gauss–Newton study).
pub(super) fn add_decision_budget(
    cfg: &Config,
    study: &ConfigStudy,
    result: &mut SweepResult,
    threads: usize,
) -> Result<()> {
    // The metric's point value (not its confidence limit, whose sampling
    // margin is no sensor's), as the ranking reports it.
    let Some(metric) = result.ranking.first().map(|r| r.metric) else {
        return Ok(());
    };
    // A budget's own restricted runs (which read some sensor exactly) and
    // a tolerance's what-if study are not budgeted.
    if study.sweep.perfect_sensors.iter().any(|&p| p)
        || study.sweep.second_class_draw_deg.is_some()
        || metric.is_ratio()
        || study.identification.iterations > 1
        || result.trials == 0
    {
        return Ok(());
    }
    let Some(method) = result.ranking.first().map(|r| r.method) else {
        return Ok(());
    };
    let rows: Vec<RankedRow> = result
        .ranking
        .iter()
        .filter(|r| r.method == method)
        .take(DECISION_BUDGET_ROWS)
        .cloned()
        .collect();
    let mut budget = Vec::with_capacity(rows.len());
    for r in &rows {
        let run = |perfect: [bool; 3], truth: Truth| -> Result<Option<f64>> {
            match restricted(study, r, result.trials, perfect, truth) {
                Some(sub) => Ok(value_of(metric, &run_alone(cfg, &sub, threads)?)),
                None => Ok(None),
            }
        };
        let sensors = |perfect| run(perfect, Truth::DATASHEET);
        let Some(total) = result.summary.get(r.row).and_then(|s| metric.value(s)) else {
            continue;
        };
        let floor = sensors([true; 3])?;
        let without = [
            sensors([true, false, false])?,
            sensors([false, true, false])?,
            sensors([false, false, true])?,
        ];
        let (Some(floor), [Some(a), Some(b), Some(c)]) = (floor, without) else {
            continue;
        };
        let Some(main) = result.budget.get(r.row) else {
            continue;
        };
        // By error term: each term read exactly in every sensor. A term
        // this combination's sensors lack leaves the measure as it is and
        // is not rerun; the paper's white reading is not split.
        let own = restricted(study, r, result.trials, [false; 3], Truth::DATASHEET)
            .map(|sub| sub.sensor_sets(&cfg.sensors));
        let structured = own
            .as_ref()
            .and_then(|sets| sets.first())
            .and_then(|s| s.structured);
        let mut by_term = [total; 4];
        let mut present = [false; 4];
        let mut reruns = 4;
        if let Some(st) = &structured {
            for (k, &t) in ErrorTerm::ALL.iter().enumerate() {
                if st.with_term_exact(t) == *st {
                    continue;
                }
                present[k] = true;
                reruns += 1;
                let truth = Truth {
                    exact_term: Some(t),
                    ..Truth::DATASHEET
                };
                if let Some(v) = run([false; 3], truth)? {
                    by_term[k] = v;
                }
            }
        }
        let term_split = structured.map(|_| TermSplit::from_means(total, floor, by_term, present));
        result.computed += reruns * result.trials;
        result.calibrations += reruns * result.trials;
        budget.push(BudgetRow {
            measure: metric.name(),
            encoder_arcsec: main.encoder_arcsec,
            scale_um: main.scale_um,
            method: main.method,
            pose_count: main.pose_count,
            encoder: main.encoder.clone(),
            scale: main.scale.clone(),
            calibrations: result.trials,
            terms: term_split,
            ..BudgetRow::from_means(total, floor, [a, b, c])
        });
    }
    result.decision_budget = budget;
    Ok(())
}
