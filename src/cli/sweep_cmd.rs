//! `sweep` (single, sharded, adaptive) and `merge`.
//!
//! A shard `--shard K/N` runs whole blocks [(K−1)·B/N, K·B/N) of the B blocks
//! of the study with exactly the per-trial streams a single run uses, and
//! writes a partial result: `partial.bin` (per-calibration records, see
//! [`sweep::Partial`]), `trials.csv` (its rows) and `partial.json` (what was
//! run; written last, so its presence marks a complete shard). `merge`
//! checks that the partials belong together and writes the same outputs as a
//! single run — `summary.csv` byte for byte, `trials.csv` identical.

use super::commands::{grade_map, parameter_chart, print_summary, sweep_chart};
use crate::config::{Config, RawConfig};
use crate::error::{Error, Result};
use crate::export::plot::Format;
use crate::export::{Exporter, JsonExporter};
use crate::io::{self, Outputs};
use crate::sweep::{self, Partial, SweepContext, SweepResult, BLOCK_TRIALS};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How to run a sweep.
#[derive(Debug, Clone, Default)]
pub struct SweepArgs {
    pub threads: usize,
    pub write_trials: bool,
    /// (K, N), 1 ≤ K ≤ N.
    pub shard: Option<(u64, u64)>,
    pub target_ci: Option<f64>,
    pub max_trials: Option<u64>,
    pub resume: bool,
}

/// Parse "K/N".
pub fn parse_shard(s: &str) -> Result<(u64, u64)> {
    let bad = || {
        Error::Argument(format!(
            "--shard must be K/N with 1 <= K <= N (got \"{s}\")"
        ))
    };
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let k: u64 = k.trim().parse().map_err(|_| bad())?;
    let n: u64 = n.trim().parse().map_err(|_| bad())?;
    if k == 0 || n == 0 || k > n || n > 100_000 {
        return Err(bad());
    }
    Ok((k, n))
}

/// Metadata of a shard's partial result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ShardInfo {
    pub tool: String,
    pub version: String,
    /// The resolved config as JSON text: merges compare it byte for byte.
    pub config_json: String,
    pub seed: u64,
    pub trials: u64,
    pub shard: u64,
    pub shards: u64,
    pub first_trial: u64,
    pub trial_count: u64,
    pub trials_csv: bool,
    pub wall_seconds: f64,
}

/// Trials [first, first + count) of shard K of N.
pub fn shard_range(trials: u64, k: u64, n: u64) -> (u64, u64) {
    let blocks = trials.div_ceil(BLOCK_TRIALS as u64);
    let b0 = (k - 1) * blocks / n;
    let b1 = k * blocks / n;
    let first = (b0 * BLOCK_TRIALS as u64).min(trials);
    let end = (b1 * BLOCK_TRIALS as u64).min(trials);
    (first, end - first)
}

fn config_json(cfg: &Config) -> Result<String> {
    serde_json::to_string(&cfg.raw)
        .map_err(|e| Error::Internal(format!("cannot serialise the config: {e}")))
}

/// A temporary trials.csv that becomes `final_path` only on success.
struct TrialsFile {
    tmp: PathBuf,
    final_path: PathBuf,
    w: Option<std::io::BufWriter<std::fs::File>>,
    /// Keep the temporary file when dropped (resumable runs).
    keep: bool,
}

impl TrialsFile {
    fn new(out: &Path, enabled: bool) -> Result<Self> {
        let tmp = out.join(format!(".trials.csv.tmp-{}", std::process::id()));
        Self::at(tmp, out.join("trials.csv"), enabled, None, false)
    }

