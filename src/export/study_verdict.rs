//! The verdict of any mechanism's study (`sweep` of a `[sweep]` study),
//! in the buyer's words: each combination's row over its machines
//! ([`Row`], summary.csv), the combination chosen ([`choose`]), and the
//! sentence and verdict.json ([`sentence`], [`verdict_json`]). The
//! mechanism gives the nouns ([`Mechanism::words`]); the study's runs
//! (the kernel, the what-ifs) are the caller's.

use super::verdict_words::{self as words, between, number, Chosen, Lead, Open, LISTED};
use crate::config::general::{Estimator, Spec, Study, StudyConfig, WhatIf};
use crate::mechanism::Mechanism;
use crate::metrics::buyer::Offer;
use crate::metrics::buyer::{fragile, machines_to_decide};
use crate::metrics::stats::{
    quantile_lower95, quantile_sorted, quantile_upper95, values_for_upper_limit,
};
use crate::montecarlo::general::{Combination, Judged};

/// The spec of a mechanism's study.
type SpecOf<M> = Spec<<M as Mechanism>::Target, <M as Mechanism>::Variant>;
/// A row of a mechanism's study.
pub type RowOf<M> = Row<<M as Mechanism>::Variant>;

/// One combination's statistics over its machines (mm, ″).
#[derive(Debug, Clone, PartialEq)]
pub struct Row<V> {
    pub c: Combination<V>,
    /// Its encoders' price (each priced as many times as fitted).
    pub price: Option<f64>,
    pub position_before_median: f64,
    pub position_median: f64,
    pub position_p95: f64,
    /// The position p95's upper 95 % confidence limit (None: too few
    /// machines to state one).
    pub position_p95_upper: Option<f64>,
    /// Its lower 95 % confidence limit (None: too few machines).
    pub position_p95_lower: Option<f64>,
    pub orientation_median: f64,
    pub orientation_p95: f64,
    pub orientation_p95_upper: Option<f64>,
    pub orientation_p95_lower: Option<f64>,
    /// Does it meet the target at the upper limits? None: no target.
    pub meets: Option<bool>,
    /// Does it miss the target beyond doubt: a judged p95 not finite, or
    /// its lower limit beyond the target? (False without a target.)
    pub clear_miss: bool,
}

