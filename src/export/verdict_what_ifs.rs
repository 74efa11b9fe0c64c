//! The verdict's what-ifs in words: the choice under each truth other than
//! the datasheets', the same at the tolerance it holds to, and the
//! cheapest combination that meets every one of them.

use super::purchase;
use crate::metrics::{GradeSummary, RankedRow};

/// A what-if row's value in the deciding metric, "(misses)" after it when
/// it misses the target.
fn value_and_miss(first: &RankedRow, r: &GradeSummary) -> String {
    format!(
        "{}{}",
        first
            .metric
            .value(r)
            .map_or("n/a".into(), |v| format!("{v:.4}")),
        if r.meets_target { "" } else { " (misses)" }
    )
}

/// Is `r` a second-class tolerance's own row (not a what-if run at that
/// tolerance)?
pub(super) fn is_tolerance_row(r: &GradeSummary, deg: f64) -> bool {
    r.second_class_deg == Some(deg) && r.truth == crate::montecarlo::tolerance::tolerance_label(deg)
}

/// What the chosen sensors and pose count reach when the true curves are
/// other multiples of the datasheet's, each estimator on the same machines.
/// The second string: the same what-ifs at the tolerance the choice holds to.
pub(super) fn what_if(first: &RankedRow, truth: &[GradeSummary]) -> (String, String) {
    let same_at = |r: &GradeSummary| {
        r.encoder == first.encoder
            && r.scale == first.scale
            && r.encoder_arcsec == first.encoder_arcsec
            && r.scale_um == first.scale_um
            && r.pose_count == first.pose_count
            && r.method == first.method
    };
    let same = |r: &&GradeSummary| same_at(r) && r.second_class_deg.is_none();
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
                .map(|r| value_and_miss(first, r))
                .collect();
            format!("{a}: {}", each.join(", "))
        })
        .collect();
    if cases.is_empty() {
        return (String::new(), String::new());
    }
    // The same what-ifs at the tolerance the choice holds to.
    let at: Vec<(f64, String)> = truth
        .iter()
        .filter(|r| r.second_class_deg.is_some_and(|d| !is_tolerance_row(r, d)) && same_at(r))
        .filter_map(|r| {
            let deg = r.second_class_deg?;
            let what = r
                .truth
                .strip_suffix(&format!(
                    ", and {}",
                    crate::montecarlo::tolerance::tolerance_label(deg)
                ))
                .unwrap_or(&r.truth);
            Some((deg, format!("{what}: {}", value_and_miss(first, r))))
        })
        .collect();
    let at_tolerance = match at.first() {
        Some(&(deg, _)) => format!(
            " With the second-class errors also drawn within ±{deg}° (the tolerance it holds to): {}.",
            at.iter().map(|(_, c)| c.as_str()).collect::<Vec<_>>().join("; ")
        ),
        None => String::new(),
    };
    let said = super::super::verdict_words::what_ifs("sensors", first.method.name(), &cases);
    (
        said.map_or(String::new(), |s| format!(" {s}")),
        at_tolerance,
    )
}

/// The cheapest feasible combination that also meets the target under
/// every what-if (see [`mark_what_ifs`]; nothing when the study has none).
pub(super) fn robust_choice(ranking: &[RankedRow]) -> String {
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
            purchase(r),
            r.pose_count,
            r.method.name(),
            r.price.map_or(String::new(), |p| format!(", total price {p:.0}"))
        ),
        None => " No combination studied meets the target under every one of them.".into(),
    }
}