    /// At a given temporary path; `resume_len`: keep the first bytes of an
    /// existing file and append after them.
    fn at(
        tmp: PathBuf,
        final_path: PathBuf,
        enabled: bool,
        resume_len: Option<u64>,
        keep: bool,
    ) -> Result<Self> {
        let w = if enabled {
            let f = match resume_len {
                Some(len) => {
                    let f = std::fs::OpenOptions::new()
                        .write(true)
                        .open(&tmp)
                        .map_err(|e| Error::io("reopen", &tmp, e))?;
                    f.set_len(len).map_err(|e| Error::io("truncate", &tmp, e))?;
                    let mut f = f;
                    std::io::Seek::seek(&mut f, std::io::SeekFrom::End(0))
                        .map_err(|e| Error::io("reopen", &tmp, e))?;
                    f
                }
                None => std::fs::File::create(&tmp).map_err(|e| Error::io("create", &tmp, e))?,
            };
            Some(std::io::BufWriter::with_capacity(1 << 20, f))
        } else {
            None
        };
        Ok(TrialsFile {
            tmp,
            final_path,
            w,
            keep,
        })
    }
    fn writer(&mut self) -> Option<&mut dyn std::io::Write> {
        self.w.as_mut().map(|w| w as &mut dyn std::io::Write)
    }
    /// Flush and sync; the rename happens in [`TrialsFile::commit`].
    fn finish(&mut self) -> Result<()> {
        if let Some(w) = self.w.take() {
            let f = w
                .into_inner()
                .map_err(|e| Error::io("write", &self.final_path, e.into_error()))?;
            f.sync_all()
                .map_err(|e| Error::io("write", &self.final_path, e))?;
        }
        Ok(())
    }
    fn commit(&self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.final_path)
            .map_err(|e| Error::io("write", &self.final_path, e))
    }
}

