//! The buyer's answer in one paragraph (the verdict): what to buy, what it
//! costs, what accuracy 95 % of machines reach, what was passed over and
//! why, and what the choice rests on.

use super::decision::Confidence;
use super::ranking::RankedRow;
use super::summary::{BudgetRow, GradeSummary};
use crate::identify::Method;

/// The buyer's answer in one paragraph: what to buy, what it costs, what
/// accuracy 95 % of machines reach and which sensor limits it — or, when
/// nothing meets the target, that plainly, with the closest combination.
///
/// `truth` holds the same combinations read by sensors whose curves differ
/// from the datasheet's (`[sweep] truth_amplitude`): the answer says what
/// the choice reaches with them, estimator by estimator.
pub fn buyer_answer(
    ranking: &[RankedRow],
    budget: &[BudgetRow],
    truth: &[GradeSummary],
    trials: u64,
) -> String {
    let Some(first) = ranking.first() else {
        return "No combination was studied.".into();
    };
    let target = format!("{} ≤ {}", first.metric, first.threshold);
    let value = |r: &RankedRow| {
        let v = r.value.map_or("n/a".into(), |v| format!("{v:.4}"));
        let limit = r.metric.upper_limit().unwrap_or(r.metric);
        match (r.confidence, r.upper_limit) {
            (Confidence::Upper95, Some(u)) => format!("{v} ({} {u:.4})", limit.limit_words()),
            (Confidence::Upper95, None) => format!(
                "{v} (no {}: too few machines were computed; it needs at least {}, so 95 % confidence cannot be claimed)",
                limit.limit_words(),
                limit.machines_needed()
            ),
            _ => v,
        }
    };
    let what = first.metric.describe();
    let mut notes = String::new();
    let harmful = ranking
        .iter()
        .filter(|r| r.harms && r.value.is_some_and(|v| v <= r.threshold))
        .count();
    if harmful > 0 {
        notes.push_str(&format!(
            " Not feasible whatever the threshold: {harmful} combination(s) whose calibration leaves the typical machine worse than not calibrating (median μ/μ0 ≥ 1, or median max dV after ≥ before)."
        ));
    }
    let before = ranking
        .iter()
        .filter_map(|r| r.uncalibrated)
        .fold(f64::INFINITY, f64::min);
    if before.is_finite() && first.threshold >= before {
        notes.push_str(&format!(
            " Warning: the target {} ≤ {} is no tighter than what the uncalibrated machines already reach ({before:.4}): check the threshold.",
            first.metric, first.threshold
        ));
    }
    if !first.chosen {
        return format!(
            "No combination meets the target {target} ({} rule, {trials} machines). The closest is {} with {} poses ({}): {what} = {}. decision.csv ranks every combination by how close it comes; other products, pose counts or estimators, or a looser target, are the options.",
            match first.confidence {
                Confidence::Upper95 => first
                    .metric
                    .upper_limit()
                    .unwrap_or(first.metric)
                    .limit_words(),
                Confidence::Estimate => "estimate",
            },
            first.purchase(),
            first.pose_count,
            first.method.name(),
            value(first)
        ) + &notes;
    }
    let price = first
        .price
        .map_or(String::new(), |p| format!(" (total price {p:.0})"));
    let mut text = format!(
        "Buy {}{price} and calibrate with {} poses ({}): {what} = {}, within the target {target} ({trials} machines simulated).",
        first.purchase(),
        first.pose_count,
        first.method.name(),
        value(first)
    );
    // The same sensors with the other pose counts: a larger pose count
    // need not do better (the subsets are different poses).
    let others: Vec<String> = ranking
        .iter()
        .filter(|r| {
            r.row != first.row
                && r.encoder == first.encoder
                && r.scale == first.scale
                && r.encoder_arcsec == first.encoder_arcsec
                && r.scale_um == first.scale_um
                && r.method == first.method
        })
        .map(|r| {
            format!(
                "{} poses {}{}",
                r.pose_count,
                r.value.map_or("n/a".into(), |v| format!("{v:.4}")),
                if r.feasible {
                    ""
                } else {
                    " (misses the target)"
                }
            )
        })
        .collect();
    if !others.is_empty() {
        text.push_str(&format!(
            " The same sensors with other pose counts: {}.",
            others.join(", ")
        ));
    }
    let p = |r: &RankedRow| r.price.unwrap_or(0.0);
    let fragile: Vec<String> = ranking
        .iter()
        .filter(|r| r.fragile && p(r) <= p(first))
        .take(3)
        .map(|r| {
            format!(
                "{} with {} poses ({}, {})",
                r.sensors(),
                r.pose_count,
                r.method.name(),
                r.value.map_or("n/a".into(), |v| format!("{v:.4}"))
            )
        })
        .collect();
    if !fragile.is_empty() {
        text.push_str(&format!(
            " Passed over as fragile (they meet the target with these poses but miss it with more of them, so the pass rests on which poses were picked): {}.",
            fragile.join("; ")
        ));
    }
    if let Some(b) = budget.get(first.row) {
        if b.limiting != "none" {
            text.push_str(&format!(
                " Of its remaining error the {}'s contributes most: with that sensor perfect and the same estimator, mean μ would fall from {:.4} mm to {:.4} mm; what no sensor can fix (linearisation, unidentifiable errors) is {:.4} mm.",
                b.limiting,
                b.mu_mean,
                b.mu_mean - b.limiting_saving(),
                b.floor_mm
            ));
            if first.method == Method::Wls {
                text.push_str(" (With WLS a finer sensor also takes more weight in the fit, so this is not a promise that a finer one does better: compare the combinations in decision.csv.)");
            }
        }
    }
    if first.method == Method::Gls {
        text.push_str(" This rests on the sensors' datasheet model: GLS weights the readings by the error curves the datasheets describe (which harmonics, the interpolation error, the jitter), and a curve of a shape the datasheet omits, or larger white terms, cost part of the gain.");
    }
    text.push_str(&what_if(first, truth));
    text.push_str(&robust_choice(ranking));
    text.push_str(&notes);
    text
}

