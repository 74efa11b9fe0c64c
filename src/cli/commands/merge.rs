//! `merge`: combine shard directories into the outputs of one run — the
//! same `summary.csv`, `trials.csv` and figures, byte for byte.

use super::sweep::write_outputs;
use crate::cli::console;
use crate::cli::sweep_args::{shard_range, MAX_SHARDS};
use crate::config::{Config, RawConfig};
use crate::error::{Error, Result};
use crate::io;
use crate::montecarlo::{self, memory, Partial, SweepContext};
use crate::store::names::PARTIAL_JSON;
use crate::store::shards::{check_trials_file, concat_trials, read_partial};
use crate::store::state::read_shard_info;
use crate::store::{ShardInfo, TrialsFile, TrialsFormat};
use std::path::{Path, PathBuf};

/// `merge`: combine shard directories into the outputs of one run.
/// Every shard's metadata, checked to belong to one study; and the order
/// of shards 1..N as indices into it.
/// Every field of one shard's partial.json within its range and consistent
/// with the others: shard K of N holds exactly the trials a single run
/// gives it.
fn check_fields(info: &ShardInfo, dir: &Path) -> Result<()> {
    let file = dir.join(PARTIAL_JSON);
    let bad = |what: String| Err(Error::Argument(format!("{}: {what}", file.display())));
    if info.version != env!("CARGO_PKG_VERSION") {
        return bad(format!(
            "written by version {} of the tool, this is {}: rerun the shard with this version",
            info.version,
            env!("CARGO_PKG_VERSION")
        ));
    }
    if info.shards == 0 || info.shards > MAX_SHARDS {
        return bad(format!(
            "shards = {} is outside 1..={MAX_SHARDS}",
            info.shards
        ));
    }
    if info.shard == 0 || info.shard > info.shards {
        return bad(format!(
            "shard = {} is outside 1..={} (shards)",
            info.shard, info.shards
        ));
    }
    if info.trials == 0 || info.trials > 1_000_000_000 {
        return bad(format!(
            "trials = {} is outside 1..=1000000000",
            info.trials
        ));
    }
    let (first, count) = shard_range(info.trials, info.shard, info.shards);
    if (info.first_trial, info.trial_count) != (first, count) {
        return bad(format!(
            "shard {}/{} of {} trials holds trials {first}..{} but the file says {}..{}",
            info.shard,
            info.shards,
            info.trials,
            first + count,
            info.first_trial,
            info.first_trial.saturating_add(info.trial_count)
        ));
    }
    Ok(())
}

/// Each shard's metadata beside its directory.
type Shards<'a> = Vec<(ShardInfo, &'a PathBuf)>;

fn check_shards(dirs: &[PathBuf]) -> Result<(Shards<'_>, Vec<usize>)> {
    if dirs.is_empty() {
        return Err(Error::Argument(
            "merge needs at least one shard directory".into(),
        ));
    }
    let mut infos: Vec<(ShardInfo, &PathBuf)> = Vec::new();
    for d in dirs {
        let info = read_shard_info(d)?;
        check_fields(&info, d)?;
        infos.push((info, d));
    }
    let (first, first_dir) = (&infos[0].0, infos[0].1);
    for (info, d) in &infos[1..] {
        if info.config_json != first.config_json
            || info.seed != first.seed
            || info.trials != first.trials
        {
            let parse = |t: &str| serde_json::from_str::<serde_json::Value>(t).ok();
            let key = match (parse(&first.config_json), parse(&info.config_json)) {
                (Some(a), Some(b)) => first_difference(&a, &b, ""),
                _ => None,
            }
            .or_else(|| (info.seed != first.seed).then(|| "sweep.seed".to_string()))
            .or_else(|| (info.trials != first.trials).then(|| "sweep.trials".to_string()));
            return Err(Error::Argument(format!(
                "{} and {} come from different studies ({}): they cannot be merged",
                first_dir.display(),
                d.display(),
                match key {
                    Some(k) => format!("their configs differ at {k}"),
                    None => "their configs or seeds differ".to_string(),
                }
            )));
        }
        if info.catalogue_digest != first.catalogue_digest {
            let catalogue = serde_json::from_str::<serde_json::Value>(&first.config_json)
                .ok()
                .and_then(|c| c["sweep"]["catalogue"].as_str().map(str::to_string))
                .unwrap_or_else(|| "the catalogue".into());
            return Err(Error::Argument(format!(
                "{} and {} were run with different contents of {catalogue} (it was edited between the shards): rerun the shards with one catalogue",
                first_dir.display(),
                d.display()
            )));
        }
        if info.shards != first.shards {
            return Err(Error::Argument(format!(
                "{} is one of {} shards but {} is one of {}: they cannot be merged",
                d.display(),
                info.shards,
                first_dir.display(),
                first.shards
            )));
        }
    }
    let n = first.shards;
    let mut by_shard: Vec<Option<usize>> = vec![None; n as usize];
    for (i, (info, d)) in infos.iter().enumerate() {
        let slot = &mut by_shard[(info.shard - 1) as usize];
        if let Some(j) = slot {
            return Err(Error::Argument(format!(
                "shard {}/{n} appears twice ({} and {})",
                info.shard,
                infos[*j].1.display(),
                d.display()
            )));
        }
        *slot = Some(i);
    }
    if let Some(missing) = by_shard.iter().position(|s| s.is_none()) {
        return Err(Error::Argument(format!(
            "shard {}/{n} is missing",
            missing + 1
        )));
    }
    let order: Vec<usize> = by_shard.into_iter().flatten().collect();
    Ok((infos, order))
}