/// Combination `c`'s row from its column `ci` of every trial's judgement:
/// it meets the target when the upper 95 % confidence limits of the
/// position's p95 (and the orientation's, where asked) are within it.
pub fn row_of<T, V: Copy>(
    judged: &[Vec<Judged>],
    ci: usize,
    c: &Combination<V>,
    price: Option<f64>,
    study: &StudyConfig<T, V>,
) -> Row<V> {
    let col = |f: fn(&Judged) -> f64| -> Vec<f64> {
        let mut v: Vec<f64> = judged.iter().map(|t| f(&t[ci])).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let (before, pos, ori) = (
        col(|j| j.position_before),
        col(|j| j.position_after),
        col(|j| j.orientation_after),
    );
    let position_p95_upper = quantile_upper95(&pos, 0.95);
    let orientation_p95_upper = quantile_upper95(&ori, 0.95);
    let position_p95_lower = quantile_lower95(&pos, 0.95);
    let orientation_p95_lower = quantile_lower95(&ori, 0.95);
    let (p95, o95) = (quantile_sorted(&pos, 0.95), quantile_sorted(&ori, 0.95));
    let beyond =
        |v: f64, lower: Option<f64>, t: f64| !v.is_finite() || lower.is_some_and(|l| l > t);
    let clear_miss = study.position_mm.is_some_and(|t| {
        beyond(p95, position_p95_lower, t)
            || study
                .orientation_arcsec
                .is_some_and(|o| beyond(o95, orientation_p95_lower, o))
    });
    let within = within_target(study, position_p95_upper, orientation_p95_upper);
    // A calibration that leaves the median machine at least as far off as
    // uncalibrated is not feasible whatever the target (the Tricept's rule).
    let (before_median, after_median) = (quantile_sorted(&before, 0.5), quantile_sorted(&pos, 0.5));
    let harms = harmful_medians(before_median, after_median);
    let meets = within.map(|m| m && !harms);
    let clear_miss = clear_miss || (harms && study.position_mm.is_some());
    Row {
        c: *c,
        price,
        position_before_median: before_median,
        position_median: after_median,
        position_p95: p95,
        position_p95_upper,
        position_p95_lower,
        orientation_median: quantile_sorted(&ori, 0.5),
        orientation_p95: o95,
        orientation_p95_upper,
        orientation_p95_lower,
        meets,
        clear_miss,
    }
}

/// Are the upper limits within the target (the position's, and the
/// orientation's where asked)? None without a target.
fn within_target<T, V>(
    study: &StudyConfig<T, V>,
    position_upper: Option<f64>,
    orientation_upper: Option<f64>,
) -> Option<bool> {
    study.position_mm.map(|target| {
        position_upper.is_some_and(|u| u <= target)
            && study
                .orientation_arcsec
                .is_none_or(|t| orientation_upper.is_some_and(|u| u <= t))
    })
}

/// Does a calibration whose median machine is `after` mm off (after
/// compensation) harm against `before` (uncalibrated)? Not where either is
/// unknown.
fn harmful_medians(before: f64, after: f64) -> bool {
    before.is_finite() && after.is_finite() && after >= before
}

/// Does calibrating with `r` leave the median machine at least as far off
/// as not calibrating?
pub fn harms<V>(r: &Row<V>) -> bool {
    harmful_medians(r.position_before_median, r.position_median)
}

/// The verdict's words on the combinations that meet the target at their
/// upper limits yet harm (not chosen whatever the target); None when none.
pub fn harmful_words<T, V>(study: &StudyConfig<T, V>, rows: &[Row<V>]) -> Option<String> {
    let within = |r: &Row<V>| {
        within_target(study, r.position_p95_upper, r.orientation_p95_upper) == Some(true)
    };
    let n = rows.iter().filter(|r| harms(r) && within(r)).count();
    words::harmful(
        n,
        "its median position error after compensation at least the uncalibrated one",
    )
}

/// Is the mechanism's accuracy judged by orientation too (its targets are
/// poses)? Where not, the orientation's cells and words are left out.
fn oriented<M: Mechanism>(m: &M) -> bool {
    m.judged().len() > 1
}

/// summary.csv: one line a row (an empty cell where a number is not
/// finite or not judged).
pub fn summary_csv<M: Mechanism>(m: &M, spec: &SpecOf<M>, rows: &[RowOf<M>]) -> String {
    // A number that is not finite (a machine whose judgement failed in
    // the percentile) is an empty cell, as a missing one is.
    let num = |x: Option<f64>| {
        x.filter(|v| v.is_finite())
            .map_or(String::new(), |v| format!("{v}"))
    };
    let oriented = oriented(m);
    let ori = |x: Option<f64>| num(x.filter(|_| oriented));
    let mut csv = String::from("encoder,per_joint,encoders_fitted,price,poses,estimator,trials,position_before_median_mm,position_median_mm,position_p95_mm,position_p95_upper95_mm,orientation_median_arcsec,orientation_p95_arcsec,orientation_p95_upper95_arcsec,meets_target,fragile\n");
    let fragile = fragile_rows(rows);
    for (r, fragile) in rows.iter().zip(fragile) {
        csv += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            spec.sensors[r.c.sensor].name,
            m.variant_name(r.c.variant),
            m.fitted(r.c.variant),
            num(r.price),
            r.c.poses,
            r.c.estimator.name(),
            spec.trials,
            num(Some(r.position_before_median)),
            num(Some(r.position_median)),
            num(Some(r.position_p95)),
            num(r.position_p95_upper),
            ori(Some(r.orientation_median)),
            ori(Some(r.orientation_p95)),
            ori(r.orientation_p95_upper),
            r.meets.map_or(String::new(), |m| m.to_string()),
            r.meets.map_or(String::new(), |_| fragile.to_string()),
        );
    }
    csv
}

/// Which rows are fragile ([`crate::metrics::buyer::fragile`]): they meet
/// the target while the same encoder, encoders per joint and estimator
/// miss it beyond doubt ([`Row::clear_miss`]) with more poses.
pub fn fragile_rows<V: PartialEq + Copy>(rows: &[Row<V>]) -> Vec<bool> {
    let keyed: Vec<_> = rows
        .iter()
        .map(|r| {
            let same = (r.c.sensor, r.c.variant, r.c.estimator);
            (same, r.c.poses, r.meets == Some(true), r.clear_miss)
        })
        .collect();
    fragile(&keyed)
}

