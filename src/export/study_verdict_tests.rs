//! The verdict of a mechanism's study against rows whose answers are
//! known: each statistic against its definition, the choice rule's every
//! tie-break, and the sentence's three cases.

use super::*;
use crate::config::general::Sensor;
use crate::mechanism::hexapod::{Encoders, Hexapod};
use crate::sensors::{Axis, ARCSEC_PER_RAD};
use nalgebra::Vector3;

/// Two catalogue encoders (the second coarser and cheaper) on the
/// hexapod, one or two a joint, 12 or 30 poses, every estimator.
fn spec() -> SpecOf<Hexapod> {
    spec_of(
        vec![Encoders::Both, Encoders::First],
        vec![12, 30],
        vec![Estimator::Linear, Estimator::Gls, Estimator::GaussNewton],
    )
}

/// The two encoders' study of any mechanism's `variants`, pose counts and
/// estimators (no workspace: the verdict reads only the rows).
fn spec_of<T, V>(
    variants: Vec<V>,
    pose_counts: Vec<usize>,
    estimators: Vec<Estimator>,
) -> Spec<T, V> {
    let sensor = |name: &str, price: f64, accuracy_arcsec: f64| Sensor {
        name: name.into(),
        price: Some(price),
        axis: Axis {
            accuracy: accuracy_arcsec / ARCSEC_PER_RAD,
            ..Axis::default()
        },
        truth: None,
    };
    Spec {
        sensors: vec![sensor("fine", 500.0, 1.0), sensor("coarse", 200.0, 5.0)],
        variants,
        pose_counts,
        estimators,
        trials: 40,
        seed: 1,
        length_bound_mm: 0.1,
        zero_bound_deg: 0.02,
        samples: 1,
        workspace: Vec::new(),
        tool_mm: Vector3::zeros(),
        iterations: 5,
        fixed: Vec::new(),
        prior_std_mm: None,
        prior_std_deg: None,
    }
}

fn study(position_mm: Option<f64>) -> Study<Hexapod> {
    StudyConfig {
        spec: spec(),
        until_decided: None,
        what_ifs: Vec::new(),
        position_mm,
        orientation_arcsec: None,
    }
}

/// A row that meets (or not) at price `price` with upper limit `upper`.
fn row(
    (sensor, variant, poses, estimator): (usize, Encoders, usize, Estimator),
    price: Option<f64>,
    upper: f64,
    meets: bool,
) -> RowOf<Hexapod> {
    Row {
        c: Combination {
            sensor,
            variant,
            poses,
            estimator,
        },
        price,
        position_before_median: 0.3,
        position_median: upper / 2.0,
        position_p95: upper * 0.9,
        position_p95_upper: Some(upper),
        position_p95_lower: Some(upper * 0.8),
        orientation_median: 5.0,
        orientation_p95: 10.0,
        orientation_p95_upper: Some(11.0),
        orientation_p95_lower: Some(9.0),
        meets: Some(meets),
        clear_miss: false,
    }
}

