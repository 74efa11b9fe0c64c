//! The ranking and the buyer's paragraph written from it, tested together
//! (moved out of metrics/ranking.rs with the prose: metrics never imports
//! export).

use super::*;
use crate::identify::Method;
use crate::metrics::ranking::*;
use crate::metrics::summary::sample_row as row;
use crate::metrics::verdict::SecondClass;
use crate::metrics::{
    Confidence, Decision, DecisionMetric, GradeSummary, IdentifiedAxes, Tolerance,
};

#[test]
fn the_ranking_puts_the_cheapest_feasible_first_then_the_closest() {
    let d = Decision {
        metric: DecisionMetric::MuP95CiHigh,
        estimate: DecisionMetric::MuP95,
        confidence: Confidence::Upper95,
        threshold: 0.1,
    };
    // (price, poses, encoder grade, mu_p95, its upper limit)
    let spec = [
        (900.0, 51, 1.0, 0.05, 0.06), // feasible, dear
        (500.0, 51, 2.0, 0.13, 0.15), // misses beyond doubt (lower 0.11 below)
        (500.0, 17, 2.0, 0.07, 0.09), // passes at 17 poses, fails at 51: fragile
        (500.0, 9, 4.0, 0.06, 0.08),  // feasible, cheap, 9 poses
        (300.0, 9, 8.0, 0.30, 0.35),  // infeasible, far
    ];
    let rows: Vec<GradeSummary> = spec
        .iter()
        .map(|&(price, poses, enc, p95, hi)| {
            let mut r = row(Method::Ols, 0.5, enc, 0.3);
            r.price = Some(price);
            r.pose_count = poses;
            r.mu_p95 = p95;
            r.mu_p95_ci_high = hi;
            r.meets_target = d.meets(&r);
            r
        })
        .collect();
    let mut rows = rows;
    rows[1].lower.mu_p95 = Some(0.11);
    // A miss the study cannot decide on (its interval holds the
    // threshold) makes nothing fragile: the 17 poses are then feasible,
    // after the cheaper 9.
    let mut open = rows.clone();
    (open[1].mu_p95, open[1].mu_p95_ci_high, open[1].lower.mu_p95) = (0.08, 0.12, Some(0.06));
    let ranked = rank_combinations(&d, &open);
    assert!(ranked.iter().all(|r| !r.fragile));
    let order: Vec<usize> = ranked.iter().map(|r| r.row).collect();
    assert_eq!(order, vec![3, 2, 0, 1, 4]);
    let ranked = rank_combinations(&d, &rows);
    let order: Vec<usize> = ranked.iter().map(|r| r.row).collect();
    // The fragile one (2″ at 17 poses) ranks among the infeasible, by
    // its value.
    assert_eq!(order, vec![3, 0, 2, 1, 4]);
    assert_eq!(
        ranked.iter().map(|r| r.rank).collect::<Vec<_>>(),
        vec![1, 2, 3, 4, 5]
    );
    assert!(ranked[0].chosen && !ranked[1].chosen);
    assert_eq!(
        ranked.iter().map(|r| r.feasible).collect::<Vec<_>>(),
        vec![true, true, false, false, false]
    );
    assert_eq!(
        ranked.iter().map(|r| r.fragile).collect::<Vec<_>>(),
        vec![false, false, true, false, false]
    );
    // At the choice's price with more poses the fragile one would not be
    // bought before it, so the choice did not pass it over.
    let text = buyer_answer(&ranked, None, &[], 100);
    assert!(!text.contains("Passed over"), "{text}");
    // Cheaper, it would have been: the paragraph names it.
    let mut cheaper = rows.clone();
    cheaper[2].price = Some(450.0);
    let text = buyer_answer(&rank_combinations(&d, &cheaper), None, &[], 100);
    assert!(
        text.contains(" Passed over as fragile (they meet the target with these poses but, beyond doubt, miss it with more of them, so the pass rests on which poses were picked): 2″ + 0.5 µm with 17 poses (ols, 0.0700)."),
        "{text}"
    );
    assert_eq!(ranked[0].value, Some(0.06));
    assert_eq!(ranked[0].upper_limit, Some(0.08));
    assert_eq!(ranked[0].price, Some(500.0));
    assert_eq!(ranked[0].sensors(), "4″ + 0.5 µm");
    let mut product = ranked[0].clone();
    (product.encoder, product.scale) = ("enc-a".into(), "sc-b".into());
    assert_eq!(product.sensors(), "enc-a + sc-b");
    // Nothing feasible: nothing chosen, closest first.
    let none = Decision {
        threshold: 0.01,
        ..d
    };
    for r in rows.iter_mut() {
        r.meets_target = none.meets(r);
    }
    let ranked = rank_combinations(&none, &rows);
    assert!(ranked.iter().all(|r| !r.chosen && !r.feasible));
    assert_eq!(ranked[0].row, 0);
    let text = buyer_answer(&ranked, None, &[], 100);
    assert!(
        text.starts_with("No combination meets the target μ reached by 95 % of machines ≤ 0.01 mm"),
        "{text}"
    );
}

