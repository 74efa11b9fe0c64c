//! `sweep` (single, sharded, adaptive).
//!
//! A shard `--shard K/N` runs whole blocks [(K−1)·B/N, K·B/N) of the B blocks
//! of the study with exactly the per-trial streams a single run uses, and
//! writes a partial result: `partial.bin` (per-calibration records, see
//! [`Partial`]), `trials.csv` (its rows) and `partial.json` (what was run;
//! written last, so its presence marks a complete shard). `merge` checks that
//! the partials belong together and writes the same outputs as a single run.

use super::sweep_checks::{
    announce_trials_file, check_machines, check_memory, finished, finished_other,
    refuse_if_all_failed,
};
use crate::cli::console;
use crate::cli::sweep_args::{shard_range, SweepArgs};
use crate::config::{Config, ConfigStudy, ErrorDraw, RawConfig};
use crate::error::{Error, Result};
use crate::export::figures::Format;
use crate::export::html::HtmlExporter;
use crate::export::page::study_page;
use crate::export::views::{
    budget_chart, grade_map_chart, parameter_chart, price_chart, sweep_chart, workspace_chart,
};
use crate::export::{csv_bytes, Exporter, JsonExporter};
use crate::io;
use crate::metrics::mu0;
use crate::metrics::DecisionRow;
use crate::montecarlo::{self, SweepContext, SweepResult};
use crate::store::names::*;
use crate::store::outputs::{write_shard, StudyOutputs};
use crate::store::state::{
    config_json, prepare_state, read_shard_info, Adaptive, ResumeNote, ShardInfo,
};
use crate::store::TrialsFile;
use serde::Serialize;
use std::path::Path;

/// The sweep's manifest.
#[derive(Serialize)]
struct Manifest<'a> {
    tool: &'static str,
    version: &'static str,
    command: &'static str,
    config_source: &'a str,
    config: &'a RawConfig,
    /// The catalogue's content digest: with the config and the version,
    /// the study's identity.
    #[serde(skip_serializing_if = "Option::is_none")]
    catalogue_digest: Option<&'a str>,
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
    decision: &'a [DecisionRow],
    /// The buyer's answer (the paragraph the run prints).
    answer: String,
    /// The verdict's status (verdict.json has its parts).
    verdict: &'static str,
    files: Vec<&'static str>,
}

