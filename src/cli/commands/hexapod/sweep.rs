//! `sweep` for a hexapod: the `[sweep]` study's rows (summary.csv), its
//! verdict in the buyer's words (verdict.json and the console) and its
//! throughput.

use super::report::{fitted, page, price_chart, Row};
use crate::cli::console;
use crate::config::hexapod::{Estimator, HexapodConfig, Sensor, Spec, StudyConfig, WhatIf};
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::hexapod::Encoders;
use crate::metrics::stats::{quantile_sorted, quantile_upper95};
use crate::montecarlo::general::{Combination, Judged, Prepared};
use crate::store::names;
use std::path::Path;
use std::time::Instant;

/// What a hexapod sweep writes (stale ones are removed).
const FILES: [&str; 5] = [
    names::SUMMARY_CSV,
    names::VERDICT_JSON,
    names::REPORT_HTML,
    names::PRICE_PNG,
    names::PRICE_SVG,
];

/// Combination `c`'s row from its column `ci` of every trial's judgement.
fn row_of(
    judged: &[Vec<Judged>],
    ci: usize,
    c: &Combination<Encoders>,
    price: Option<f64>,
    study: &StudyConfig,
) -> Row {
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
fn what_ifs(
    cfg: &HexapodConfig,
    spec: &Spec,
    study: &StudyConfig,
    chosen: &Row,
    threads: usize,
) -> Result<Vec<(WhatIf, Option<Row>)>> {
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
        let prepared = Prepared::new(&cfg.hexapod, &cfg.poses, &sub)
            .map_err(|why| Error::config(&cfg.source, why))?;
        let judged = prepared
            .run(threads)
            .map_err(|why| Error::config(&cfg.source, why))?;
        let c = prepared.combinations[0];
        out.push((*w, Some(row_of(&judged, 0, &c, chosen.price, study))));
    }
    Ok(out)
}

/// `sweep` on a hexapod config's `text` (read from `source`): the Tricept's
/// study flags (`unsupported`, each with whether it was given) refused in
/// one sentence, `--trials` bounded as `sweep.trials`, then the study.
pub fn sweep_from_flags(
    text: &str,
    source: &str,
    out: &Path,
    (threads, trials, seed): (usize, Option<u64>, Option<u64>),
    unsupported: &[(&str, bool)],
) -> Result<()> {
    if let Some((flag, _)) = unsupported.iter().find(|(_, set)| *set) {
        return Err(Error::Argument(format!(
            "a hexapod sweep does not take {flag} (the Tricept's study does): it takes --config, --out, --trials, --seed and --threads"
        )));
    }
    if let Some(n) = trials.filter(|&n| n > 10_000_000) {
        return Err(Error::Argument(format!(
            "--trials must be at most 10000000 for a hexapod sweep (got {n}), as sweep.trials"
        )));
    }
    let cfg = HexapodConfig::parse(text, source)?;
    run_sweep(&cfg, out, threads, trials, seed)
}