/// A confidence limit that does not exist at this many machines (empty
/// cell, NaN in the row) never meets the target, and the verdict says
/// that 95 % confidence cannot be claimed and how many machines it needs.
#[test]
fn a_missing_limit_is_never_feasible_and_is_said() {
    let d = Decision {
        metric: DecisionMetric::MuP95CiHigh,
        estimate: DecisionMetric::MuP95,
        confidence: Confidence::Upper95,
        threshold: 0.1,
    };
    let mut r = row(Method::Gls, 0.5, 1.0, 0.3);
    r.mu_p95 = 0.05;
    r.mu_p95_ci_high = f64::NAN;
    r.meets_target = d.meets(&r);
    assert!(!r.meets_target);
    let ranked = rank_combinations(&d, &[r]);
    assert!(!ranked[0].chosen && ranked[0].upper_limit.is_none());
    let text = buyer_answer(&ranked, None, &[], 20);
    assert!(
        text.contains("no upper 95 % confidence limit")
            && text.contains("at least 59")
            && text.contains("95 % confidence cannot be claimed"),
        "{text}"
    );
    // The top of a two-sided interval is a 97.5 % limit and says so.
    assert!(DecisionMetric::RatioP95CiHigh
        .limit_words()
        .starts_with("upper 97.5 %"));
    assert_eq!(DecisionMetric::RatioP95CiHigh.machines_needed(), 72);
    assert_eq!(DecisionMetric::MuMeanCiHigh.machines_needed(), 2);
    assert_eq!(DecisionMetric::DvAfterP95P95CiHigh.machines_needed(), 59);
    assert_eq!(DecisionMetric::MuP95.machines_needed(), 1);
}

/// What-if rows: the verdict quotes those of the choice and names the
/// cheapest combination that meets the target under every one.
#[test]
fn the_answer_reads_the_what_if_rows() {
    let d = Decision {
        metric: DecisionMetric::MuP95,
        estimate: DecisionMetric::MuP95,
        confidence: Confidence::Estimate,
        threshold: 0.1,
    };
    // (price, encoder grade, mu_p95 at 1×, at 2×)
    let spec = [
        (300.0, 8.0, 0.08, 0.2),
        (500.0, 4.0, 0.06, 0.09),
        (900.0, 1.0, 0.05, 0.2),
    ];
    let mut rows = Vec::new();
    let mut truth = Vec::new();
    for &(price, enc, p95, p95_2x) in &spec {
        let mut r = row(Method::Gls, 0.5, enc, 0.3);
        r.price = Some(price);
        r.mu_p95 = p95;
        r.meets_target = d.meets(&r);
        let mut t = r.clone();
        t.truth_amplitude = 2.0;
        t.truth = "curves 2× the datasheet's".into();
        t.mu_p95 = p95_2x;
        t.meets_target = d.meets(&t);
        rows.push(r);
        truth.push(t);
    }
    let mut ranked = rank_combinations(&d, &rows);
    mark_what_ifs(&mut ranked, &truth);
    assert_eq!(ranked[0].row, 0);
    let robust: Vec<Option<bool>> = ranked.iter().map(|r| r.meets_every_what_if).collect();
    assert_eq!(robust, [Some(false), Some(true), Some(false)]);
    let text = buyer_answer(&ranked, None, &truth, 100);
    // Only the choice's own what-if rows (one here), not the others'.
    assert!(
        text.contains(
            "the same sensors, poses and estimator (gls) reach: curves 2× the datasheet's: 0.2000 (misses)."
        ),
        "{text}"
    );
    assert!(
        text.contains("under every one of them too: 2 encoders of grade 4″ and a scale of grade 0.5 µm with 51 poses (gls), total price 500."),
        "{text}"
    );
    // What it assumes is the verdict's (crate::export::verdict), from
    // the study: the paragraph alone does not claim a model.
    assert!(!text.contains("It assumes"));
    let v = verdict(
        &ranked,
        None,
        &truth,
        100,
        &["the sky is blue.".into(), "water is wet.".into()],
        &[],
        None,
    );
    assert!(
        v.text
            .ends_with("It assumes that the sky is blue; and that water is wet."),
        "{}",
        v.text
    );
    // The choice itself robust: said so; none robust: said so.
    truth[0].meets_target = true;
    mark_what_ifs(&mut ranked, &truth);
    let text = buyer_answer(&ranked, None, &truth, 100);
    assert!(
        text.contains("It meets the target under every one of them too."),
        "{text}"
    );
    for t in truth.iter_mut() {
        t.meets_target = false;
    }
    mark_what_ifs(&mut ranked, &truth);
    let text = buyer_answer(&ranked, None, &truth, 100);
    assert!(
        text.contains("No combination studied meets the target under every one"),
        "{text}"
    );
    // Without what-if rows, nothing of it.
    mark_what_ifs(&mut ranked, &[]);
    assert!(ranked.iter().all(|r| r.meets_every_what_if.is_none()));
    let text = buyer_answer(&ranked, None, &[], 100);
    assert!(
        !text.contains("what-if") && !text.contains("every one of them"),
        "{text}"
    );
}

