//! `merge`: combine shard directories into the outputs of one run — the
//! same `summary.csv`, `trials.csv` and figures, byte for byte.

use super::sweep::write_outputs;
use crate::cli::console;
use crate::cli::sweep_args::{shard_range, MAX_SHARDS};
use crate::config::{Config, RawConfig};
use crate::error::{Error, Result};
use crate::export::names::{PARTIAL_BIN, PARTIAL_JSON};
use crate::io;
use crate::montecarlo::{self, memory, Partial, SweepContext, TrialSink};
use crate::store::state::read_shard_info;
use crate::store::{partial, ShardInfo, TrialsFile, TrialsFormat};
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

/// Lines of a shard's trials.csv: header + one per calibration, each ended
/// by a newline (a truncated file is refused before anything is written).
fn check_trials_csv(
    path: &Path,
    info: &ShardInfo,
    grades: u64,
    format: TrialsFormat,
) -> Result<()> {
    let expected_rows = info.trial_count * grades;
    let f = std::fs::File::open(path).map_err(|e| Error::io("read", path, e))?;
    // trials.csv.gz is read through its decompression: its rows are checked
    // as trials.csv's are, and a damaged stream is an error here.
    let raw: Box<dyn std::io::Read> = match format {
        TrialsFormat::Csv => Box::new(f),
        TrialsFormat::Gzip => Box::new(flate2::read::MultiGzDecoder::new(
            std::io::BufReader::with_capacity(1 << 20, f),
        )),
    };
    let mut r = std::io::BufReader::with_capacity(1 << 20, raw);
    let (mut lines, mut last) = (0u64, b'\n');
    // The trial column of the first and the last row.
    let mut first_row: Vec<u8> = Vec::new();
    let mut tail: Vec<u8> = Vec::new();
    loop {
        let buf = std::io::BufRead::fill_buf(&mut r).map_err(|e| match format {
            // A damaged stream is the shard's fault (bad input), not the disk's.
            TrialsFormat::Gzip => Error::Argument(format!(
                "{}: damaged gzip stream ({e}): the file is truncated or does not belong to this shard",
                path.display()
            )),
            TrialsFormat::Csv => Error::io("read", path, e),
        })?;
        if buf.is_empty() {
            break;
        }
        for &b in buf {
            if lines == 1 && b != b'\n' {
                first_row.push(b);
            }
            if b == b'\n' {
                lines += 1;
                if lines < expected_rows + 1 {
                    tail.clear();
                }
            } else if lines >= 1 {
                tail.push(b);
            }
        }
        last = buf[buf.len() - 1];
        let n = buf.len();
        std::io::BufRead::consume(&mut r, n);
    }
    let trial = |row: &[u8]| {
        std::str::from_utf8(row)
            .ok()
            .and_then(|r| r.split(',').nth(3))
            .and_then(|t| t.parse::<u64>().ok())
    };
    let ends = (trial(&first_row), trial(&tail));
    let want = (
        Some(info.first_trial),
        Some(info.first_trial + info.trial_count.saturating_sub(1)),
    );
    if last != b'\n' || lines != expected_rows + 1 || (expected_rows > 0 && ends != want) {
        return Err(Error::Argument(format!(
            "{}: {} complete lines where the shard holds {} calibrations (+1 header): the file is truncated or does not belong to this shard",
            path.display(),
            lines,
            expected_rows
        )));
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
            return Err(Error::Argument(format!(
                "{} and {} come from different configs or seeds: they cannot be merged",
                first_dir.display(),
                d.display()
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

/// The trials files of the shards, in order, under one header. A gzip
/// file's header is its first member, the same bytes in every shard: the
/// rest of each file is copied as it is.
fn concat_trials(dirs: &[&PathBuf], trials: &mut TrialsFile) -> Result<()> {
    if trials.rows().is_none() {
        return Ok(());
    }
    let format = trials.format();
    let header = format.header();
    trials.write(&header)?;
    for d in dirs {
        let p = d.join(format.file_name());
        let f = std::fs::File::open(&p).map_err(|e| Error::io("read", &p, e))?;
        let mut r = std::io::BufReader::new(f);
        let mut first = vec![0u8; header.len()];
        let whole = std::io::Read::read_exact(&mut r, &mut first).is_ok();
        if !whole || first != header {
            return Err(Error::Argument(format!(
                "{}: unexpected header",
                p.display()
            )));
        }
        let mut buf = vec![0u8; 1 << 20];
        loop {
            let n = std::io::Read::read(&mut r, &mut buf).map_err(|e| Error::io("read", &p, e))?;
            if n == 0 {
                break;
            }
            trials.write(&buf[..n])?;
        }
    }
    Ok(())
}

pub fn run(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let started = std::time::Instant::now();
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
            rows: 3 * (study.poses.len() as u64 - 1),
            volumetric: study.sweep.volumetric_step_mm.is_some(),
            rows_csv: false,
            copies: 2,
            workers: 0,
            jitter_draws: 0,
        },
        "this merge",
    )?;
    let ctx = SweepContext::new(&cfg, &study)?;
    let mut parts = Vec::with_capacity(order.len());
    for &i in &order {
        let (info, d) = &infos[i];
        let p = d.join(PARTIAL_BIN);
        let g = ctx.grades.len();
        let blocks = info.trial_count.div_ceil(montecarlo::BLOCK_TRIALS as u64);
        let expected = partial::encoded_len(info.trial_count, g as u64, ctx.volumetric(), blocks);
        let len = std::fs::metadata(&p)
            .map_err(|e| Error::io("read", &p, e))?
            .len();
        if len as u128 != expected {
            return Err(Error::Argument(format!(
                "{}: {len} bytes where shard {}/{n} of this study holds {expected}: truncated or not this study's",
                p.display(),
                info.shard
            )));
        }
        let bytes = std::fs::read(&p).map_err(|e| Error::io("read", &p, e))?;
        let part = partial::decode(&bytes)
            .filter(|x| {
                x.first_trial == info.first_trial
                    && x.trials == info.trial_count
                    && x.grades == g
                    && x.volumetric == ctx.volumetric()
                    && x.block_err_sum.len() as u64 == blocks * g as u64
            })
            .ok_or_else(|| {
                Error::Argument(format!(
                    "{}: truncated or does not match partial.json",
                    p.display()
                ))
            })?;
        if with_trials {
            check_trials_csv(
                &d.join(format.file_name()),
                info,
                ctx.grades.len() as u64,
                format,
            )?;
        }
        parts.push(part);
    }
    // The results first: a study refused on them leaves --out untouched.
    let refs: Vec<&Partial> = parts.iter().collect();
    let mut result = montecarlo::finalize(&ctx, &study, &refs);
    super::sweep_checks::refuse_if_all_failed(&cfg, &result)?;
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