/// A row's statistics are their definitions over its machines: medians
/// and 95th percentiles of the sorted column, the p95's upper limit the
/// order statistic `quantile_upper95` names; it meets the target exactly
/// when that limit (and the orientation's, where one is asked) is
/// within it, and no target leaves it unjudged.
#[test]
fn a_rows_statistics_and_its_target_are_their_definitions() {
    // 200 machines, two combinations: the second's errors are the
    // first's doubled, its column read by its index.
    let judged: Vec<Vec<Judged>> = (0..200)
        .map(|k| {
            let x = ((k * 73) % 200) as f64 + 1.0;
            let one = Judged {
                position_before: 10.0 * x,
                position_after: x * 1e-3,
                orientation_before: 100.0 * x,
                orientation_after: x * 0.1,
            };
            let two = Judged {
                position_after: 2.0 * one.position_after,
                orientation_after: 2.0 * one.orientation_after,
                ..one
            };
            vec![one, two]
        })
        .collect();
    let c = Combination {
        sensor: 0,
        variant: Encoders::Both,
        poses: 12,
        estimator: Estimator::Gls,
    };
    let mut s = study(Some(1.0));
    let r = row_of(&judged, 1, &c, Some(7.0), &s);
    let sorted: Vec<f64> = (1..=200).map(|x| 2e-3 * x as f64).collect();
    let upper = quantile_upper95(&sorted, 0.95).unwrap();
    assert_eq!(r.position_median, quantile_sorted(&sorted, 0.5));
    assert_eq!(r.position_p95, quantile_sorted(&sorted, 0.95));
    assert_eq!(r.position_p95_upper, Some(upper));
    assert!(upper > r.position_p95);
    // The lower limit: the order statistic `quantile_lower95` names.
    let lower = crate::metrics::stats::quantile_lower95(&sorted, 0.95).unwrap();
    assert_eq!(r.position_p95_lower, Some(lower));
    assert!(lower < r.position_p95);
    assert_eq!(r.orientation_p95_lower, Some(100.0 * lower));
    let before: Vec<f64> = (1..=200).map(|x| 10.0 * x as f64).collect();
    assert_eq!(r.position_before_median, quantile_sorted(&before, 0.5));
    assert_eq!(r.orientation_p95, 100.0 * r.position_p95);
    assert_eq!((r.c, r.price), (c, Some(7.0)));
    // At the limit it meets; just under it, it does not.
    s.position_mm = Some(upper);
    assert_eq!(row_of(&judged, 1, &c, None, &s).meets, Some(true));
    s.position_mm = Some(upper * (1.0 - 1e-12));
    assert_eq!(row_of(&judged, 1, &c, None, &s).meets, Some(false));
    assert!(!row_of(&judged, 1, &c, None, &s).clear_miss);
    // Missed beyond doubt: the lower limit beyond the target.
    s.position_mm = Some(lower * (1.0 - 1e-12));
    assert!(row_of(&judged, 1, &c, None, &s).clear_miss);
    s.position_mm = Some(lower);
    assert!(!row_of(&judged, 1, &c, None, &s).clear_miss);
    s.position_mm = Some(upper * (1.0 - 1e-12));
    // The first column is half as large: it meets the same target.
    assert_eq!(row_of(&judged, 0, &c, None, &s).meets, Some(true));
    // An orientation target is met at its own upper limit too.
    s.position_mm = Some(upper);
    let o_upper = r.orientation_p95_upper.unwrap();
    s.orientation_arcsec = Some(o_upper);
    assert_eq!(row_of(&judged, 1, &c, None, &s).meets, Some(true));
    s.orientation_arcsec = Some(o_upper * (1.0 - 1e-12));
    assert_eq!(row_of(&judged, 1, &c, None, &s).meets, Some(false));
    s.position_mm = None;
    assert_eq!(row_of(&judged, 1, &c, None, &s).meets, None);
}