/// The fragile rows the choice passed over: those bought before it (every
/// one, when none is chosen), in the buyer's order.
pub fn passed_over<M: Mechanism>(
    m: &M,
    spec: &SpecOf<M>,
    rows: &[RowOf<M>],
    chosen: Option<usize>,
) -> Vec<usize> {
    let fragile = fragile_rows(rows);
    let mut out: Vec<usize> = (0..rows.len())
        .filter(|&i| {
            fragile[i]
                && chosen.is_none_or(|c| {
                    offer(m, spec, &rows[i])
                        .buyer_cmp(&offer(m, spec, &rows[c]))
                        .is_lt()
                })
        })
        .collect();
    out.sort_by(|&a, &b| offer(m, spec, &rows[a]).buyer_cmp(&offer(m, spec, &rows[b])));
    out
}

/// A combination in the buyer's words: "6 × angle-1as (one φ encoder per
/// U-joint) with 12 poses".
fn named<M: Mechanism>(m: &M, spec: &SpecOf<M>, r: &RowOf<M>) -> String {
    format!(
        "{} × {} ({} per {}) with {} poses",
        m.fitted(r.c.variant),
        spec.sensors[r.c.sensor].name,
        m.variant_words(r.c.variant)[0],
        m.words().joint,
        r.c.poses,
    )
}

/// The verdict's closing words on the fragile rows passed over (the first
/// three), None when there are none.
pub fn passed_over_words<M: Mechanism>(
    m: &M,
    (spec, study): (&SpecOf<M>, &Study<M>),
    rows: &[RowOf<M>],
    passed: &[usize],
) -> Option<String> {
    let listed: Vec<String> = passed
        .iter()
        .take(LISTED)
        .map(|&i| {
            let r = &rows[i];
            let position = number(r.position_p95_upper, 4);
            format!(
                "{} ({}, {})",
                named(m, spec, r),
                r.c.estimator.name(),
                match study.orientation_arcsec.is_some() && oriented(m) {
                    true => format!(
                        "upper limits {position} mm and {}″",
                        number(r.orientation_p95_upper, 2)
                    ),
                    false => format!("upper limit {position} mm"),
                }
            )
        })
        .collect();
    words::passed_over(&listed, passed.len())
}

/// The row chosen: the first that meets the target, and is not fragile, in the buyer's order
/// of any mechanism ([`Offer::buyer_cmp`]: total price, fewer encoders,
/// fewer poses, the coarser grade, one step before Gauss–Newton, the
/// smaller upper limit of the position's p95, linear before GLS).
pub fn choose<M: Mechanism>(m: &M, spec: &SpecOf<M>, rows: &[RowOf<M>]) -> Option<usize> {
    let fragile = fragile_rows(rows);
    (rows.iter().enumerate())
        .filter(|(i, r)| r.meets == Some(true) && !fragile[*i])
        .min_by(|(_, a), (_, b)| offer(m, spec, a).buyer_cmp(&offer(m, spec, b)))
        .map(|(i, _)| i)
}

/// What the buyer's order compares of a row.
fn offer<M: Mechanism>(m: &M, spec: &SpecOf<M>, r: &RowOf<M>) -> Offer {
    Offer {
        price: r.price,
        fitted: m.fitted(r.c.variant),
        poses: r.c.poses,
        grades: [spec.sensors[r.c.sensor].axis.accuracy, 0.0],
        iterated: r.c.estimator == Estimator::GaussNewton,
        upper: r.position_p95_upper,
        estimator: r.c.estimator as u8,
    }
}

/// A combination these machines cannot decide on: it misses the target at
/// the upper confidence limits, yet no lower limit is beyond the target,
/// so more machines could make it meet. `machines`: about how many would
/// settle it (the most any of its judged quantities needs; None where one
/// sits on the target or has no limit at this many machines).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Undecided {
    /// Its index in the rows.
    pub row: usize,
    pub machines: Option<u64>,
}