/// Refuse an output directory that is one of the shard directories read:
/// merging into it would replace the shard's own files.
fn refuse_out_among_inputs(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let same = |a: &Path, b: &Path| match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    };
    if let Some(d) = dirs.iter().find(|d| same(d, out)) {
        return Err(Error::Argument(format!(
            "--out {} is the shard directory {} that merge reads: merging into it would destroy that shard; choose another --out",
            out.display(),
            d.display()
        )));
    }
    Ok(())
}

pub fn run(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let started = std::time::Instant::now();
    refuse_out_among_inputs(dirs, out)?;
    let (infos, order) = check_shards(dirs)?;
    let (first, first_dir) = (&infos[0].0, infos[0].1);
    let n = first.shards;
    let raw: RawConfig = serde_json::from_str(&first.config_json).map_err(|e| {
        Error::Argument(format!(
            "{}: the recorded config cannot be read ({e})",
            first_dir.display()
        ))
    })?;
    let source = match first.config_source.is_empty() {
        true => format!("merged from {n} shards"),
        false => first.config_source.clone(),
    };
    let cfg = Config::from_raw(raw, &source)?;
    if cfg.catalogue_digest() != first.catalogue_digest.as_deref() {
        return Err(Error::Argument(format!(
            "{}: the catalogue {} has changed since the shards were run (its content differs): rerun the shards, or restore the catalogue they read",
            first_dir.display(),
            cfg.sweep
                .products
                .as_ref()
                .map_or("(none)".into(), |p| p.path.display().to_string())
        )));
    }
    let study = cfg.study().build()?;
    let with_trials = order.iter().all(|&i| infos[i].0.trials_csv);
    let format_of = |i: &ShardInfo| {
        TrialsFormat::parse(i.trials_format.as_deref().unwrap_or("csv")).ok_or_else(|| {
            Error::Argument(format!(
                "{}: unknown trials_format in partial.json",
                first_dir.display()
            ))
        })
    };
    let format = format_of(first)?;
    for &i in &order {
        if with_trials && format_of(&infos[i].0)? != format {
            return Err(Error::Argument(format!(
                "{} and {} store their trials in different formats (--trials-format): rerun the shards with one",
                first_dir.display(),
                infos[i].1.display()
            )));
        }
    }
    memory::check(
        &memory::Footprint {
            trials: first.trials,
            grades: study.grades(),
            errors: cfg.errors.len() as u64,
            rows: 3 * (study.poses.len() as u64 - 1),
            volumetric: study.sweep.volumetric_step_mm.is_some(),
            rows_csv: false,
            copies: 2,
            workers: 0,
            jitter_draws: 0,
            weight_columns: study.weight_columns(&cfg.sensors),
            recorded: study.recorded_grades(),
        },
        "this merge",
    )?;
    let ctx = SweepContext::new(&cfg, &study)?;
    let mut parts = Vec::with_capacity(order.len());
    for &i in &order {
        let (info, d) = &infos[i];
        let part = read_partial(
            d,
            info,
            n,
            (ctx.grades().len(), ctx.errors()),
            (ctx.volumetric(), ctx.oriented()),
        )?;
        if with_trials {
            check_trials_file(
                &d.join(format.file_name()),
                info,
                ctx.grades().len() as u64,
                format,
            )?;
        }
        parts.push(part);
    }
    // The results first: a study refused on them leaves --out untouched.
    let refs: Vec<&Partial> = parts.iter().collect();
    let mut result = montecarlo::finalize(&ctx, &study, &refs);
    super::sweep_checks::refuse_if_all_failed(&cfg, &result)?;
    montecarlo::add_follow_ups(&cfg, &study, &mut result, 0)?;
    let _lock = io::claim_dir(out)?;
    let mut trials = TrialsFile::new(out, with_trials, format)?;
    let dirs: Vec<&PathBuf> = order.iter().map(|&i| infos[i].1).collect();
    concat_trials(&dirs, &mut trials)?;
    trials.finish()?;
    result.computed = 0;
    result.wall_seconds = started.elapsed().as_secs_f64();
    let shards = order
        .iter()
        .map(|&i| format!("{}/{n}: {}", infos[i].0.shard, infos[i].1.display()))
        .collect();
    write_outputs(
        &cfg,
        &study,
        &result,
        out,
        with_trials.then_some(&trials),
        None,
        shards,
    )?;
    console::sweep_report(&result);
    Ok(())
}

/// The first key (dotted, in key order) at which two configs differ.
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, at: &str) -> Option<String> {
    use serde_json::Value;
    let join = |k: &str| {
        if at.is_empty() {
            k.to_string()
        } else {
            format!("{at}.{k}")
        }
    };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(p), Some(q)) => first_difference(p, q, &join(k)),
                _ => Some(join(k)),
            })
        }
        _ if a == b => None,
        _ => Some(if at.is_empty() {
            "the top level".to_string()
        } else {
            at.to_string()
        }),
    }
}