/// A combination that leaves the typical machine worse than not
/// calibrating is never bought, whatever the threshold, and a target
/// the uncalibrated machines already meet is warned about.
#[test]
fn the_verdict_never_buys_harm() {
    let d = Decision {
        metric: DecisionMetric::MuMean,
        estimate: DecisionMetric::MuMean,
        confidence: Confidence::Estimate,
        threshold: 50.0,
    };
    let mut worse = row(Method::Ols, 0.5, 1.0, 0.3);
    worse.ratio_median = 4.97;
    worse.price = Some(100.0);
    let mut dv_worse = row(Method::Ols, 0.5, 2.0, 0.3);
    (
        dv_worse.dv.dv_after_max_median,
        dv_worse.dv.dv_before_max_median,
    ) = (Some(4.64), Some(1.56));
    let mut nan = row(Method::Ols, 0.5, 3.0, 0.3);
    nan.ratio_median = f64::NAN;
    let mut good = row(Method::Ols, 0.5, 4.0, 0.3);
    good.price = Some(900.0);
    (good.dv.dv_after_max_median, good.dv.dv_before_max_median) = (Some(0.2), Some(1.56));
    assert!(worse.harms() && dv_worse.harms() && nan.harms() && !good.harms());
    let mut at_one = good.clone();
    at_one.ratio_median = 1.0;
    assert!(at_one.harms());
    let mut rows = vec![worse, dv_worse, nan, good];
    for r in rows.iter_mut() {
        r.meets_target = d.meets(r);
    }
    assert_eq!(
        rows.iter().map(|r| r.meets_target).collect::<Vec<_>>(),
        [false, false, false, true]
    );
    let ranked = rank_combinations(&d, &rows);
    assert_eq!(ranked[0].row, 3);
    assert!(ranked[0].chosen && !ranked[0].harms);
    assert_eq!(ranked.iter().filter(|r| r.harms).count(), 3);
    let text = buyer_answer(&ranked, None, &[], 100);
    assert!(
        text.contains("Not feasible whatever the threshold: 3 combination(s)"),
        "{text}"
    );
    assert!(
        text.contains("no tighter than what the uncalibrated machines already reach (0.2500)"),
        "{text}"
    );
    // A tight target: no warning.
    let tight = Decision {
        threshold: 0.1,
        ..d
    };
    let ranked = rank_combinations(&tight, &rows);
    let text = buyer_answer(&ranked, None, &[], 100);
    assert!(!text.contains("Warning"), "{text}");
}

