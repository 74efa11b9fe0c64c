//! The buyer's answer in one paragraph (the verdict): what to buy, what it
//! costs, what accuracy 95 % of machines reach, what was passed over and
//! why, and what the choice rests on — the prose, written from a ranked
//! study into [`Verdict`] (whose data is `metrics/verdict.rs`'s).

use super::verdict_parts::identified_sentence;
pub use super::verdict_parts::paragraphs;
use super::verdict_words::{
    between, harmful as harmful_words, number, other_pose_counts, passed_over, undecided_lead,
    Chosen, Lead, Open, LISTED,
};
use crate::identify::Method;
use crate::metrics::verdict::{Choice, SecondClass, Undecided, WhatIf};
use crate::metrics::{
    BudgetRow, Confidence, DecisionMetric, GradeSummary, IdentifiedAxes, RankedRow, Tolerance,
    Verdict,
};
use crate::montecarlo::SweepResult;

/// The verdict of a finished study, with its paragraph.
pub fn of(result: &SweepResult) -> Verdict {
    verdict(
        &result.ranking,
        result.first_budget(),
        &result.truth,
        result.trials,
        &result.assumptions,
        &result.tolerances,
        result.identified_exact_axes,
    )
}

/// The metric at value `v` in a sentence a buyer signs.
pub fn metric_sentence(metric: DecisionMetric, v: &str) -> String {
    use DecisionMetric as M;
    match metric {
        M::MuMean => format!("mean residual μ across machines {v} mm"),
        M::MuMedian => format!("median residual μ across machines {v} mm"),
        M::MuP95 => format!("95 % of machines with a residual μ within {v} mm"),
        M::RatioMean => format!("on average {v} of the uncalibrated residual left (μ/μ0)"),
        M::RatioMedian => {
            format!("the median machine keeps {v} of its uncalibrated residual (μ/μ0)")
        }
        M::RatioP95 => {
            format!("95 % of machines keep at most {v} of their uncalibrated residual (μ/μ0)")
        }
        M::DvAfterMaxP95 => {
            format!("95 % of machines within {v} mm everywhere in the workspace after compensation")
        }
        M::DvAfterMaxMedian => format!(
            "the median machine within {v} mm everywhere in the workspace after compensation"
        ),
        M::DvAfterMeanMean => {
            format!("a mean position error of {v} mm over the workspace after compensation")
        }
        M::DvAfterP95P95 => {
            format!("95 % of machines within {v} mm over 95 % of the workspace after compensation")
        }
        M::ApAfterMaxP95 => {
            format!("95 % of machines with ISO 9283 accuracy AP within {v} mm at P1–P5")
        }
        _ => format!("{} = {v}", metric.describe()),
    }
}

/// What to buy, in words: catalogue products or grades.
fn purchase(r: &RankedRow) -> String {
    if r.encoder.is_empty() {
        format!(
            "2 encoders of grade {}″ and a scale of grade {} µm",
            r.encoder_arcsec, r.scale_um
        )
    } else {
        format!("2 × {} encoders and one {} scale", r.encoder, r.scale)
    }
}

fn choice(r: &RankedRow) -> Choice {
    Choice {
        encoder: r.encoder.clone(),
        scale: r.scale.clone(),
        encoder_arcsec: r.encoder_arcsec,
        scale_um: r.scale_um,
        price: r.price,
        poses: r.pose_count,
        method: r.method,
        value: r.value,
        upper_limit: r.upper_limit,
        statement: statement(r),
    }
}

/// The one-sided confidences of `r`'s lower and upper limits.
fn confidences(r: &RankedRow) -> (f64, f64) {
    let upper = r.upper_limit_confidence.unwrap_or(0.95);
    (r.metric.lower_confidence().unwrap_or(upper), upper)
}

/// The unit of `r`'s metric in a sentence: " mm", or none for a ratio.
fn unit(r: &RankedRow) -> &'static str {
    match r.metric.describe().ends_with("(mm)") {
        true => " mm",
        false => "",
    }
}

/// The metric of `r` in a sentence a buyer signs: "95 % of machines within
/// 0.101 mm over the workspace, at most 0.105 at 95 % confidence".
fn statement(r: &RankedRow) -> String {
    let v = r.value.map_or("n/a".to_string(), |v| format!("{v:.4}"));
    let unit = unit(r);
    let limit = match (r.confidence, r.upper_limit, r.upper_limit_confidence) {
        (_, Some(u), c) => format!(
            ", at most {u:.4}{unit} at {} % confidence",
            100.0 * c.unwrap_or(0.95)
        ),
        _ => String::new(),
    };
    metric_sentence(r.metric, &v) + &limit
}