pub fn run_sweep(
    cfg: &HexapodConfig,
    out: &Path,
    threads: usize,
    trials: Option<u64>,
    seed: Option<u64>,
) -> Result<()> {
    let Some(study) = &cfg.study else {
        return Err(Error::config(
            &cfg.source,
            "has no [sweep] section: a hexapod study needs one (sweep.catalogue or sweep.encoder_arcsec; docs/config.md, \"The hexapod\")",
        ));
    };
    let mut spec = study.spec.clone();
    if let Some(n) = trials {
        spec.trials = n;
    }
    if let Some(s) = seed {
        spec.seed = s;
    }
    let prepared = Prepared::new(&cfg.hexapod, &cfg.poses, &spec)
        .map_err(|why| Error::config(&cfg.source, why))?;
    let combos = prepared.combinations.len();
    let need = crate::montecarlo::general::result_bytes(combos, spec.trials);
    if need > 32 * crate::config::hexapod::MAX_RESULTS {
        return Err(Error::Argument(format!(
            "--trials {} × {combos} combinations needs {need} bytes of results, over 1 GiB: fewer trials",
            spec.trials
        )));
    }
    let _lock = io::claim_dir(out)?;
    let start = Instant::now();
    let judged = prepared
        .run(threads)
        .map_err(|why| Error::config(&cfg.source, why))?;
    let secs = start.elapsed().as_secs_f64();
    let calibrations = spec.trials * combos as u64;
    let rows: Vec<Row> = prepared
        .combinations
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let price = spec.sensors[c.sensor]
                .price
                .map(|p| p * fitted(c.variant) as f64);
            row_of(&judged, ci, c, price, study)
        })
        .collect();
    let num = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v}"));
    let mut csv = String::from("encoder,per_joint,encoders_fitted,price,poses,estimator,trials,position_before_median_mm,position_median_mm,position_p95_mm,position_p95_upper95_mm,orientation_median_arcsec,orientation_p95_arcsec,orientation_p95_upper95_arcsec,meets_target\n");
    for r in &rows {
        csv += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            spec.sensors[r.c.sensor].name,
            r.c.variant.name(),
            fitted(r.c.variant),
            num(r.price),
            r.c.poses,
            r.c.estimator.name(),
            spec.trials,
            r.position_before_median,
            r.position_median,
            r.position_p95,
            num(r.position_p95_upper),
            r.orientation_median,
            r.orientation_p95,
            num(r.orientation_p95_upper),
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
            let cost = |r: &Row| r.price.unwrap_or(-spec.sensors[r.c.sensor].axis.accuracy);
            let iterated = |r: &Row| r.c.estimator == Estimator::GaussNewton;
            let upper = |r: &Row| r.position_p95_upper.unwrap_or(f64::INFINITY);
            cost(a)
                .total_cmp(&cost(b))
                .then(fitted(a.c.variant).cmp(&fitted(b.c.variant)))
                .then(a.c.poses.cmp(&b.c.poses))
                .then(iterated(a).cmp(&iterated(b)))
                .then(upper(a).total_cmp(&upper(b)))
                .then((a.c.estimator as u8).cmp(&(b.c.estimator as u8)))
        });
    let supposed = match chosen {
        Some(r) => what_ifs(cfg, &spec, study, r, threads)?,
        None => Vec::new(),
    };
    let mut sentence = match (study.position_mm, chosen) {
        (None, _) => "No target was set ([decision] position_mm): the rows compare the encoders, and no choice is made".to_string(),
        (Some(t), None) => format!(
            "No combination keeps 95 % of machines within {t} mm{} everywhere in the workspace at the upper 95 % confidence limit: a finer encoder or one with less jitter, both encoders per joint{}",
            study.orientation_arcsec.map_or(String::new(), |o| format!(" and {o}″")),
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
            "Buy {} × {} ({} per U-joint){}, calibrate with {} poses ({}): 95 % of machines within {:.4} mm (upper limit {:.4} mm) and {:.2}″ (upper {:.2}″) everywhere in the workspace after compensation, against the {t} mm{} asked; uncalibrated, the median machine is {:.4} mm off",
            fitted(r.c.variant),
            spec.sensors[r.c.sensor].name,
            if r.c.variant == Encoders::Both { "two" } else { "one" },
            r.price.map_or(String::new(), |p| format!(" for {p}")),
            r.c.poses,
            r.c.estimator.name(),
            r.position_p95,
            r.position_p95_upper.unwrap_or(f64::NAN),
            r.orientation_p95,
            r.orientation_p95_upper.unwrap_or(f64::NAN),
            study.orientation_arcsec.map_or(String::new(), |o| format!(" and {o}″")),
            r.position_before_median,
        ) + "; it holds for " + &machines_words(&spec),
    };
    if let Some(r) = chosen.filter(|_| !supposed.is_empty()) {
        let name = &spec.sensors[r.c.sensor].name;
        let parts: Vec<String> = supposed
            .iter()
            .map(|(w, row)| match row {
                Some(x) => format!(
                    "{}: {:.4} mm and {:.2}″ at the upper limit ({})",
                    w.words(),
                    x.position_p95_upper.unwrap_or(f64::NAN),
                    x.orientation_p95_upper.unwrap_or(f64::NAN),
                    if x.meets == Some(true) {
                        "meets the target"
                    } else {
                        "misses the target"
                    }
                ),
                None => format!(
                    "{}: does not apply to {name} (no mounting eccentricity of its own)",
                    w.words()
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
        "mechanism": "hexapod",
        "trials": spec.trials,
        "seed": spec.seed,
        "workspace_poses": spec.workspace.len(),
        "target_position_mm": study.position_mm,
        "target_orientation_arcsec": study.orientation_arcsec,
        "metric": "95th percentile over machines of the largest tool-point position error over the workspace after compensation, judged at its upper 95 % confidence limit",
        "chosen": chosen.map(|r| serde_json::json!({
            "encoder": spec.sensors[r.c.sensor].name,
            "per_joint": r.c.variant.name(),
            "encoders_fitted": fitted(r.c.variant),
            "price": r.price,
            "poses": r.c.poses,
            "estimator": r.c.estimator.name(),
            "position_p95_mm": fin(r.position_p95),
            "position_p95_upper95_mm": r.position_p95_upper.map(fin),
            "orientation_p95_arcsec": fin(r.orientation_p95),
        })),
        "what_ifs": supposed.iter().map(|(w, row)| serde_json::json!({
            "what": w.words(),
            "applies": row.is_some(),
            "position_p95_upper95_mm": row.as_ref().and_then(|x| x.position_p95_upper).map(fin),
            "orientation_p95_upper95_arcsec": row.as_ref().and_then(|x| x.orientation_p95_upper).map(fin),
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
    let figure = price_chart(&spec, study, &rows, chosen_index);
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
        "hexapod study: {calibrations} calibrations ({} machines × {combos} combinations) in {secs:.2} s on {threads} threads: {:.0} calibrations/s",
        spec.trials,
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

/// The machines a verdict holds for, in words ("machines whose …"): the
/// bounds their errors were drawn within, and the errors fixed at
/// measured values.
pub fn machines_words(spec: &Spec) -> String {
    let names = crate::mechanism::hexapod::error_names();
    let fixed: Vec<&str> = spec.fixed.iter().map(|&(j, _)| names[j].as_str()).collect();
    format!(
        "machines whose joint centres and leg offsets are each within ±{} mm and encoder zeros within ±{}° of nominal (sweep.length_bound_mm, sweep.zero_bound_deg){}",
        spec.length_bound_mm,
        spec.zero_bound_deg,
        if fixed.is_empty() {
            String::new()
        } else {
            format!(", with {} fixed at measured values (identification.fix)", fixed.join(", "))
        }
    )
}