/// Render and write every output of a finished study; `trials` commits
/// trials.csv first.
pub fn write_outputs(
    cfg: &Config,
    study: &ConfigStudy,
    result: &SweepResult,
    out: &Path,
    trials: Option<&TrialsFile>,
    adaptive: Option<Adaptive>,
    shards: Vec<String>,
) -> Result<()> {
    let mut outputs = StudyOutputs::new(out, trials);
    outputs.add(SUMMARY_CSV, csv_bytes(result.summary_rows())?);
    outputs.add(PARAMETERS_CSV, csv_bytes(&result.parameters)?);
    // A row is chosen only when the verdict buys it (not while undecided).
    let buys = crate::export::verdict::of(result).status == "buy";
    let ranking: Vec<_> = result
        .ranking
        .iter()
        .cloned()
        .map(|mut r| {
            r.chosen &= buys;
            r
        })
        .collect();
    outputs.add(DECISION_CSV, csv_bytes(&ranking)?);
    outputs.add(BUDGET_CSV, csv_bytes(&result.budget)?);
    if !result.decision_budget.is_empty() {
        outputs.add(
            DECISION_BUDGET_CSV,
            crate::export::rows::decision_budget_csv(&result.decision_budget)?,
        );
    }
    // Every figure once: its PNG and SVG, and the SVG on the page, in the
    // page's order (price first when the study has prices).
    type Render<'a> = Box<dyn Fn(Format) -> Result<Vec<u8>> + 'a>;
    let mut figures: Vec<(&str, &'static str, &'static str, Render)> = Vec::new();
    if let Some(c) = price_chart(study, result) {
        figures.push((
            "price_accuracy: sensor price against accuracy",
            PRICE_PNG,
            PRICE_SVG,
            Box::new(move |f| c.render(f)),
        ));
    }
    let c = sweep_chart(study, result);
    figures.push((
        "fig4: μ/μ0 against the encoder grade",
        FIG4_PNG,
        FIG4_SVG,
        Box::new(move |f| c.render(f)),
    ));
    let c = budget_chart(study, result);
    figures.push((
        "budget: where the error after calibration comes from",
        BUDGET_PNG,
        BUDGET_SVG,
        Box::new(move |f| c.render(f)),
    ));
    if let Some(c) = workspace_chart(study, result) {
        figures.push((
            "workspace: dV after compensation against grade",
            WORKSPACE_PNG,
            WORKSPACE_SVG,
            Box::new(move |f| c.render(f)),
        ));
    }
    if let Some(c) = grade_map_chart(study, result) {
        figures.push((
            "grade_map: the deciding metric per encoder × scale grade",
            GRADE_MAP_PNG,
            GRADE_MAP_SVG,
            Box::new(move |f| c.render(f)),
        ));
    }
    let c = parameter_chart(study, result);
    figures.push((
        "parameters: Monte-Carlo spread against the linear prediction",
        PARAMETERS_PNG,
        PARAMETERS_SVG,
        Box::new(move |f| c.render(f)),
    ));
    let mut page_figures = Vec::new();
    for (caption, png, svg, render) in &figures {
        outputs.add(png, render(Format::Png)?);
        let bytes = render(Format::Svg)?;
        page_figures.push((
            caption.to_string(),
            String::from_utf8_lossy(&bytes).into_owned(),
        ));
        outputs.add(svg, bytes);
    }
    outputs.add(
        REPORT_HTML,
        HtmlExporter.render(&study_page(cfg, study, result, page_figures))?,
    );
    let verdict = crate::export::verdict::of(result);
    outputs.add(VERDICT_JSON, JsonExporter.render(&verdict)?);
    let manifest = Manifest {
        tool: "tricept-calib",
        version: env!("CARGO_PKG_VERSION"),
        command: if shards.is_empty() { "sweep" } else { "merge" },
        config_source: &cfg.source,
        config: cfg.resolved(),
        catalogue_digest: cfg.catalogue_digest(),
        seed: cfg.sweep.seed,
        trials: result.trials,
        grades: result.summary.len() + result.truth.len(),
        threads: result.threads,
        wall_seconds: result.wall_seconds,
        calibrations: result.calibrations,
        calibrations_per_second: result.calibrations_per_second(),
        adaptive,
        shards,
        decision: &result.decisions,
        answer: verdict.text.clone(),
        verdict: verdict.status,
        files: outputs.listed(),
    };
    outputs.write(JsonExporter.render(&manifest)?)
}

