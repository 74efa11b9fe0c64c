//! `sweep` of any mechanism's `[sweep]` study: its rows (summary.csv), its
//! verdict in the buyer's words (verdict.json and the console) and its
//! throughput; the mechanism gives the nouns ([`Mechanism::words`]).

use super::report::{machines_words, page, price_chart, Row};
use crate::cli::console;
use crate::config::general::{
    Estimator, MechanismConfig, Sensor, Spec, Study, StudyConfig, WhatIf,
};
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::{Commanded, Mechanism};
use crate::metrics::stats::{quantile_sorted, quantile_upper95};
use crate::montecarlo::general::kernel::{
    check, combinations, run_kernel, run_reporting, KernelFn,
};
use crate::montecarlo::general::{Combination, Judged};
use crate::store::names;
use std::path::Path;
use std::time::Instant;

/// The spec of a mechanism's study.
type SpecOf<M> = Spec<<M as Mechanism>::Target, <M as Mechanism>::Variant>;

/// What a sweep writes (stale ones are removed).
const FILES: [&str; 5] = [
    names::SUMMARY_CSV,
    names::VERDICT_JSON,
    names::REPORT_HTML,
    names::PRICE_PNG,
    names::PRICE_SVG,
];

/// Combination `c`'s row from its column `ci` of every trial's judgement.
fn row_of<T, V: Copy>(
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
    let meets = study.position_mm.map(|target| {
        position_p95_upper.is_some_and(|u| u <= target)
            && study
                .orientation_arcsec
                .is_none_or(|t| orientation_p95_upper.is_some_and(|u| u <= t))
    });
    Row {
        c: *c,
        price,
        position_before_median: quantile_sorted(&before, 0.5),
        position_median: quantile_sorted(&pos, 0.5),
        position_p95: quantile_sorted(&pos, 0.95),
        position_p95_upper,
        orientation_median: quantile_sorted(&ori, 0.5),
        orientation_p95: quantile_sorted(&ori, 0.95),
        orientation_p95_upper,
        meets,
    }
}

/// The chosen combination again, with its encoders reading as each
/// what-if supposes (the same machines and draws; the estimator still
/// weights by the datasheet): its row, or None where the what-if does not
/// apply to that encoder.
#[allow(clippy::type_complexity)]
fn what_ifs<C: MechanismConfig>(
    cfg: &C,
    spec: &SpecOf<C::M>,
    study: &Study<C::M>,
    chosen: &Row<<C::M as Mechanism>::Variant>,
    (threads, sizes): (usize, KernelFn<C::M>),
) -> Result<Vec<(WhatIf, Option<Row<<C::M as Mechanism>::Variant>>)>>
where
    C::M: Commanded,
{
    let sensor = &spec.sensors[chosen.c.sensor];
    let mut out = Vec::new();
    for w in &study.what_ifs {
        let Some(truth) = w.truth(&sensor.axis) else {
            out.push((*w, None));
            continue;
        };
        let sub = Spec {
            sensors: vec![Sensor {
                truth: Some(truth),
                ..sensor.clone()
            }],
            variants: vec![chosen.c.variant],
            pose_counts: vec![chosen.c.poses],
            estimators: vec![chosen.c.estimator],
            ..spec.clone()
        };
        let (combos, judged) = run_kernel(cfg.machine(), cfg.poses(), &sub, threads, sizes)
            .map_err(|why| Error::config(cfg.source(), why))?;
        let c = combos[0];
        out.push((*w, Some(row_of(&judged, 0, &c, chosen.price, study))));
    }
    Ok(out)
}