/// The combinations that would be bought before `chosen` (any, when none
/// is chosen) and that these machines cannot decide on, in the buyer's
/// order. Empty: the study has decided (or states no target).
pub fn undecided<M: Mechanism>(
    m: &M,
    (spec, study): (&SpecOf<M>, &Study<M>),
    rows: &[RowOf<M>],
    chosen: Option<usize>,
) -> Vec<Undecided> {
    let Some(position) = study.position_mm else {
        return Vec::new();
    };
    // Each judged quantity: its p95, its limits and its target.
    let judged = |r: &RowOf<M>| {
        let mut q = vec![(
            r.position_p95,
            (r.position_p95_lower, r.position_p95_upper),
            position,
        )];
        if let Some(o) = study.orientation_arcsec.filter(|_| oriented(m)) {
            q.push((
                r.orientation_p95,
                (r.orientation_p95_lower, r.orientation_p95_upper),
                o,
            ));
        }
        q
    };
    let mut out: Vec<Undecided> = (rows.iter().enumerate())
        .filter(|(i, r)| {
            r.meets == Some(false)
                && chosen.is_none_or(|c| {
                    offer(m, spec, r)
                        .buyer_cmp(&offer(m, spec, &rows[c]))
                        .is_lt()
                        && *i != c
                })
                && !r.clear_miss
        })
        .map(|(i, r)| {
            // The quantities that miss at the upper limit decide; one with
            // no upper limit yet needs at least the machines that give one.
            let open: Vec<Option<u64>> = judged(r)
                .into_iter()
                .filter(|&(_, (_, up), t)| up.is_none_or(|u| u > t))
                .map(|(v, lim, t)| match lim.1 {
                    None => Some(values_for_upper_limit(0.95, 0.95) as u64),
                    Some(_) => machines_to_decide(spec.trials, v, t, lim),
                })
                .collect();
            Undecided {
                row: i,
                machines: open
                    .iter()
                    .copied()
                    .collect::<Option<Vec<u64>>>()
                    .and_then(|n| n.into_iter().max()),
            }
        })
        .collect();
    out.sort_by(|a, b| offer(m, spec, &rows[a.row]).buyer_cmp(&offer(m, spec, &rows[b.row])));
    out
}

/// The verdict's lead when the study has not decided: which combinations
/// (the first three, and how many more verdict.json lists) and how many
/// machines would settle them. `chosen`: whether a combination was chosen
/// (they would be bought before it). None when `open` is empty.
pub fn undecided_lead<M: Mechanism>(
    m: &M,
    (spec, study): (&SpecOf<M>, &Study<M>),
    (rows, chosen): (&[RowOf<M>], bool),
    open: &[Undecided],
) -> Option<String> {
    let listed: Vec<Open> = open
        .iter()
        .take(LISTED)
        .map(|u| {
            let r = &rows[u.row];
            let mut judged = vec![between(
                "position p95",
                (
                    Some(r.position_p95),
                    r.position_p95_lower,
                    r.position_p95_upper,
                ),
                (" mm", 4),
                (0.95, 0.95),
            )];
            if study.orientation_arcsec.is_some() && oriented(m) {
                judged.push(between(
                    "orientation p95",
                    (
                        Some(r.orientation_p95),
                        r.orientation_p95_lower,
                        r.orientation_p95_upper,
                    ),
                    ("″", 2),
                    (0.95, 0.95),
                ));
            }
            Open {
                named: format!("{} ({})", named(m, spec, r), r.c.estimator.name()),
                judged: judged.join(", "),
                machines: u.machines,
            }
        })
        .collect();
    let lead = Lead {
        trials: spec.trials,
        confidence: Some(0.95),
        // The choice meets the target at its upper limits, so it is never
        // among them.
        chosen: match chosen {
            true => Chosen::Before,
            false => Chosen::None,
        },
        most: crate::config::general::MAX_STUDY_TRIALS,
        how: match study.until_decided {
            Some(_) => "a larger sweep.max_trials or --max-trials",
            None => "--trials, or sweep.until_decided = true",
        },
    };
    words::undecided_lead(lead, &listed, open.len())
}

