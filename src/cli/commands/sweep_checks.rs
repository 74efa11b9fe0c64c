//! What a sweep checks around its trials: before any work, that the
//! study can state the confidence it claims and fits in memory, whether
//! `--out` already holds this study finished (or another one), and how large
//! trials.csv will be; after the trials, that there is something to report.

use crate::cli::console;
use crate::cli::sweep_args::{shard_range, SweepArgs};
use crate::config::{Config, ConfigStudy};
use crate::error::{Error, Result};
use crate::metrics::Confidence;
use crate::montecarlo::{memory, SweepContext, SweepResult};
use crate::store::names::*;
use crate::store::TrialsFormat;
use std::path::Path;

/// The finished study `out` holds (its manifest), and what differs between
/// it and this run: the tool's version, the config, the catalogue's
/// content, the trials file, adaptive stopping. None without a manifest.
fn differences(
    cfg: &Config,
    out: &Path,
    args: &SweepArgs,
) -> Option<(serde_json::Value, Vec<String>)> {
    let text = std::fs::read_to_string(out.join(MANIFEST_JSON)).ok()?;
    let m = serde_json::from_str::<serde_json::Value>(&text).ok()?;
    let mut changed = Vec::new();
    let files: Vec<&str> = m
        .get("files")
        .and_then(|f| f.as_array())
        .map(|f| f.iter().filter_map(|x| x.as_str()).collect())
        .unwrap_or_default();
    let wanted = args.write_trials.then(|| args.trials_format.file_name());
    let had = TRIALS_FILES.iter().find(|t| files.contains(t)).copied();
    if had != wanted {
        changed.push("the trials file (--no-trials or --trials-format)".to_string());
    }
    let adaptive = m.get("adaptive").map(|a| {
        (
            a.get("target_rel_half_width").and_then(|x| x.as_f64()),
            a.get("max_trials").and_then(|x| x.as_u64()),
        )
    });
    let asked = args
        .target_ci
        .map(|t| (Some(t), Some(args.max_trials.unwrap_or(cfg.sweep.trials))));
    if adaptive != asked {
        changed.push("adaptive stopping (--target-ci, --max-trials)".to_string());
    }
    if m.get("version").and_then(|v| v.as_str()) != Some(env!("CARGO_PKG_VERSION")) {
        changed.push("the tool's version".to_string());
    }
    let now = serde_json::to_value(cfg.resolved()).unwrap_or_default();
    if Some(&now) != m.get("config") {
        let keys = crate::store::state::config_differences(
            m.get("config").unwrap_or(&serde_json::Value::Null),
            &now,
        );
        changed.push(match keys.is_empty() {
            true => "the config".to_string(),
            false => format!("the config ({})", keys.join(", ")),
        });
    }
    if m.get("catalogue_digest").and_then(|d| d.as_str()) != cfg.catalogue_digest() {
        changed.push("the catalogue's content".to_string());
    }
    Some((m, changed))
}

/// Does `out` hold a finished unsharded sweep of this very study and mode,
/// its files in place? Its results are what this run would write.
pub(super) fn finished(cfg: &Config, out: &Path, args: &SweepArgs) -> bool {
    differences(cfg, out, args).is_some_and(|(m, changed)| {
        changed.is_empty()
            && m.get("command").and_then(|c| c.as_str()) == Some("sweep")
            && out.join(SUMMARY_CSV).exists()
            && (!args.write_trials || out.join(args.trials_format.file_name()).exists())
    })
}

/// What differs between the finished study in `out` and this run, in
/// words; None when there is none or nothing differs.
pub(super) fn finished_other(cfg: &Config, out: &Path, args: &SweepArgs) -> Option<String> {
    let (_, changed) = differences(cfg, out, args)?;
    (!changed.is_empty()).then(|| changed.join(", "))
}

/// Refuse a study whose deciding confidence limit cannot exist: with
/// `confidence = "upper95"` the limit of a 95th percentile needs at least 59
/// machines (the largest of n values is an upper 95 % limit only when
/// 1 − 0.95ⁿ ≥ 0.95); fewer could not claim the confidence the verdict states.
///
/// With `confidence = "auto"` (the default) a study too small for the limit
/// decides on the estimate instead (the verdict then says the margin is a
/// point estimate's).
pub(super) fn check_machines(
    cfg: &Config,
    study: &mut ConfigStudy,
    args: &SweepArgs,
) -> Result<()> {
    let d = &study.decision;
    if d.confidence != Confidence::Upper95 {
        return Ok(());
    }
    let (key, machines) = match (args.target_ci, args.max_trials) {
        (Some(_), Some(m)) => ("--max-trials", m),
        _ if args.trials_from_flag => ("--trials", cfg.sweep.trials),
        _ => ("sweep.trials", cfg.sweep.trials),
    };
    let needed = d.metric.machines_needed() as u64;
    if machines < needed && cfg.resolved().decision.confidence == "auto" {
        study.decision.confidence = Confidence::Estimate;
        study.decision.metric = study.decision.estimate;
        return Ok(());
    }
    if machines < needed {
        return Err(Error::config(
            &cfg.source,
            format!(
                "{key} = {machines} is too few machines for decision.confidence = \"upper95\": the {} of {} exists only from {needed} machines on (or use confidence = \"estimate\")",
                d.metric.limit_words(),
                d.estimate
            ),
        ));
    }
    Ok(())
}