/// What the chosen sensors and pose count reach when the true curves are
/// other multiples of the datasheet's, each estimator on the same machines.
fn what_if(first: &RankedRow, truth: &[GradeSummary]) -> String {
    let same = |r: &&GradeSummary| {
        r.encoder == first.encoder
            && r.scale == first.scale
            && r.encoder_arcsec == first.encoder_arcsec
            && r.scale_um == first.scale_um
            && r.pose_count == first.pose_count
    };
    let key = |r: &GradeSummary| r.truth.clone();
    let mut amplitudes: Vec<String> = Vec::new();
    for r in truth.iter().filter(same) {
        if !amplitudes.contains(&key(r)) {
            amplitudes.push(key(r));
        }
    }
    let cases: Vec<String> = amplitudes
        .iter()
        .map(|a| {
            let each: Vec<String> = truth
                .iter()
                .filter(same)
                .filter(|r| &key(r) == a)
                .map(|r| {
                    format!(
                        "{} {}{}",
                        r.method.name(),
                        first
                            .metric
                            .value(r)
                            .map_or("n/a".into(), |v| format!("{v:.4}")),
                        if r.meets_target { "" } else { " (misses)" }
                    )
                })
                .collect();
            format!("{a}: {}", each.join(", "))
        })
        .collect();
    if cases.is_empty() {
        return String::new();
    }
    format!(
        " If the true sensors' curves are not the datasheet's, the same sensors and poses reach: {}.",
        cases.join("; ")
    )
}

/// The cheapest feasible combination that also meets the target under
/// every what-if (see [`mark_what_ifs`]; nothing when the study has none).
fn robust_choice(ranking: &[RankedRow]) -> String {
    if ranking.iter().all(|r| r.meets_every_what_if.is_none()) {
        return String::new();
    }
    let robust = ranking
        .iter()
        .find(|r| r.feasible && r.meets_every_what_if == Some(true));
    match robust {
        Some(r) if r.chosen => " It meets the target under every one of them too.".into(),
        Some(r) => format!(
            " The {} combination that meets the target under every one of them too: {} with {} poses ({}){}.",
            if r.price.is_some() { "cheapest" } else { "first-ranked" },
            r.purchase(),
            r.pose_count,
            r.method.name(),
            r.price.map_or(String::new(), |p| format!(", total price {p:.0}"))
        ),
        None => " No combination studied meets the target under every one of them.".into(),
    }
}