impl Drop for TrialsFile {
    fn drop(&mut self) {
        // Left only when something failed before commit.
        if !self.keep {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// The sweep's manifest.
#[derive(Serialize)]
struct Manifest<'a> {
    tool: &'static str,
    version: &'static str,
    command: &'static str,
    config_source: &'a str,
    config: &'a RawConfig,
    seed: u64,
    trials: u64,
    grades: usize,
    threads: usize,
    wall_seconds: f64,
    calibrations: u64,
    calibrations_per_second: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    adaptive: Option<Adaptive>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    shards: Vec<String>,
    decision: &'a [sweep::DecisionRow],
    files: Vec<&'static str>,
}

#[derive(Serialize, Clone, Copy)]
struct Adaptive {
    target_rel_half_width: f64,
    max_trials: u64,
    trials_used: u64,
    target_met: bool,
}

/// Render and write every output of a finished study; `trials` commits
/// trials.csv first.
fn write_outputs(
    cfg: &Config,
    ctx: &SweepContext,
    result: &SweepResult,
    out: &Path,
    trials: Option<&TrialsFile>,
    adaptive: Option<Adaptive>,
    shards: Vec<String>,
) -> Result<()> {
    let mut outputs = Outputs::default();
    outputs.add(out.join("summary.csv"), io::csv_bytes(&result.summary)?);
    outputs.add(
        out.join("parameters.csv"),
        io::csv_bytes(&result.parameters)?,
    );
    outputs.add(out.join("decision.csv"), io::csv_bytes(&result.decisions)?);
    let chart = sweep_chart(cfg, result);
    outputs.add(out.join("fig4.png"), chart.render(Format::Png)?);
    outputs.add(out.join("fig4.svg"), chart.render(Format::Svg)?);
    outputs.add(
        out.join("parameters.png"),
        parameter_chart(cfg, result).render(Format::Png)?,
    );
    let mut files = vec![
        "summary.csv",
        "parameters.csv",
        "parameters.png",
        "decision.csv",
        "fig4.png",
        "fig4.svg",
        "manifest.json",
    ];
    if let Some(map) = grade_map(cfg, result) {
        outputs.add(out.join("grade_map.png"), map.render(Format::Png)?);
        outputs.add(out.join("grade_map.svg"), map.render(Format::Svg)?);
        files.extend(["grade_map.png", "grade_map.svg"]);
    }
    if trials.is_some() {
        files.insert(0, "trials.csv");
    }
    let manifest = Manifest {
        tool: "tricept-calib",
        version: env!("CARGO_PKG_VERSION"),
        command: if shards.is_empty() { "sweep" } else { "merge" },
        config_source: &cfg.source,
        config: &cfg.raw,
        seed: cfg.sweep.seed,
        trials: result.trials,
        grades: ctx.grades.len(),
        threads: result.threads,
        wall_seconds: result.wall_seconds,
        calibrations: result.calibrations,
        calibrations_per_second: result.calibrations_per_second(),
        adaptive,
        shards,
        decision: &result.decisions,
        files,
    };
    outputs.add(
        out.join("manifest.json"),
        JsonExporter {
            name: "manifest.json",
        }
        .render(&manifest)?,
    );
    if let Some(t) = trials {
        t.commit()?;
    }
    outputs.write()?;
    Ok(())
}

/// Print the summary table, the decision, throughput and uncertainty notes.
fn report(result: &SweepResult) {
    print_summary(result);
    for p in &result.parameters {
        let disagree = !(0.8..=1.25).contains(&p.ratio_mc_to_predicted);
        if p.identifiable && disagree && result.trials >= 100 {
            println!(
                "note: {} at {}\" / {} um ({}): Monte-Carlo std {:.4} mm vs linear prediction {:.4} mm (ratio {:.2}) — the linear uncertainty model is not reliable here",
                p.parameter, p.encoder_arcsec, p.scale_um, p.method, p.mc_std_mm, p.predicted_std_mm, p.ratio_mc_to_predicted
            );
        }
    }
}

/// `sweep`: single run, one shard, or adaptive.
pub fn sweep(cfg: &Config, out: &Path, args: &SweepArgs) -> Result<()> {
    io::ensure_dir(out)?;
    let ctx = SweepContext::new(cfg)?;
    let progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    if let Some((k, n)) = args.shard {
        return run_shard(cfg, &ctx, out, args, k, n, progress);
    }
    let state_dir = out.join(".sweep-state");
    let (mut trials, mut checkpoint) = prepare_state(cfg, out, &state_dir, args)?;
    let started = std::time::Instant::now();
    let opts = sweep::RunOptions {
        trials: cfg.sweep.trials,
        threads: args.threads,
        progress,
        trials_out: trials.writer(),
        trials_path: out.join("trials.csv"),
        checkpoint: checkpoint.take(),
    };
    let (result, adaptive) = match args.target_ci {
        Some(rel) => {
            let max = args.max_trials.unwrap_or(cfg.sweep.trials);
            let (r, met) = sweep::run_adaptive(&ctx, cfg, rel, max, opts)?;
            let a = Adaptive {
                target_rel_half_width: rel,
                max_trials: max,
                trials_used: r.trials,
                target_met: met,
            };
            (r, Some(a))
        }
        None => (sweep::run(&ctx, cfg, opts)?, None),
    };
    trials.finish()?;
    let mut result = result;
    result.wall_seconds = started.elapsed().as_secs_f64();
    write_outputs(
        cfg,
        &ctx,
        &result,
        out,
        args.write_trials.then_some(&trials),
        adaptive,
        Vec::new(),
    )?;
    drop(checkpoint);
    let _ = std::fs::remove_dir_all(&state_dir);
    report(&result);
    if let Some(a) = adaptive {
        println!(
            "adaptive: {} trials used of at most {}; target half-width {} × mean {}",
            a.trials_used,
            a.max_trials,
            a.target_rel_half_width,
            if a.target_met {
                "met for every grade"
            } else {
                "NOT met: raise --max-trials"
            }
        );
        for r in &result.summary {
            println!(
                "  {}\" / {} um / {}: mean mu {:.5} ± {:.5} mm (relative {:.4})",
                r.encoder_arcsec,
                r.scale_um,
                r.method,
                r.mu_mean,
                (r.mu_mean_ci_high - r.mu_mean_ci_low) / 2.0,
                (r.mu_mean_ci_high - r.mu_mean_ci_low) / 2.0 / r.mu_mean
            );
        }
    }
    Ok(())
}

/// What an interrupted unsharded sweep must match to be resumed.
#[derive(Serialize)]
struct SweepState<'a> {
    config_json: &'a str,
    target_ci: Option<f64>,
    max_trials: Option<u64>,
    trials_csv: bool,
}

/// Set up the block log and trials file of an unsharded sweep in
/// `out/.sweep-state`; with `--resume`, continue what a killed run left.
fn prepare_state(
    cfg: &Config,
    out: &Path,
    state_dir: &Path,
    args: &SweepArgs,
) -> Result<(TrialsFile, Option<sweep::Checkpoint>)> {
    let json = config_json(cfg)?;
    let state = serde_json::to_string(&SweepState {
        config_json: &json,
        target_ci: args.target_ci,
        max_trials: args.max_trials,
        trials_csv: args.write_trials,
    })
    .map_err(|e| Error::Internal(e.to_string()))?;
    let state_path = state_dir.join("state.json");
    let log_path = state_dir.join("blocks.bin");
    let part_path = state_dir.join("trials.csv.part");
    let mut recovered = None;
    if args.resume {
        match std::fs::read_to_string(&state_path) {
            Ok(text) if text == state => {
                let log = std::fs::read(&log_path).unwrap_or_default();
                recovered = sweep::Checkpoint::read(&log);
                if let Some((p, _, _)) = &recovered {
                    println!("resuming after {} completed trials from {}", p.trials, state_dir.display());
                }
            }
            Ok(_) => {
                return Err(Error::Argument(format!(
                    "{} holds an interrupted sweep with a different config, seed or mode: remove it or choose another --out",
                    state_dir.display()
                )))
            }
            Err(_) => println!("no interrupted sweep in {}; starting from the beginning", out.display()),
        }
    }
    let (trials, log) = match recovered {
        Some((partial, trials_bytes, log_len)) => {
            let trials = TrialsFile::at(
                part_path,
                out.join("trials.csv"),
                args.write_trials,
                Some(trials_bytes),
                true,
            )?;
            let log = std::fs::OpenOptions::new()
                .write(true)
                .open(&log_path)
                .map_err(|e| Error::io("reopen", &log_path, e))?;
            log.set_len(log_len)
                .map_err(|e| Error::io("truncate", &log_path, e))?;
            let mut log = log;
            std::io::Seek::seek(&mut log, std::io::SeekFrom::End(0))
                .map_err(|e| Error::io("reopen", &log_path, e))?;
            (
                trials,
                sweep::Checkpoint {
                    file: log,
                    path: log_path,
                    resume: Some((partial, trials_bytes)),
                },
            )
        }
        None => {
            let _ = std::fs::remove_dir_all(state_dir);
            std::fs::create_dir_all(state_dir).map_err(|e| Error::io("create", state_dir, e))?;
            io::write_atomic(&state_path, state.as_bytes())?;
            let trials = TrialsFile::at(
                part_path,
                out.join("trials.csv"),
                args.write_trials,
                None,
                true,
            )?;
            let log =
                std::fs::File::create(&log_path).map_err(|e| Error::io("create", &log_path, e))?;
            (
                trials,
                sweep::Checkpoint {
                    file: log,
                    path: log_path,
                    resume: None,
                },
            )
        }
    };
    Ok((trials, Some(log)))
}

fn read_shard_info(dir: &Path) -> Result<ShardInfo> {
    let p = dir.join("partial.json");
    let text = std::fs::read_to_string(&p).map_err(|_| {
        Error::Argument(format!(
            "{}: not a complete shard (no partial.json)",
            dir.display()
        ))
    })?;
    serde_json::from_str(&text)
        .map_err(|e| Error::Argument(format!("{}: malformed shard metadata ({e})", p.display())))
}

fn run_shard(
    cfg: &Config,
    ctx: &SweepContext,
    out: &Path,
    args: &SweepArgs,
    k: u64,
    n: u64,
    progress: bool,
) -> Result<()> {
    let json = config_json(cfg)?;
    if args.resume {
        if let Ok(info) = read_shard_info(out) {
            if info.config_json == json
                && info.shard == k
                && info.shards == n
                && out.join("partial.bin").exists()
            {
                println!(
                    "shard {k}/{n} is already complete in {}; nothing to do (--resume)",
                    out.display()
                );
                return Ok(());
            }
        }
    }
    let (first, count) = shard_range(cfg.sweep.trials, k, n);
    let started = std::time::Instant::now();
    let mut trials = TrialsFile::new(out, args.write_trials)?;
    let partial = {
        let mut runner = sweep::BlockRunner::new(
            ctx,
            first,
            args.threads,
            trials.writer(),
            out.join("trials.csv"),
        )?;
        runner.write_header()?;
        runner.run_trials(count, progress)?;
        runner.partial
    };
    trials.finish()?;
    let wall = started.elapsed().as_secs_f64();
    let info = ShardInfo {
        tool: "tricept-calib".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        config_json: json,
        seed: cfg.sweep.seed,
        trials: cfg.sweep.trials,
        shard: k,
        shards: n,
        first_trial: first,
        trial_count: count,
        trials_csv: args.write_trials,
        wall_seconds: wall,
    };
    // Remove a stale marker first: partial.json is written last.
    let _ = std::fs::remove_file(out.join("partial.json"));
    if args.write_trials {
        trials.commit()?;
    }
    io::write_atomic(&out.join("partial.bin"), &partial.to_bytes())?;
    let meta = serde_json::to_vec_pretty(&info).map_err(|e| Error::Internal(e.to_string()))?;
    io::write_atomic(&out.join("partial.json"), &meta)?;
    let calib = count * ctx.grades.len() as u64;
    println!(
        "shard {k}/{n}: trials {first}..{} ({calib} calibrations) in {wall:.3} s = {:.0} calibrations/s; merge with `tricept-calib merge DIR... --out DIR`",
        first + count,
        calib as f64 / wall.max(1e-9)
    );
    Ok(())
}

/// `merge`: combine shard directories into the outputs of one run.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<()> {
    if dirs.is_empty() {
        return Err(Error::Argument(
            "merge needs at least one shard directory".into(),
        ));
    }
    let started = std::time::Instant::now();
    let mut infos: Vec<(ShardInfo, &PathBuf)> = Vec::new();
    for d in dirs {
        infos.push((read_shard_info(d)?, d));
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
    let raw: RawConfig = serde_json::from_str(&first.config_json).map_err(|e| {
        Error::Argument(format!(
            "{}: the recorded config cannot be read ({e})",
            first_dir.display()
        ))
    })?;
    let cfg = Config::from_raw(raw, &format!("merged from {} shards", n))?;
    let ctx = SweepContext::new(&cfg)?;
    let mut parts = Vec::with_capacity(order.len());
    for &i in &order {
        let (info, d) = &infos[i];
        let p = d.join("partial.bin");
        let bytes = std::fs::read(&p).map_err(|e| Error::io("read", &p, e))?;
        let part = Partial::from_bytes(&bytes)
            .filter(|x| {
                x.first_trial == info.first_trial
                    && x.trials == info.trial_count
                    && x.grades == ctx.grades.len()
            })
            .ok_or_else(|| {
                Error::Argument(format!(
                    "{}: truncated or does not match partial.json",
                    p.display()
                ))
            })?;
        parts.push(part);
    }
    io::ensure_dir(out)?;
    let with_trials = order.iter().all(|&i| infos[i].0.trials_csv);
    let mut trials = TrialsFile::new(out, with_trials)?;
    if let Some(w) = trials.writer() {
        w.write_all(sweep::TRIALS_HEADER.as_bytes())
            .map_err(|e| Error::io("write", out.join("trials.csv"), e))?;
        for &i in &order {
            let p = infos[i].1.join("trials.csv");
            let f = std::fs::File::open(&p).map_err(|e| Error::io("read", &p, e))?;
            let mut r = std::io::BufReader::new(f);
            let mut header = String::new();
            std::io::BufRead::read_line(&mut r, &mut header)
                .map_err(|e| Error::io("read", &p, e))?;
            if header != sweep::TRIALS_HEADER {
                return Err(Error::Argument(format!(
                    "{}: unexpected header",
                    p.display()
                )));
            }
            std::io::copy(&mut r, w).map_err(|e| Error::io("write", out.join("trials.csv"), e))?;
        }
    }
    trials.finish()?;
    let refs: Vec<&Partial> = parts.iter().collect();
    let mut result = sweep::finalize(&ctx, &cfg, &refs);
    result.wall_seconds = started.elapsed().as_secs_f64();
    let shards = order
        .iter()
        .map(|&i| format!("{}/{n}: {}", infos[i].0.shard, infos[i].1.display()))
        .collect();
    write_outputs(
        &cfg,
        &ctx,
        &result,
        out,
        with_trials.then_some(&trials),
        None,
        shards,
    )?;
    report(&result);
    Ok(())
}