/// The verdict in one paragraph: what to buy and how to calibrate with
/// it, what it reaches against the target, for which machines (`holds`:
/// "machines whose …"), what the same encoders reach with the study's
/// other pose counts (`rows`), and what it reaches if its encoders read
/// otherwise than their datasheets say (`supposed`: each what-if's row,
/// None where it does not apply). Without a target, or with none met,
/// says so and what to try. Each sentence ends in a full stop.
pub fn sentence<M: Mechanism>(
    m: &M,
    (spec, study): (&SpecOf<M>, &Study<M>),
    (rows, chosen): (&[RowOf<M>], Option<&RowOf<M>>),
    supposed: &[(WhatIf, Option<RowOf<M>>)],
    holds: &str,
) -> String {
    let w = m.words();
    let oriented = oriented(m);
    let mut sentence = match (study.position_mm, chosen) {
        (None, _) => "No target was set ([decision] position_mm): the rows compare the encoders, and no choice is made.".to_string(),
        // Too few machines for any upper limit: nothing can be shown to
        // meet the target, whatever the encoders, so the advice is more
        // machines, not other encoders.
        (Some(t), None) if spec.trials < values_for_upper_limit(0.95, 0.95) as u64 => format!(
            "No combination can be shown to keep 95 % of machines within {t} mm{} everywhere in the workspace with {} machine{}: a 95th percentile's upper 95 % confidence limit needs at least {} (--trials).",
            study.orientation_arcsec.map_or(String::new(), |o| format!(" and {o}″")),
            spec.trials,
            if spec.trials == 1 { "" } else { "s" },
            values_for_upper_limit(0.95, 0.95),
        ),
        (Some(t), None) => format!(
            "No combination keeps 95 % of machines within {t} mm{} everywhere in the workspace at the upper 95 % confidence limit: a finer encoder or one with less jitter, {}{}.",
            study.orientation_arcsec.map_or(String::new(), |o| format!(" and {o}″")),
            w.more_sensors,
            if spec.estimators.contains(&Estimator::Gls) {
                ", or more poses".to_string()
            } else {
                let list: Vec<String> = spec
                    .estimators
                    .iter()
                    .map(|e| format!("\"{}\"", e.name()))
                    .chain(["\"gls\"".to_string()])
                    .collect();
                format!(", more poses, or GLS (sweep.estimators = [{}])", list.join(", "))
            }
        ),
        (Some(t), Some(r)) => format!(
            "Buy {} × {} ({} per {}{}), calibrate with {} poses ({}): 95 % of machines within {:.4} mm (upper limit {:.4} mm){} everywhere in the workspace after compensation, against the {t} mm{} asked; uncalibrated, the median machine is {:.4} mm off",
            m.fitted(r.c.variant),
            spec.sensors[r.c.sensor].name,
            m.variant_words(r.c.variant)[0],
            w.joint,
            r.price.map_or(String::new(), |p| format!("; total price {p:.0}, the catalogue's")),
            r.c.poses,
            r.c.estimator.name(),
            r.position_p95,
            r.position_p95_upper.unwrap_or(f64::NAN),
            if oriented {
                format!(
                    " and {:.2}″ (upper {:.2}″)",
                    r.orientation_p95,
                    r.orientation_p95_upper.unwrap_or(f64::NAN)
                )
            } else {
                String::new()
            },
            study.orientation_arcsec.map_or(String::new(), |o| format!(" and {o}″")),
            r.position_before_median,
        ) + "; it holds for " + holds + ".",
    };
    let Some(r) = chosen.filter(|_| study.position_mm.is_some()) else {
        return sentence;
    };
    let sensors = format!("{}s", w.sensor);
    // The same encoders and estimator with the study's other pose counts.
    let others: Vec<String> = rows
        .iter()
        .filter(|x| {
            (x.c.sensor, x.c.variant, x.c.estimator) == (r.c.sensor, r.c.variant, r.c.estimator)
                && x.c.poses != r.c.poses
        })
        // At the upper limits, which decide whether it meets.
        .map(|x| {
            format!(
                "{} poses {} mm{} at the upper limit{}{}",
                x.c.poses,
                number(x.position_p95_upper, 4),
                match oriented {
                    true => format!(" and {}″", number(x.orientation_p95_upper, 2)),
                    false => String::new(),
                },
                if oriented { "s" } else { "" },
                match x.meets {
                    Some(false) => " (misses the target)",
                    _ => "",
                }
            )
        })
        .collect();
    if let Some(words) = words::other_pose_counts(&sensors, &others) {
        sentence = format!("{sentence} {words}");
    }
    let name = &spec.sensors[r.c.sensor].name;
    let cases: Vec<String> = supposed
        .iter()
        .map(|(what, row)| match row {
            Some(x) => format!(
                "{}: {} mm{} at the upper limit ({})",
                what.words(),
                number(x.position_p95_upper, 4),
                if oriented {
                    format!(" and {}″", number(x.orientation_p95_upper, 2))
                } else {
                    String::new()
                },
                if x.meets == Some(true) {
                    "meets the target"
                } else {
                    "misses the target"
                }
            ),
            None => format!(
                "{}: does not apply to {name} (no mounting eccentricity of its own)",
                what.words()
            ),
        })
        .collect();
    if let Some(words) = words::what_ifs(&sensors, r.c.estimator.name(), &cases) {
        sentence = format!("{sentence} {words}");
    }
    sentence
}