/// Refuse a run that would not fit in memory (the trials this process runs).
pub(super) fn check_memory(cfg: &Config, study: &ConfigStudy, args: &SweepArgs) -> Result<()> {
    let trials = match args.target_ci {
        Some(_) => args.max_trials.unwrap_or(cfg.sweep.trials),
        None => match args.shard {
            Some((k, n)) => shard_range(cfg.sweep.trials, k, n).1,
            // until_decided may run up to its budget.
            None => cfg.sweep.until_decided_max.map_or(cfg.sweep.trials, |m| {
                args.max_trials.unwrap_or(m).max(cfg.sweep.trials)
            }),
        },
    };
    memory::check(
        &memory::Footprint {
            trials,
            grades: study.grades(),
            errors: cfg.errors.len() as u64,
            rows: 3 * (study.poses.len() as u64 - 1),
            volumetric: study.sweep.volumetric_step_mm.is_some(),
            rows_csv: args.write_trials,
            copies: if args.resume { 3 } else { 1 },
            workers: args.threads as u64,
            jitter_draws: cfg.jitter_draws(study.poses.len()),
            weight_columns: study.weight_columns(&cfg.sensors),
            recorded: study.recorded_grades(),
        },
        "this sweep",
    )
}

/// A study in which every trial failed has nothing to report.
pub fn refuse_if_all_failed(cfg: &Config, result: &SweepResult) -> Result<()> {
    if result.summary.iter().all(|r| r.trials == 0) {
        return Err(Error::config(
            &cfg.source,
            "sweep: every trial failed — no simulated machine reached all calibration poses; lower sweep.error_bound or move the poses inside the workspace",
        ));
    }
    // A combination whose workspace map failed for every machine has no
    // workspace statistic: no verdict can be made on it.
    if let Some(r) = result.summary.iter().find(|r| r.workspace_unjudged()) {
        return Err(Error::config(
            &cfg.source,
            format!(
                "sweep.volumetric: the workspace map failed for every one of the {} machines of {} (exact kinematics did not converge at some grid point after calibration); shrink [workspace], lower sweep.error_bound or set sweep.volumetric_exact = false",
                r.trials,
                combination(r)
            ),
        ));
    }
    Ok(())
}

/// Bytes a trials.csv row takes, about (measured on the shipped studies:
/// 110, and 205 with the five workspace columns).
const TRIALS_ROW_BYTES: u64 = 110;
const TRIALS_ROW_WORKSPACE_BYTES: u64 = 95;

/// Say, before a long run, when trials.csv will be large.
pub(super) fn announce_trials_file<
    M: crate::montecarlo::Studied<P, R, A>,
    const P: usize,
    const R: usize,
    const A: usize,
>(
    trials: u64,
    ctx: &SweepContext<M, P, R, A>,
    args: &SweepArgs,
) {
    if !args.write_trials {
        return;
    }
    let trials = args.max_trials.unwrap_or(trials);
    let row = TRIALS_ROW_BYTES
        + if ctx.volumetric() {
            TRIALS_ROW_WORKSPACE_BYTES
        } else {
            0
        };
    let csv = trials * ctx.grades().len() as u64 * row;
    // gzip (level 1) stores the rows in about a third (measured: 2.8× on
    // the shipped catalogue study, 3.8× on the grade study).
    let (name, bytes) = match args.trials_format {
        TrialsFormat::Csv => (crate::store::names::TRIALS_CSV, csv),
        TrialsFormat::Gzip => (crate::store::names::TRIALS_CSV_GZ, csv / 3),
    };
    if bytes >= 100_000_000 {
        let size = console::size_words(bytes);
        console::note(format_args!(
            "note: {name} will be about {size} (one row per calibration: {trials} trials × {} combinations); --no-trials leaves it out{}",
            ctx.grades().len(),
            match args.trials_format {
                TrialsFormat::Csv => ", --trials-format gz compresses it about 3×",
                TrialsFormat::Gzip => "",
            }
        ));
    }
}

/// A combination in words: its products (or grades), poses and estimator.
fn combination(r: &crate::metrics::GradeSummary) -> String {
    let sensors = match r.encoder.is_empty() {
        true => format!("{}″ + {} µm", r.encoder_arcsec, r.scale_um),
        false => format!("{} + {}", r.encoder, r.scale),
    };
    format!(
        "{sensors} with {} poses ({})",
        r.pose_count,
        r.method.name()
    )
}