/// The choice: the cheapest row that meets the target (a cheaper one
/// that misses is passed over), then each tie-break in its turn: fewer
/// encoders, fewer poses, the coarser grade, one step before
/// Gauss–Newton, the smaller upper limit, linear before GLS; bare grades
/// by the same order as the Tricept's (fewer poses, then the coarsest);
/// none when nothing meets.
#[test]
fn the_choice_is_the_cheapest_that_meets_then_each_tie_break() {
    use Encoders::{Both, First};
    use Estimator::{GaussNewton as Gn, Gls, Linear};
    let hex = Hexapod::example();
    let s = spec();
    let pick = |rows: &[RowOf<Hexapod>]| choose(&hex, &s, rows);
    // Price: the cheap row misses, the mid-priced beats the dearer and
    // more accurate.
    let rows = [
        row((1, First, 12, Gls), Some(100.0), 0.03, false),
        row((0, Both, 12, Gls), Some(900.0), 0.005, true),
        row((0, First, 30, Gls), Some(400.0), 0.018, true),
    ];
    assert_eq!(pick(&rows), Some(2));
    // Equal price: fewer encoders fitted.
    let rows = [
        row((0, Both, 12, Gls), Some(400.0), 0.01, true),
        row((0, First, 30, Gls), Some(400.0), 0.018, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // Then fewer poses.
    let rows = [
        row((0, First, 30, Gls), Some(400.0), 0.01, true),
        row((0, First, 12, Gls), Some(400.0), 0.018, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // Then one step before Gauss–Newton.
    let rows = [
        row((0, First, 12, Gn), Some(400.0), 0.01, true),
        row((0, First, 12, Linear), Some(400.0), 0.018, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // Then the smaller upper limit.
    let rows = [
        row((0, First, 12, Linear), Some(400.0), 0.018, true),
        row((0, First, 12, Gls), Some(400.0), 0.01, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // Then linear before GLS.
    let rows = [
        row((0, First, 12, Gls), Some(400.0), 0.01, true),
        row((0, First, 12, Linear), Some(400.0), 0.01, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // Equal price and poses: the coarser grade (sensor 1, 5″).
    let rows = [
        row((0, First, 12, Gls), Some(400.0), 0.005, true),
        row((1, First, 12, Gls), Some(400.0), 0.018, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // Grades without a price: the coarsest (sensor 1, 5″) that meets.
    let rows = [
        row((0, First, 12, Gls), None, 0.005, true),
        row((1, First, 12, Gls), None, 0.018, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    // … but fewer poses first, as the Tricept's ranking.
    let rows = [
        row((1, First, 30, Gls), None, 0.018, true),
        row((0, First, 12, Gls), None, 0.005, true),
    ];
    assert_eq!(pick(&rows), Some(1));
    let rows = [row((0, First, 12, Gls), Some(1.0), 0.03, false)];
    assert_eq!(pick(&rows), None);
    assert_eq!(pick(&[]), None);
}

/// The sentence: with no target it says no choice is made; with none met
/// it says what to try (more poses, or GLS where it was not studied);
/// with a choice it says what to buy, how many poses and estimator, the
/// numbers against the target, for which machines, and each what-if's
/// numbers; verdict.json says the same choice.
#[test]
fn the_sentence_says_the_choice_or_what_to_try() {
    let hex = Hexapod::example();
    let mut st = study(None);
    let s = Spec {
        trials: 100,
        ..spec()
    };
    let said = |st: &Study<Hexapod>, chosen, supposed: &[_]| {
        sentence(&hex, (&s, st), (&[], chosen), supposed, "machines whose …")
    };
    assert!(said(&st, None, &[]).starts_with("No target was set"));
    st.position_mm = Some(0.02);
    let none = said(&st, None, &[]);
    assert!(
        none.starts_with("No combination keeps 95 % of machines within 0.02 mm")
            && none.ends_with(", or more poses."),
        "{none}"
    );
    // Below 59 machines no 95th percentile has an upper limit: the advice
    // is more machines, not other encoders.
    let few = Spec {
        trials: 58,
        ..s.clone()
    };
    let none = sentence(&hex, (&few, &st), (&[], None), &[], "");
    assert_eq!(
        none,
        "No combination can be shown to keep 95 % of machines within 0.02 mm everywhere in the workspace with 58 machines: a 95th percentile's upper 95 % confidence limit needs at least 59 (--trials).",
    );
    let mut no_gls = s.clone();
    no_gls.estimators = vec![Estimator::Linear];
    let none = sentence(&hex, (&no_gls, &st), (&[], None), &[], "");
    assert!(
        none.ends_with(r#"more poses, or GLS (sweep.estimators = ["linear", "gls"])."#),
        "{none}"
    );
    let r = row(
        (1, Encoders::Both, 12, Estimator::Gls),
        Some(2400.0),
        0.0151,
        true,
    );
    let worse = Row {
        position_p95_upper: Some(0.0301),
        meets: Some(false),
        ..r.clone()
    };
    let supposed = [
        (WhatIf::White(2.0), Some(worse)),
        (WhatIf::EccentricityUm(5.0), None),
    ];
    // The study's rows: the choice, the same encoders with 30 poses (a
    // miss), with one a joint and with the linear estimator (neither the
    // same encoders and estimator).
    let rows = [
        r.clone(),
        Row {
            c: Combination { poses: 30, ..r.c },
            position_p95_upper: Some(0.0251),
            meets: Some(false),
            ..r.clone()
        },
        Row {
            c: Combination {
                variant: Encoders::First,
                ..r.c
            },
            ..r.clone()
        },
        Row {
            c: Combination {
                estimator: Estimator::Linear,
                poses: 20,
                ..r.c
            },
            ..r.clone()
        },
    ];
    let text = sentence(
        &hex,
        (&s, &st),
        (&rows, Some(&r)),
        &supposed,
        "machines whose …",
    );
    for part in [
        "Buy 12 × coarse (a φ and a ψ encoder per U-joint; total price 2400, the catalogue's), calibrate with 12 poses (gls): 95 % of machines within 0.0136 mm (upper limit 0.0151 mm) and 10.00″ (upper 11.00″)",
        "against the 0.02 mm asked; uncalibrated, the median machine is 0.3000 mm off; it holds for machines whose …. The same U-joint encoders with other pose counts: 30 poses 0.0251 mm and 11.00″ at the upper limits (misses the target). If the true U-joint encoders are not as the datasheets say, the same U-joint encoders, poses and estimator (gls) reach: ",
        "interpolation error and jitter 2× the datasheet's: 0.0301 mm and 11.00″ at the upper limit (misses the target)",
        "rings mounted to 5 µm of eccentricity instead of their stated tolerance: does not apply to coarse (no mounting eccentricity of its own).",
    ] {
        assert!(text.contains(part), "{part}\n{text}");
    }
    assert!(!text.contains("20 poses"), "{text}");
    assert!(text.ends_with('.'), "{text}");
    let v = verdict_json(&hex, (&s, &st), Some(&r), &supposed, (&[], &[], &[]), &text);
    assert_eq!(v["status"], "buy");
    assert_eq!(v["undecided"], serde_json::json!([]));
    assert_eq!(v["chosen"]["encoder"], "coarse");
    assert_eq!(v["chosen"]["encoders_fitted"], 12);
    assert_eq!(v["chosen"]["position_p95_upper95_mm"], 0.0151);
    assert_eq!(v["chosen"]["orientation_p95_upper95_arcsec"], 11.0);
    assert_eq!(v["what_ifs"][0]["meets_target"], false);
    assert_eq!(v["what_ifs"][1]["applies"], false);
    assert_eq!(v["verdict"], text.as_str());
}

/// A mechanism judged by its tool point's position alone (the Tricept
/// through `Homed`: its targets are points) leaves the orientation's
/// cells empty, its words out of the sentence and null in verdict.json;
/// a number that is not finite is written as null, never NaN.
#[test]
fn a_position_only_verdict_leaves_the_orientation_out_and_writes_no_nan() {
    use crate::mechanism::tricept::{Geometry, Tricept, N_PARAMS, N_READINGS};
    use crate::mechanism::Homed;
    let g = Geometry::paper();
    let m: Homed<'_, Tricept, N_PARAMS, N_READINGS> = Homed::new(&g);
    let s: Spec<Vector3<f64>, ()> = spec_of(vec![()], vec![12], vec![Estimator::Gls]);
    let st = StudyConfig {
        spec: s.clone(),
        until_decided: None,
        what_ifs: Vec::new(),
        position_mm: Some(0.02),
        orientation_arcsec: None,
    };
    let r = Row {
        c: Combination {
            sensor: 0,
            variant: (),
            poses: 12,
            estimator: Estimator::Gls,
        },
        price: Some(1000.0),
        position_before_median: 0.3,
        position_median: f64::NAN,
        position_p95: 0.0136,
        position_p95_upper: Some(0.0151),
        position_p95_lower: Some(0.0121),
        orientation_median: 0.0,
        orientation_p95: 0.0,
        orientation_p95_upper: Some(0.0),
        orientation_p95_lower: Some(0.0),
        meets: Some(true),
        clear_miss: false,
    };
    let csv = summary_csv(&m, &s, std::slice::from_ref(&r));
    let line = csv.lines().nth(1).unwrap();
    let cells: Vec<&str> = line.split(',').collect();
    assert_eq!(cells.len(), 16, "{line}");
    assert_eq!(cells[11..14], ["", "", ""], "{line}");
    assert_eq!((cells[8], cells[9]), ("", "0.0136"), "{line}");
    let text = sentence(&m, (&s, &st), (&[], Some(&r)), &[], "machines whose …");
    assert!(!text.contains('″'), "{text}");
    let v = verdict_json(&m, (&s, &st), Some(&r), &[], (&[], &[], &[]), &text);
    assert!(v["chosen"]["orientation_p95_arcsec"].is_null());
    assert_eq!(v["chosen"]["position_p95_mm"], 0.0136);
    let unknown = Row {
        position_p95: f64::NAN,
        ..r.clone()
    };
    let v = verdict_json(&m, (&s, &st), Some(&unknown), &[], (&[], &[], &[]), &text);
    assert!(v["chosen"]["position_p95_mm"].is_null());
    assert!(!serde_json::to_string(&v).unwrap().contains("NaN"));
}

/// The combinations these machines cannot decide on: those bought before
/// the choice (any, without one) that miss the target at an upper limit
/// while no lower limit is beyond it, in the buyer's order, each with the
/// machines that would settle it (by hand: 40 × (half-width / gap)² ×
/// 1.1, two significant figures); the sentence leads with them and
/// verdict.json lists them.
#[test]
fn the_verdict_names_what_these_machines_cannot_decide() {
    use Encoders::{Both, First};
    use Estimator::{Gls, Linear};
    let hex = Hexapod::example();
    let s = spec();
    let mut st = study(Some(0.02));
    st.orientation_arcsec = Some(20.0);
    // Position p95 0.018 in 0.016–0.0215, orientation well within.
    let open = |c, price| Row {
        position_p95: 0.018,
        position_p95_lower: Some(0.016),
        position_p95_upper: Some(0.0215),
        meets: Some(false),
        ..row(c, price, 0.0215, false)
    };
    let rows = [
        // 0: the choice.
        row((0, First, 12, Gls), Some(400.0), 0.015, true),
        // 1: cheaper and open on position: listed, 40 × (3.5/2)² × 1.1 =
        // 134.75 → 140.
        open((1, First, 12, Gls), Some(200.0)),
        // 2: cheaper, but its lower limit is beyond the target: decided.
        Row {
            position_p95_lower: Some(0.0201),
            clear_miss: true,
            ..open((1, First, 12, Linear), Some(200.0))
        },
        // 3: cheaper, position met, orientation open: 18″ in 15–24″
        // against 20″: 40 × (6/2)² × 1.1 = 396 → 400.
        Row {
            position_p95_upper: Some(0.019),
            orientation_p95: 18.0,
            orientation_p95_lower: Some(15.0),
            orientation_p95_upper: Some(24.0),
            ..open((1, First, 30, Gls), Some(100.0))
        },
        // 4: dearer than the choice: not listed.
        open((0, Both, 12, Gls), Some(900.0)),
    ];
    let u = undecided(&hex, (&s, &st), &rows, Some(0));
    assert_eq!(
        u,
        vec![
            Undecided {
                row: 3,
                machines: Some(400)
            },
            Undecided {
                row: 1,
                machines: Some(140)
            },
        ]
    );
    // Without a choice every open row, cheapest first.
    let all: Vec<usize> = undecided(&hex, (&s, &st), &rows, None)
        .iter()
        .map(|u| u.row)
        .collect();
    assert_eq!(all, [3, 1, 4]);
    // No target: nothing to decide.
    assert!(undecided(&hex, (&s, &study(None)), &rows, None).is_empty());
    let lead = undecided_lead(&hex, (&s, &st), (&rows, true), &u).unwrap();
    for part in [
        "Undecided at 40 machines: between their lower and upper 95 % confidence limits these combinations, bought before the choice, may or may not meet the target",
        "6 × coarse (one φ encoder per U-joint) with 30 poses (gls): position p95 0.0180 mm (95 % limits 0.0160 and 0.0190 mm), orientation p95 18.00″ (95 % limits 15.00 and 24.00″); about 400 machines would decide",
        "6 × coarse (one φ encoder per U-joint) with 12 poses (gls): position p95 0.0180 mm (95 % limits 0.0160 and 0.0215 mm), orientation p95 10.00″ (95 % limits 9.00 and 11.00″); about 140 machines would decide",
        "Run about 400 machines (--trials, or sweep.until_decided = true) before buying.",
    ] {
        assert!(lead.contains(part), "{part}\n{lead}");
    }
    assert_eq!(undecided_lead(&hex, (&s, &st), (&rows, true), &[]), None);
    // Without a choice they are not "bought before" it; with no upper
    // limit yet (too few machines) they need at least the 59 that give
    // one; past one study's machines, the words say so; past three, how
    // many more verdict.json lists.
    let few = Row {
        position_p95_upper: None,
        ..open((1, First, 12, Gls), Some(200.0))
    };
    let far = Row {
        position_p95: 0.01999999,
        position_p95_upper: Some(0.0201),
        ..open((1, First, 12, Linear), Some(200.0))
    };
    let many = [few.clone(), far, few.clone(), few];
    let all = undecided(&hex, (&s, &st), &many, None);
    assert_eq!(all.len(), 4);
    assert!(all.iter().any(|u| u.machines == Some(59)));
    // Exactly three: no "more"; no orientation target: no orientation.
    let three = undecided_lead(&hex, (&s, &study(Some(0.02))), (&many, false), &all[..3]).unwrap();
    assert!(
        !three.contains("more combination") && !three.contains("orientation"),
        "{three}"
    );
    let lead = undecided_lead(&hex, (&s, &st), (&many, false), &all).unwrap();
    assert!(
        lead.contains("these combinations may or may not meet the target")
            && lead.contains("(lower 95 % limit 0.0160 mm; no upper limit at these machines)")
            && lead.contains("more than the 10000000 machines one study runs would decide")
            && lead.contains("; and 1 more combination (verdict.json lists them)"),
        "{lead}"
    );
    let v = verdict_json(
        &hex,
        (&s, &st),
        Some(&rows[0]),
        &[],
        (&rows, &u, &[]),
        &lead,
    );
    assert_eq!(v["status"], "undecided");
    assert_eq!(v["undecided"][0]["poses"], 30);
    assert_eq!(v["undecided"][0]["machines_to_decide"], 400);
    assert_eq!(v["undecided"][1]["position_p95_lower95_mm"], 0.016);
    let v = verdict_json(&hex, (&s, &st), None, &[], (&rows, &[], &[]), "");
    assert_eq!(v["status"], "none_meets");
}

/// A row that meets the target with some poses while the same encoder,
/// encoders per joint and estimator miss it with more is fragile: the
/// choice passes over it, summary.csv marks it, the sentence names it
/// (when bought before the choice) and verdict.json lists it.
#[test]
fn a_fragile_pass_is_passed_over_and_named() {
    use Encoders::First;
    use Estimator::{Gls, Linear};
    let hex = Hexapod::example();
    let s = spec();
    let st = study(Some(0.02));
    let rows = [
        // 0: cheapest, meets at 12 poses, misses at 30 (row 1): fragile.
        row((1, First, 12, Gls), Some(200.0), 0.019, true),
        Row {
            clear_miss: true,
            ..row((1, First, 30, Gls), Some(200.0), 0.021, false)
        },
        // 2: the same encoder with another estimator meets at both.
        row((1, First, 12, Linear), Some(200.0), 0.0195, true),
        row((1, First, 30, Linear), Some(200.0), 0.0199, true),
        // 4: dearer.
        row((0, First, 12, Gls), Some(500.0), 0.01, true),
    ];
    assert_eq!(fragile_rows(&rows), [true, false, false, false, false]);
    assert_eq!(choose(&hex, &s, &rows), Some(2));
    assert_eq!(passed_over(&hex, &s, &rows, Some(2)), [0]);
    // Bought after the choice: not named.
    assert!(passed_over(&hex, &s, &rows, Some(0)).is_empty());
    let words = passed_over_words(&hex, (&s, &st), &rows, &[0]).unwrap();
    assert!(
        words.contains("Passed over as fragile")
            && words.contains(
                "6 × coarse (one φ encoder per U-joint) with 12 poses (gls, upper limit 0.0190 mm)"
            ),
        "{words}"
    );
    assert_eq!(passed_over_words(&hex, (&s, &st), &rows, &[]), None);
    let csv = summary_csv(&hex, &s, &rows);
    let last: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    assert_eq!(last, ["true", "false", "false", "false", "false"]);
    assert!(csv
        .lines()
        .next()
        .unwrap()
        .ends_with(",meets_target,fragile"));
    let v = verdict_json(
        &hex,
        (&s, &st),
        Some(&rows[2]),
        &[],
        (&rows, &[], &[0]),
        &words,
    );
    assert_eq!(v["fragile"][0]["poses"], 12);
    assert_eq!(v["fragile"][0]["estimator"], "gls");
    assert_eq!(v["fragile"][0]["position_p95_upper95_mm"], 0.019);
}