/// verdict.json: the study, the target, the chosen combination, the
/// what-ifs and the sentence (non-finite numbers as null).
pub fn verdict_json<M: Mechanism>(
    m: &M,
    (spec, study): (&SpecOf<M>, &Study<M>),
    chosen: Option<&RowOf<M>>,
    supposed: &[(WhatIf, Option<RowOf<M>>)],
    (rows, open, passed): (&[RowOf<M>], &[Undecided], &[usize]),
    sentence: &str,
) -> serde_json::Value {
    let oriented = oriented(m);
    let fin = |x: f64| {
        if x.is_finite() {
            serde_json::json!(x)
        } else {
            serde_json::Value::Null
        }
    };
    let status = match (study.position_mm, chosen, open.is_empty()) {
        (None, _, _) => "no_target",
        (_, _, false) => "undecided",
        (_, Some(_), true) => "buy",
        (_, None, true) => "none_meets",
    };
    // A combination's identity and p95s, with `extra`'s keys.
    let entry = |r: &RowOf<M>, extra: serde_json::Value| {
        let mut v = serde_json::json!({
            "encoder": spec.sensors[r.c.sensor].name,
            "per_joint": m.variant_name(r.c.variant),
            "encoders_fitted": m.fitted(r.c.variant),
            "price": r.price,
            "poses": r.c.poses,
            "estimator": r.c.estimator.name(),
            "position_p95_mm": fin(r.position_p95),
            "orientation_p95_arcsec": if oriented { fin(r.orientation_p95) } else { serde_json::Value::Null },
        });
        if let (Some(o), serde_json::Value::Object(e)) = (v.as_object_mut(), extra) {
            o.extend(e);
        }
        v
    };
    serde_json::json!({
        "mechanism": m.name(),
        "status": status,
        "trials": spec.trials,
        "seed": spec.seed,
        "workspace_poses": spec.workspace.len(),
        "target_position_mm": study.position_mm,
        "target_orientation_arcsec": study.orientation_arcsec,
        "metric": "95th percentile over machines of the largest tool-point position error over the workspace after compensation, judged at its upper 95 % confidence limit",
        "chosen": chosen.map(|r| entry(r, serde_json::json!({
            "position_p95_upper95_mm": r.position_p95_upper.map(fin),
            "orientation_p95_upper95_arcsec": r.orientation_p95_upper.filter(|_| oriented).map(fin),
        }))),
        "what_ifs": supposed.iter().map(|(w, row)| serde_json::json!({
            "what": w.words(),
            "applies": row.is_some(),
            "position_p95_upper95_mm": row.as_ref().and_then(|x| x.position_p95_upper).map(fin),
            "orientation_p95_upper95_arcsec": row.as_ref().and_then(|x| x.orientation_p95_upper).filter(|_| oriented).map(fin),
            "meets_target": row.as_ref().and_then(|x| x.meets),
        })).collect::<Vec<_>>(),
        "undecided": open.iter().map(|u| {
            let r = &rows[u.row];
            entry(r, serde_json::json!({
                "position_p95_lower95_mm": r.position_p95_lower.map(fin),
                "position_p95_upper95_mm": r.position_p95_upper.map(fin),
                "orientation_p95_lower95_arcsec": r.orientation_p95_lower.filter(|_| oriented).map(fin),
                "orientation_p95_upper95_arcsec": r.orientation_p95_upper.filter(|_| oriented).map(fin),
                "machines_to_decide": u.machines,
            }))
        }).collect::<Vec<_>>(),
        "fragile": passed.iter().map(|&i| {
            let r = &rows[i];
            entry(r, serde_json::json!({
                "position_p95_upper95_mm": r.position_p95_upper.map(fin),
                "orientation_p95_upper95_arcsec": r.orientation_p95_upper.filter(|_| oriented).map(fin),
            }))
        }).collect::<Vec<_>>(),
        "verdict": sentence,
    })
}

#[cfg(test)]
#[path = "study_verdict_tests.rs"]
mod tests;