/// What identifying the Hooke axes buys, in words: each tolerance's
/// identified value says itself when it misses, and the value without says
/// when it does — never "both" unless both do.
#[test]
fn the_identified_sentence_says_which_side_misses() {
    let d = Decision {
        metric: DecisionMetric::MuP95CiHigh,
        estimate: DecisionMetric::MuP95,
        confidence: Confidence::Upper95,
        threshold: 0.1,
    };
    let mut r = row(Method::Wls, 0.5, 1.0, 0.3);
    r.mu_p95 = 0.05;
    r.mu_p95_ci_high = 0.06;
    r.meets_target = d.meets(&r);
    let ranked = rank_combinations(&d, &[r]);
    let ia = |value: f64, meets: bool| IdentifiedAxes {
        value,
        upper_limit: None,
        meets_target: meets,
    };
    let tol = |deg: f64, value: f64, meets: bool, id: IdentifiedAxes| SecondClass {
        tolerance_deg: deg,
        value: Some(value),
        meets_target: meets,
        cheapest: None,
        identified: Some(id),
    };
    let s = identified_sentence(
        &ranked[0],
        &[
            tol(0.002, 0.0900, true, ia(0.1100, false)),
            tol(0.01, 0.2000, false, ia(0.0950, true)),
        ],
        Some(ia(0.0700, true)),
        None,
    );
    assert!(
        s.contains("0.1100 mm (misses) within ±0.002° (0.0900 without)"),
        "{s}"
    );
    assert!(
        s.contains("0.0950 mm within ±0.01° (0.2000 without, which misses)"),
        "{s}"
    );
    assert!(s.contains("it still misses at ±0.002°"), "{s}");
    assert!(
        s.contains("with exact axes it gives 0.0700 mm against 0.0500 without them"),
        "{s}"
    );
    let limit = IdentifiedAxes {
        upper_limit: Some(0.1234),
        ..ia(0.0990, false)
    };
    let s = identified_sentence(
        &ranked[0],
        &[tol(0.002, 0.09, true, limit)],
        Some(limit),
        None,
    );
    assert!(
        s.contains("0.0990 mm (upper limit 0.1234: misses) within ±0.002°"),
        "{s}"
    );
    assert!(
        s.contains("it gives 0.0990 mm (upper limit 0.1234: misses) against"),
        "{s}"
    );
}

/// The paragraph splits into its parts before each turn, and the parts
/// joined by a space give it back.
#[test]
fn the_verdict_splits_into_its_parts() {
    let text = "Buy this. Of its remaining error the scale. If the true sensors differ: x. It holds if the UP limb's axes hold. Identifying the first Hooke axis's yaw helps. It assumes that all is well.";
    let parts = paragraphs(text);
    assert_eq!(parts.len(), 6, "{parts:?}");
    assert_eq!(parts[0], "Buy this.");
    assert!(parts[5].starts_with("It assumes that"));
    assert_eq!(parts.join(" "), text);
    assert_eq!(paragraphs("Buy this."), vec!["Buy this."]);
}

/// The verdict's caller side: the largest tolerance the choice holds to
/// with the axes identified is the last of an unbroken run from the
/// smallest, and the sentence appears only when every tolerance has its
/// identified value.
#[test]
fn the_verdict_holds_to_the_last_unbroken_identified_tolerance() {
    let d = Decision {
        metric: DecisionMetric::MuP95CiHigh,
        estimate: DecisionMetric::MuP95,
        confidence: Confidence::Upper95,
        threshold: 0.1,
    };
    let mut r = row(Method::Wls, 0.5, 1.0, 0.3);
    r.mu_p95 = 0.05;
    r.mu_p95_ci_high = 0.06;
    r.meets_target = d.meets(&r);
    let ranked = rank_combinations(&d, std::slice::from_ref(&r));
    assert!(ranked[0].chosen);
    let truth: Vec<GradeSummary> = [(0.001, 0.07), (0.002, 0.09), (0.005, 0.3)]
        .iter()
        .map(|&(deg, v)| {
            let mut t = r.clone();
            t.second_class_deg = Some(deg);
            t.truth = crate::montecarlo::tolerance::tolerance_label(deg);
            t.mu_p95 = v;
            t.mu_p95_ci_high = v;
            t.meets_target = d.meets(&t);
            t
        })
        .collect();
    let ia = |value: f64, meets: bool| IdentifiedAxes {
        value,
        upper_limit: Some(value),
        meets_target: meets,
    };
    let tolerances = |ids: [Option<IdentifiedAxes>; 3]| -> Vec<Tolerance> {
        [0.001, 0.002, 0.005]
            .iter()
            .zip(ids)
            .map(|(&deg, identified)| Tolerance {
                deg,
                cheapest: None,
                identified,
                identified_in_study: false,
            })
            .collect()
    };
    let run = |t: &[Tolerance]| verdict(&ranked, None, &truth, 100, &[], t, Some(ia(0.06, true)));
    // Identified: meets, misses, meets — holds to the first only.
    let v = run(&tolerances([
        Some(ia(0.08, true)),
        Some(ia(0.2, false)),
        Some(ia(0.09, true)),
    ]));
    assert_eq!(v.holds_to_deg, Some(0.002));
    assert_eq!(v.identified_holds_to_deg, Some(0.001));
    assert!(v.text.contains("it holds to ±0.001°"), "{}", v.text);
    assert!(v.text.contains("(not identified)"), "{}", v.text);
    // All meet: holds to the largest.
    let v = run(&tolerances([
        Some(ia(0.08, true)),
        Some(ia(0.08, true)),
        Some(ia(0.09, true)),
    ]));
    assert_eq!(v.identified_holds_to_deg, Some(0.005));
    // One tolerance without its rerun: no sentence.
    let v = run(&tolerances([
        Some(ia(0.08, true)),
        None,
        Some(ia(0.09, true)),
    ]));
    assert!(!v.text.contains("second_class = true"), "{}", v.text);
    assert_eq!(v.status, "buy");
    // A choice that misses at every tolerance studied is not bought: the
    // status says so and names the tolerance it would need.
    let tight: Vec<GradeSummary> = truth
        .iter()
        .cloned()
        .map(|mut t| {
            t.mu_p95 = 0.3;
            t.mu_p95_ci_high = 0.3;
            t.meets_target = d.meets(&t);
            t
        })
        .collect();
    let v = verdict(
        &ranked,
        None,
        &tight,
        100,
        &[],
        &tolerances([None, None, None]),
        None,
    );
    assert_eq!(v.status, "none_meets_at_tolerances", "{}", v.text);
    assert!(v.choice.is_none() && v.meets_so_far.is_some());
    assert_eq!(v.holds_to_deg, None);
    assert!(
        v.text
            .starts_with("None meets the target at the second-class tolerances studied")
            && v.text.contains("less than ±0.001° (1.75 µm per 100 mm)"),
        "{}",
        v.text
    );
}