/// `sweep`: single run, one shard, or adaptive.
pub fn run(cfg: &Config, out: &Path, args: &SweepArgs) -> Result<()> {
    let begun = std::time::Instant::now();
    let mut study = cfg.study().build()?;
    if study.sweep.errors == ErrorDraw::Fixed
        && mu0(&cfg.errors) == 0.0
        && study.decision.metric.is_ratio()
    {
        return Err(Error::config(
            &cfg.source,
            format!(
                "errors: every error is 0, so μ0 = 0 and μ/μ0 is undefined: decision.metric = \"{}\" needs a non-zero [errors] table or sweep.errors = \"random\"",
                study.decision.metric
            ),
        ));
    }
    check_machines(cfg, &mut study, args)?;
    check_memory(cfg, &study, args)?;
    // The study's set-up (poses, workspace map) is checked before the
    // output folder is touched.
    let ctx = SweepContext::new(cfg, &study)?;
    let _lock = io::claim_dir(out)?;
    if let Some((k, n)) = args.shard {
        return run_shard(cfg, &ctx, out, args, k, n);
    }
    let state_dir = out.join(SWEEP_STATE_DIR);
    if args.resume && finished(cfg, out, args) {
        let _ = std::fs::remove_dir_all(&state_dir);
        console::line(format_args!(
            "the sweep in {} is complete (manifest.json records this config); nothing to resume",
            out.display()
        ));
        return Ok(());
    }
    if args.resume && !state_dir.join(crate::store::names::STATE_JSON).exists() {
        if let Some(what) = finished_other(cfg, out, args) {
            console::note(format_args!(
                "note: {} holds a finished study, but {what} changed since: running this one from the beginning",
                out.display()
            ));
        }
    }
    if args.restart && state_dir.join(crate::store::names::STATE_JSON).exists() {
        console::note(format_args!(
            "note: discarding the interrupted sweep in {} (--restart)",
            out.display()
        ));
    }
    let (mut trials, resume, note) = prepare_state(
        cfg,
        out,
        &state_dir,
        &args.mode(),
        (args.resume, args.restart),
        (ctx.grades().len(), ctx.volumetric()),
    )?;
    console::resume_note(note, out, &state_dir);
    console::resume_on_interrupt();
    announce_trials_file(cfg.sweep.trials, &ctx, args);
    if note == ResumeNote::Fresh {
        console::note(format_args!(
            "note: if this sweep is interrupted, the same command with --resume continues it from its last complete block"
        ));
    }
    let progress = console::SweepProgress::new("sweep");
    let started = std::time::Instant::now();
    let setup_seconds = begun.elapsed().as_secs_f64();
    let opts = montecarlo::RunOptions {
        trials: cfg.sweep.trials,
        threads: args.threads,
        progress: &progress,
        sink: &mut trials,
        resume,
    };
    let (result, adaptive) = match args.target_ci {
        Some(rel) => {
            let max = args.max_trials.unwrap_or(cfg.sweep.trials);
            let (r, met) = montecarlo::run_adaptive(&ctx, &study, rel, max, opts)?;
            let a = Adaptive {
                target_rel_half_width: rel,
                max_trials: max,
                trials_used: r.trials,
                target_met: met,
            };
            (r, Some(a))
        }
        None => match cfg.sweep.until_decided_max {
            Some(max) => {
                let max = args.max_trials.unwrap_or(max).max(cfg.sweep.trials);
                let (r, decided) = montecarlo::run_until_decided(&ctx, &study, max, opts)?;
                if r.trials > cfg.sweep.trials || !decided {
                    console::note(format_args!(
                        "note: sweep.until_decided: {} machines {} (sweep.trials {}, at most {max})",
                        r.trials,
                        if decided { "decided the study" } else { "did not decide it" },
                        cfg.sweep.trials
                    ));
                }
                (r, None)
            }
            None => (montecarlo::run(&ctx, &study, opts)?, None),
        },
    };
    trials.finish()?;
    if let Err(e) = refuse_if_all_failed(cfg, &result) {
        // Deterministic: a rerun would fail the same way, so there is
        // nothing to resume.
        let _ = std::fs::remove_dir_all(&state_dir);
        return Err(e);
    }
    let mut result = result;
    montecarlo::add_follow_ups(cfg, &study, &mut result, args.threads)?;
    result.wall_seconds = started.elapsed().as_secs_f64();
    let writing = std::time::Instant::now();
    write_outputs(
        cfg,
        &study,
        &result,
        out,
        args.write_trials.then_some(&trials),
        adaptive,
        Vec::new(),
    )?;
    let _ = std::fs::remove_dir_all(&state_dir);
    console::sweep_report(&result);
    console::phases(&console::Phases {
        setup: setup_seconds,
        trials: result.trials_seconds,
        summary: result.summary_seconds,
        outputs: writing.elapsed().as_secs_f64(),
        total: begun.elapsed().as_secs_f64(),
    });
    if let Some(a) = adaptive {
        console::adaptive_report(&a, &result);
    }
    if args.json {
        console::json(&crate::export::verdict::of(&result))?;
    }
    target_met(&result, args.require_target)
}