/// `sweep`: the config's `[sweep]` study on `threads` threads (`trials`
/// and `seed` as the flags give them), its files in `out`.
pub fn run_sweep<C: MechanismConfig>(
    cfg: &C,
    out: &Path,
    (threads, sizes): (usize, KernelFn<C::M>),
    trials: Option<u64>,
    seed: Option<u64>,
) -> Result<()>
where
    C::M: Commanded,
{
    let m = cfg.machine();
    let w = m.words();
    let Some(study) = cfg.study() else {
        return Err(Error::config(
            cfg.source(),
            format!(
                "has no [sweep] section: a {} study needs one ({})",
                m.name(),
                cfg.study_keys()
            ),
        ));
    };
    if study.orientation_arcsec.is_some() && !m.judged().contains(&crate::mechanism::ORIENTATION) {
        return Err(Error::config(
            cfg.source(),
            format!(
                "decision.orientation_arcsec: the {} is judged by its tool point's position alone (its targets are points); leave it out",
                m.name()
            ),
        ));
    }
    let mut spec = study.spec.clone();
    if let Some(n) = trials {
        spec.trials = n;
    }
    if let Some(s) = seed {
        spec.seed = s;
    }
    check(m, cfg.poses().len(), &spec).map_err(|why| Error::config(cfg.source(), why))?;
    let combos = combinations(&spec).len();
    let need = crate::montecarlo::general::result_bytes(combos, spec.trials);
    if need > crate::config::general::MAX_RESULT_BYTES {
        return Err(Error::Argument(format!(
            "--trials {} × {combos} combinations needs {need} bytes of results, over 1 GiB: fewer trials",
            spec.trials
        )));
    }
    let _lock = io::claim_dir(out)?;
    let start = Instant::now();
    let progress = console::SweepProgress::new(&format!("{} study", m.name()));
    let (combinations, judged) = run_reporting(m, cfg.poses(), &spec, (threads, &progress), sizes)
        .map_err(|why| Error::config(cfg.source(), why))?;
    let secs = start.elapsed().as_secs_f64();
    let calibrations = spec.trials * combos as u64;
    let rows: Vec<Row<_>> = combinations
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let price = spec.sensors[c.sensor]
                .price
                .map(|p| p * m.fitted(c.variant) as f64);
            row_of(&judged, ci, c, price, study)
        })
        .collect();
    let num = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v}"));
    // Whether accuracy is judged by orientation too (targets are poses);
    // where not, the orientation's cells are empty.
    let oriented = m.judged().len() > 1;
    let ori = |x: Option<f64>| num(x.filter(|_| oriented));
    let mut csv = String::from("encoder,per_joint,encoders_fitted,price,poses,estimator,trials,position_before_median_mm,position_median_mm,position_p95_mm,position_p95_upper95_mm,orientation_median_arcsec,orientation_p95_arcsec,orientation_p95_upper95_arcsec,meets_target\n");
    for r in &rows {
        csv += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            spec.sensors[r.c.sensor].name,
            m.variant_name(r.c.variant),
            m.fitted(r.c.variant),
            num(r.price),
            r.c.poses,
            r.c.estimator.name(),
            spec.trials,
            r.position_before_median,
            r.position_median,
            r.position_p95,
            num(r.position_p95_upper),
            ori(Some(r.orientation_median)),
            ori(Some(r.orientation_p95)),
            ori(r.orientation_p95_upper),
            r.meets.map_or(String::new(), |m| m.to_string()),
        );
    }
    // The cheapest combination that meets the target; then the fewer
    // encoders, the fewer poses, a one-step estimator (linear or GLS)
    // before Gauss–Newton, the more accurate (position p95's upper limit);
    // grades (no price) the coarsest.
    let chosen = rows
        .iter()
        .filter(|r| r.meets == Some(true))
        .min_by(|a, b| {
            let cost = |r: &Row<_>| r.price.unwrap_or(-spec.sensors[r.c.sensor].axis.accuracy);
            let iterated = |r: &Row<_>| r.c.estimator == Estimator::GaussNewton;
            let upper = |r: &Row<_>| r.position_p95_upper.unwrap_or(f64::INFINITY);
            cost(a)
                .total_cmp(&cost(b))
                .then(m.fitted(a.c.variant).cmp(&m.fitted(b.c.variant)))
                .then(a.c.poses.cmp(&b.c.poses))
                .then(iterated(a).cmp(&iterated(b)))
                .then(upper(a).total_cmp(&upper(b)))
                .then((a.c.estimator as u8).cmp(&(b.c.estimator as u8)))
        });
    let supposed = match chosen {
        Some(r) => what_ifs(cfg, &spec, study, r, (threads, sizes))?,
        None => Vec::new(),
    };
    let mut sentence = match (study.position_mm, chosen) {
        (None, _) => "No target was set ([decision] position_mm): the rows compare the encoders, and no choice is made".to_string(),
        (Some(t), None) => format!(
            "No combination keeps 95 % of machines within {t} mm{} everywhere in the workspace at the upper 95 % confidence limit: a finer encoder or one with less jitter, {}{}",
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
            "Buy {} × {} ({} per {}){}, calibrate with {} poses ({}): 95 % of machines within {:.4} mm (upper limit {:.4} mm){} everywhere in the workspace after compensation, against the {t} mm{} asked; uncalibrated, the median machine is {:.4} mm off",
            m.fitted(r.c.variant),
            spec.sensors[r.c.sensor].name,
            m.variant_words(r.c.variant)[0],
            w.joint,
            r.price.map_or(String::new(), |p| format!(" for {p}")),
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
        ) + "; it holds for " + &machines_words(m, &spec),
    };
    if let Some(r) = chosen.filter(|_| !supposed.is_empty()) {
        let name = &spec.sensors[r.c.sensor].name;
        let parts: Vec<String> = supposed
            .iter()
            .map(|(what, row)| match row {
                Some(x) => format!(
                    "{}: {:.4} mm{} at the upper limit ({})",
                    what.words(),
                    x.position_p95_upper.unwrap_or(f64::NAN),
                    if oriented {
                        format!(" and {:.2}″", x.orientation_p95_upper.unwrap_or(f64::NAN))
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
        sentence = format!(
            "{sentence}. If the encoders read otherwise than their datasheets say, the same choice reaches: {}",
            parts.join("; ")
        );
    }
    let fin = |x: f64| {
        if x.is_finite() {
            serde_json::json!(x)
        } else {
            serde_json::Value::Null
        }
    };
    let verdict = serde_json::json!({
        "mechanism": m.name(),
        "trials": spec.trials,
        "seed": spec.seed,
        "workspace_poses": spec.workspace.len(),
        "target_position_mm": study.position_mm,
        "target_orientation_arcsec": study.orientation_arcsec,
        "metric": "95th percentile over machines of the largest tool-point position error over the workspace after compensation, judged at its upper 95 % confidence limit",
        "chosen": chosen.map(|r| serde_json::json!({
            "encoder": spec.sensors[r.c.sensor].name,
            "per_joint": m.variant_name(r.c.variant),
            "encoders_fitted": m.fitted(r.c.variant),
            "price": r.price,
            "poses": r.c.poses,
            "estimator": r.c.estimator.name(),
            "position_p95_mm": fin(r.position_p95),
            "position_p95_upper95_mm": r.position_p95_upper.map(fin),
            "orientation_p95_arcsec": if oriented { fin(r.orientation_p95) } else { serde_json::Value::Null },
        })),
        "what_ifs": supposed.iter().map(|(w, row)| serde_json::json!({
            "what": w.words(),
            "applies": row.is_some(),
            "position_p95_upper95_mm": row.as_ref().and_then(|x| x.position_p95_upper).map(fin),
            "orientation_p95_upper95_arcsec": row.as_ref().and_then(|x| x.orientation_p95_upper).filter(|_| oriented).map(fin),
            "meets_target": row.as_ref().and_then(|x| x.meets),
        })).collect::<Vec<_>>(),
        "verdict": sentence,
    });
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &FILES);
    outputs.add(out.join(FILES[0]), csv.into_bytes());
    let mut json = serde_json::to_string_pretty(&verdict).unwrap_or_default();
    json.push('\n');
    outputs.add(out.join(FILES[1]), json.into_bytes());
    let chosen_index = chosen.map(|c| rows.iter().position(|r| std::ptr::eq(r, c)).unwrap_or(0));
    let figure = price_chart(m, &spec, study, &rows, chosen_index);
    let mut svg = None;
    if let Some(chart) = &figure {
        use crate::export::figures::Format;
        let png = chart.render(Format::Png)?;
        let text = chart.render(Format::Svg)?;
        outputs.add(out.join(names::PRICE_PNG), png);
        outputs.add(out.join(names::PRICE_SVG), text.clone());
        svg = Some(String::from_utf8_lossy(&text).into_owned());
    }
    let page = page(cfg, &spec, study, &rows, &sentence, svg)?;
    outputs.add(out.join(names::REPORT_HTML), page);
    outputs.write()?;
    console::line(format!(
        "{} study: {calibrations} calibrations ({} machines × {combos} combinations) in {secs:.2} s on {threads} {}: {:.0} calibrations/s",
        m.name(),
        spec.trials,
        if threads == 1 { "thread" } else { "threads" },
        calibrations as f64 / secs.max(1e-9)
    ));
    console::line(format!("verdict: {sentence}"));
    console::line(format!(
        "wrote summary.csv, verdict.json, report.html{} to {}",
        if figure.is_some() {
            " and price_accuracy.png/.svg"
        } else {
            ""
        },
        out.display()
    ));
    Ok(())
}