/// A tolerance in µm per 100 mm beside its degrees: tan(0.002°)·100 mm is
/// 3.49 µm; 0.005° is 8.73 µm.
#[test]
fn tolerances_read_in_micrometres_per_100_mm() {
    use crate::export::verdict_parts::per_100_mm;
    assert_eq!(per_100_mm(0.002), " (3.49 µm per 100 mm)");
    assert_eq!(per_100_mm(0.005), " (8.73 µm per 100 mm)");
    assert_eq!(per_100_mm(0.001), " (1.75 µm per 100 mm)");
}

/// A metric without confidence limits (median μ) is decided on its
/// estimate: nothing is undecided. On the estimate rule the choice itself
/// can be undecided, and the lead says so, naming each limit's own
/// confidence (μ p95's lower is the bottom of a two-sided 95 % interval,
/// its upper one-sided 95 %). A combination without an upper limit yet
/// needs at least the machines that give one.
#[test]
fn undecided_needs_limits_and_names_the_choice_among_them() {
    let rows_of = |d: &Decision, values: &[(f64, f64, f64)]| -> Vec<GradeSummary> {
        values
            .iter()
            .map(|&(v, lo, hi)| {
                let mut r = row(Method::Ols, 0.5, 2.0, 0.3);
                (r.mu_median, r.mu_p95, r.mu_p95_ci_high) = (v, v, hi);
                r.lower.mu_p95 = Some(lo);
                r.meets_target = d.meets(&r);
                r
            })
            .collect()
    };
    let median = Decision {
        metric: DecisionMetric::MuMedian,
        estimate: DecisionMetric::MuMedian,
        confidence: Confidence::Estimate,
        threshold: 0.1,
    };
    let ranked = rank_combinations(
        &median,
        &rows_of(&median, &[(0.099, 0.0, 1.0), (0.101, 0.0, 1.0)]),
    );
    assert!(ranked.iter().all(|r| !r.undecided), "{ranked:?}");
    let v = verdict(&ranked, None, &[], 100, &[], &[], None);
    assert_eq!(v.status, "buy", "{}", v.text);
    // μ p95 on its estimate: 0.095 meets 0.1, but its limits hold it.
    let p95 = Decision {
        metric: DecisionMetric::MuP95,
        estimate: DecisionMetric::MuP95,
        confidence: Confidence::Estimate,
        threshold: 0.1,
    };
    let ranked = rank_combinations(&p95, &rows_of(&p95, &[(0.095, 0.08, 0.12)]));
    assert!(ranked[0].chosen && ranked[0].undecided);
    let v = verdict(&ranked, None, &[], 100, &[], &[], None);
    assert_eq!(v.status, "undecided");
    for part in [
        "between their lower and upper confidence limits these combinations, the choice or bought before it, may or may not meet the target",
        "mu_p95 0.0950 mm (lower 97.5 % limit 0.0800 mm, upper 95 % limit 0.1200 mm)",
    ] {
        assert!(v.text.contains(part), "{part}\n{}", v.text);
    }
    // No upper limit yet: the machines that give one (59 for a p95's).
    let mut open = ranked[0].clone();
    open.upper_limit = None;
    assert_eq!(open.machines_to_decide(40), Some(59));
    assert_eq!(open.machines_to_decide(70), Some(71));
}