/// The verdict from a ranked study (see [`Verdict`]).
pub fn verdict(
    ranking: &[RankedRow],
    budget: Option<&BudgetRow>,
    truth: &[GradeSummary],
    trials: u64,
    assumptions: &[String],
    tolerances: &[Tolerance],
    identified_exact_axes: Option<IdentifiedAxes>,
) -> Verdict {
    let first = ranking.first();
    let chosen = first.filter(|r| r.chosen);
    // What would change the answer: an undecided combination that would be
    // bought before the choice (or any, when nothing is chosen).
    let undecided = crate::metrics::ranking::undecided(ranking);
    let mut status = match (chosen, undecided.is_empty()) {
        (_, false) => "undecided",
        (Some(_), true) => "buy",
        (None, true) => "none_meets",
    };
    let mut text = buyer_answer(ranking, budget, truth, trials);
    let same_as = |c: &RankedRow, r: &GradeSummary| {
        r.encoder == c.encoder
            && r.scale == c.scale
            && r.encoder_arcsec == c.encoder_arcsec
            && r.scale_um == c.scale_um
            && r.pose_count == c.pose_count
            && r.method == c.method
    };
    let second_class: Vec<SecondClass> = tolerances
        .iter()
        .map(|t| {
            let row = chosen.and_then(|c| {
                truth
                    .iter()
                    .find(|r| is_tolerance_row(r, t.deg) && same_as(c, r))
            });
            SecondClass {
                tolerance_deg: t.deg,
                value: row.and_then(|r| chosen.and_then(|c| c.metric.value(r))),
                meets_target: row.is_some_and(|r| r.meets_target),
                cheapest: t.cheapest.as_ref().map(choice),
                identified: t.identified,
            }
        })
        .collect();
    let holds_to_deg = second_class
        .iter()
        .take_while(|s| s.meets_target)
        .last()
        .map(|s| s.tolerance_deg);
    // A choice that misses at every second-class tolerance studied is not
    // one to buy on its word: the status says what it needs.
    if status == "buy" && !second_class.is_empty() && holds_to_deg.is_none() {
        status = "none_meets_at_tolerances";
        text = format!(
            "None meets the target at the second-class tolerances studied: the answer below holds only with the UP limb's Hooke-joint axes and guide within less than ±{}°{}, the smallest studied (tighten the assembly, or study smaller tolerances). {text}",
            second_class[0].tolerance_deg,
            crate::export::verdict_parts::per_100_mm(second_class[0].tolerance_deg)
        );
    }
    if let (Some(_), false) = (chosen, second_class.is_empty()) {
        let v = |s: &SecondClass| s.value.map_or("n/a".into(), |v| format!("{v:.4}"));
        match holds_to_deg {
            Some(d) => text.push_str(&format!(
                " It holds if the UP limb's Hooke-joint axes and guide are within ±{d}°{} (with second-class errors drawn within that: {} mm).",
                crate::export::verdict_parts::per_100_mm(d),
                second_class
                    .iter()
                    .find(|s| s.tolerance_deg == d)
                    .map_or("n/a".into(), v)
            )),
            None => text.push_str(&format!(
                " It needs the UP limb's Hooke-joint axes and guide within less than ±{}°{}, the smallest tolerance studied (there: {}).",
                second_class[0].tolerance_deg,
                crate::export::verdict_parts::per_100_mm(second_class[0].tolerance_deg),
                v(&second_class[0])
            )),
        }
        let beyond: Vec<String> = second_class
            .iter()
            .filter(|s| !s.meets_target)
            .map(|s| format!("±{}°: {} (misses)", s.tolerance_deg, v(s)))
            .collect();
        if !beyond.is_empty() {
            text.push_str(&format!(" Beyond it: {}.", beyond.join(", ")));
        }
    }
    let identified_holds_to_deg = second_class
        .iter()
        .take_while(|s| s.identified.is_some_and(|i| i.meets_target))
        .last()
        .map(|s| s.tolerance_deg);
    if let (Some(c), true) = (chosen, second_class.iter().all(|s| s.identified.is_some())) {
        if !second_class.is_empty() {
            text.push_str(&identified_sentence(
                c,
                &second_class,
                identified_exact_axes,
                identified_holds_to_deg,
            ));
        }
    }
    if !second_class.is_empty() {
        let each: Vec<String> = second_class
            .iter()
            .map(|s| match &s.cheapest {
                Some(c) => format!(
                    "within ±{}°, {} with {} poses ({}){}",
                    s.tolerance_deg,
                    if c.encoder.is_empty() {
                        format!("{}″ + {} µm", c.encoder_arcsec, c.scale_um)
                    } else {
                        format!("{} + {}", c.encoder, c.scale)
                    },
                    c.poses,
                    c.method.name(),
                    c.price.map_or(String::new(), |p| format!(", {p:.0}"))
                ),
                None => format!("within ±{}°, none", s.tolerance_deg),
            })
            .collect();
        text.push_str(&format!(
            " The cheapest combination that meets the target with the second-class errors ({}) {}.",
            if tolerances.iter().any(|t| t.identified_in_study) {
                "the Hooke axes identified"
            } else {
                "not identified"
            },
            each.join("; ")
        ));
    }
    if status == "undecided" {
        let open: Vec<Open> = undecided
            .iter()
            .take(LISTED)
            .map(|r| Open {
                named: format!(
                    "{} with {} poses ({})",
                    r.sensors(),
                    r.pose_count,
                    r.method.name()
                ),
                judged: between(
                    r.metric.name(),
                    (r.value, r.lower_limit, r.upper_limit),
                    (unit(r), 4),
                    confidences(r),
                ),
                machines: r.machines_to_decide(trials),
            })
            .collect();
        // The limits' confidences, where the lower's and the upper's agree.
        let shared = first
            .map(confidences)
            .filter(|(lower, upper)| lower == upper)
            .map(|(_, upper)| upper);
        let lead = Lead {
            trials,
            confidence: shared,
            chosen: match chosen {
                None => Chosen::None,
                // Chosen on its estimate, it may itself be undecided.
                Some(c) if undecided.iter().any(|r| r.row == c.row) => Chosen::Among,
                Some(_) => Chosen::Before,
            },
            most: crate::config::MAX_TRIALS,
            how: "--trials, or sweep.until_decided = true",
        };
        if let Some(lead) = undecided_lead(lead, &open, undecided.len()) {
            text = format!("{lead} {text}");
        }
    }
    if !assumptions.is_empty() {
        let clauses: Vec<&str> = assumptions
            .iter()
            .map(|a| a.trim_end_matches('.'))
            .collect();
        let (last, rest) = clauses.split_last().expect("not empty");
        text.push_str(" It assumes that ");
        if !rest.is_empty() {
            text.push_str(&rest.join("; that "));
            text.push_str("; and that ");
        }
        text.push_str(last);
        text.push('.');
    }
    // The choice's what-ifs: as the datasheets' alternatives (`at_tolerance`
    // false), or the same with the second-class errors within the
    // tolerance the choice holds to (both met together on a real machine).
    let what_ifs_of = |at_tolerance: bool| -> Vec<WhatIf> {
        let Some(c) = chosen else {
            return Vec::new();
        };
        truth
            .iter()
            .filter(|r| {
                let at = r.second_class_deg.is_some_and(|d| !is_tolerance_row(r, d));
                let plain = r.second_class_deg.is_none();
                same_as(c, r) && if at_tolerance { at } else { plain }
            })
            .map(|r| WhatIf {
                truth: r.truth.clone(),
                value: c.metric.value(r),
                meets_target: r.meets_target,
            })
            .collect()
    };
    let (what_ifs, what_ifs_at_tolerance) = (what_ifs_of(false), what_ifs_of(true));
    Verdict {
        status,
        choice: chosen.filter(|_| status == "buy").map(choice),
        meets_so_far: chosen.filter(|_| status != "buy").map(choice),
        undecided: undecided
            .iter()
            .map(|r| Undecided {
                sensors: r.sensors(),
                price: r.price,
                poses: r.pose_count,
                method: r.method,
                value: r.value,
                lower_limit: r.lower_limit,
                upper_limit: r.upper_limit,
                machines_to_decide: r.machines_to_decide(trials),
            })
            .collect(),
        machines: trials,
        metric: first.map_or(String::new(), |r| r.metric.describe().to_string()),
        threshold: first.map_or(0.0, |r| r.threshold),
        assumptions: assumptions.to_vec(),
        what_ifs,
        what_ifs_at_tolerance,
        second_class,
        holds_to_deg,
        identified_exact_axes,
        identified_holds_to_deg,
        budget: budget.cloned(),
        budget_terms: budget.and_then(|b| b.terms),
        text,
    }
}