/// With `--require-target`, the distinct failure of a study where no
/// combination meets the target (its outputs are written first).
pub fn target_met(result: &SweepResult, required: bool) -> Result<()> {
    let met = result.ranking.first().is_some_and(|r| r.chosen);
    if required && !met {
        return Err(Error::TargetNotMet(
            "no combination meets the target (--require-target); the outputs are written".into(),
        ));
    }
    Ok(())
}

fn run_shard<
    M: crate::montecarlo::Studied<P, R, A>,
    const P: usize,
    const R: usize,
    const A: usize,
>(
    cfg: &Config,
    ctx: &SweepContext<M, P, R, A>,
    out: &Path,
    args: &SweepArgs,
    k: u64,
    n: u64,
) -> Result<()> {
    let json = config_json(cfg)?;
    if args.resume {
        if let Ok(info) = read_shard_info(out) {
            if info.config_json == json
                && info.catalogue_digest.as_deref() == cfg.catalogue_digest()
                && info.trials_csv == args.write_trials
                && info.trials_format.as_deref().unwrap_or("csv") == args.trials_format.name()
                && info.shard == k
                && info.shards == n
                && out.join(PARTIAL_BIN).exists()
            {
                console::line(format_args!(
                    "shard {k}/{n} is already complete in {}; nothing to do (--resume)",
                    out.display()
                ));
                return Ok(());
            }
        }
    }
    let (first, count) = shard_range(cfg.sweep.trials, k, n);
    if count == 0 {
        let blocks = cfg.sweep.trials.div_ceil(montecarlo::BLOCK_TRIALS as u64);
        return Err(Error::Argument(format!(
            "--shard {k}/{n}: the study's {} trials make {blocks} block(s) of {} trials, so shard {k} would run none; use at most {blocks} shard(s)",
            cfg.sweep.trials,
            montecarlo::BLOCK_TRIALS
        )));
    }
    let started = std::time::Instant::now();
    let mut trials = TrialsFile::new(out, args.write_trials, args.trials_format)?;
    let partial = {
        let progress = console::SweepProgress::new(&format!("shard {k}/{n}"));
        let mut runner = montecarlo::BlockRunner::new(ctx, first, args.threads, &mut trials)?;
        runner.report_to(&progress);
        runner.write_header()?;
        montecarlo::Progress::start(&progress, count, 0);
        runner.run_trials(count)?;
        montecarlo::Progress::finish(&progress);
        runner.partial
    };
    trials.finish()?;
    let wall = started.elapsed().as_secs_f64();
    let info = ShardInfo {
        tool: "tricept-calib".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        config_json: json,
        catalogue_digest: cfg.catalogue_digest().map(str::to_string),
        config_source: cfg.source.clone(),
        seed: cfg.sweep.seed,
        trials: cfg.sweep.trials,
        shard: k,
        shards: n,
        first_trial: first,
        trial_count: count,
        trials_csv: args.write_trials,
        trials_format: Some(args.trials_format.name().to_string()),
        wall_seconds: wall,
    };
    write_shard(out, args.write_trials.then_some(&trials), &partial, &info)?;
    let calib = count * ctx.grades().len() as u64;
    console::line(format_args!(
        "shard {k}/{n}: trials {first}..{} ({calib} calibrations) in {wall:.3} s = {:.0} calibrations/s; merge with `tricept-calib merge DIR... --out DIR`",
        first + count,
        calib as f64 / wall.max(1e-9)
    ));
    if args.json {
        console::json(&ShardJson {
            shard: k,
            shards: n,
            first_trial: first,
            trial_count: count,
            calibrations: calib,
            wall_seconds: wall,
            out: out.display().to_string(),
        })?;
    }
    Ok(())
}

/// A shard's result for scripts (`sweep --shard K/N --json`): which trials
/// it ran and where its partial result is; `merge` gives the verdict.
#[derive(serde::Serialize)]
struct ShardJson {
    shard: u64,
    shards: u64,
    first_trial: u64,
    trial_count: u64,
    calibrations: u64,
    wall_seconds: f64,
    out: String,
}