/// The buyer's answer in one paragraph: what to buy, what it costs, what
/// accuracy 95 % of machines reach and which sensor limits it — or, when
/// nothing meets the target, that plainly, with the closest combination.
///
/// `truth` holds the same combinations read by sensors whose curves differ
/// from the datasheet's (`[sweep] truth_amplitude`): the answer says what
/// the choice reaches with them, estimator by estimator.
pub fn buyer_answer(
    ranking: &[RankedRow],
    budget: Option<&BudgetRow>,
    truth: &[GradeSummary],
    trials: u64,
) -> String {
    let Some(first) = ranking.first() else {
        return "No combination was studied.".into();
    };
    let target = format!(
        "{} ≤ {}{}",
        first.metric.describe().trim_end_matches(" (mm)"),
        first.threshold,
        if first.metric.describe().ends_with("(mm)") {
            " mm"
        } else {
            ""
        }
    );
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
    if let Some(words) = harmful_words(harmful, "median μ/μ0 ≥ 1, or median max dV after ≥ before")
    {
        notes.push(' ');
        notes.push_str(&words);
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
            purchase(first),
            first.pose_count,
            first.method.name(),
            value(first)
        ) + &notes;
    }
    let price = first
        .price
        .map_or(String::new(), |p| format!(" (total price {p:.0})"));
    let mut text = format!(
        "Buy {}{price} and calibrate with {} poses ({}): {}; the target is {target} ({trials} machines simulated).",
        purchase(first),
        first.pose_count,
        first.method.name(),
        statement(first)
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
    if let Some(words) = other_pose_counts("sensors", &others) {
        text.push(' ');
        text.push_str(&words);
    }
    // The fragile combinations bought before the choice, passed over.
    let fragile: Vec<&RankedRow> = ranking
        .iter()
        .filter(|r| r.fragile && r.cheaper_than(first))
        .collect();
    let listed: Vec<String> = fragile
        .iter()
        .take(LISTED)
        .map(|r| {
            format!(
                "{} with {} poses ({}, {})",
                r.sensors(),
                r.pose_count,
                r.method.name(),
                number(r.value, 4)
            )
        })
        .collect();
    if let Some(words) = passed_over(&listed, fragile.len()) {
        text.push(' ');
        text.push_str(&words);
    }
    if let Some(b) = budget {
        if b.limiting != "none" {
            let measure = if b.measure == "mu_mean" {
                "mean μ".to_string()
            } else {
                first
                    .metric
                    .describe()
                    .trim_end_matches(" (mm)")
                    .to_string()
            };
            text.push_str(&format!(
                " Of its remaining error the {}'s contributes most: with that sensor read exactly and the same estimator, {measure} would fall from {:.4} mm to {:.4} mm; what no sensor can fix (linearisation, unidentifiable errors) is {:.4} mm.",
                b.limiting,
                b.total_mm,
                b.total_mm - b.limiting_saving(),
                b.floor_mm
            ));
            if first.method == Method::Wls {
                text.push_str(" (With WLS a finer sensor also takes more weight in the fit, so this is not a promise that a finer one does better: compare the combinations in decision.csv.)");
            }
        }
        if let Some(t) = b.terms.filter(|t| t.limiting_term != "none") {
            // Only the terms these sensors have (an integral bearing has no
            // eccentricity to quote).
            let parts: Vec<String> = crate::metrics::BUDGET_TERMS
                .iter()
                .zip(t.shares())
                .zip(t.present)
                .filter(|(_, present)| *present)
                .map(|((name, share), _)| format!("{name} {share:.4}"))
                .collect();
            text.push_str(&format!(
                " Split across all three sensors by error term instead, the {} contributes most: read exactly in every sensor, the same would fall to {:.4} mm ({} mm of the {:.4} mm the sensors add).",
                t.limiting_term,
                b.total_mm - t.limiting_saving(),
                parts.join(", "),
                (b.total_mm - b.floor_mm).max(0.0)
            ));
        }
    }
    // The what-ifs, then whether a combination meets them all (which reads
    // the what-ifs alone), then the same what-ifs at the tolerance.
    let (plain, at_tolerance) = what_if(first, truth);
    text.push_str(&plain);
    text.push_str(&robust_choice(ranking));
    text.push_str(&at_tolerance);
    text.push_str(&notes);
    text
}

#[path = "verdict_what_ifs.rs"]
mod what_ifs;
use what_ifs::{is_tolerance_row, robust_choice, what_if};

#[cfg(test)]
#[path = "verdict_tests.rs"]
mod tests;
