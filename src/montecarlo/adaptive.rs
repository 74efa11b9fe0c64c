//! Adaptive stopping: blocks of trials until the study's estimates are as
//! precise as asked. Deterministic: the trials are a prefix of the same
//! streams, checked after whole blocks.

use super::outcome::Failure;
use super::partial::{Partial, DV_PER_CALIBRATION};
use super::runner::{BlockRunner, RunOptions, BLOCK_TRIALS};
use super::summary::{finalize, SweepResult};
use super::trial::{Studied, SweepContext};
use crate::config::Study;
use crate::error::Result;
use crate::metrics::stats;

/// Adaptive stopping (JCGM 101 §7.9 style): blocks of trials until, for every
/// grade, the 95 % half-width of mean μ is at most `target_rel` × mean μ (and,
/// when the decision uses it, the 95 % CI of ratio_p95 has a half-width at
/// most `target_rel` × ratio_p95), or `max_trials` is reached. Deterministic:
/// the trials are a prefix of the same streams, checked after whole blocks.
pub fn run_adaptive<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
    target_rel: f64,
    max_trials: u64,
    opts: RunOptions,
) -> Result<(SweepResult, bool)> {
    let started = std::time::Instant::now();
    let mut runner = BlockRunner::new(ctx, 0, opts.threads, opts.sink)?;
    runner.report_to(opts.progress);
    let resumed = runner.resume(opts.resume);
    runner.start(resumed)?;
    let restored = runner.done();
    opts.progress.start(max_trials, restored);
    let target_met = |p: &Partial| target_met(ctx, study, p, target_rel);
    // A resumed run checks what it recovered first, as the killed run did.
    let mut met = restored > 0 && target_met(&runner.partial);
    while !met && runner.partial.trials < max_trials {
        let n = ((max_trials - runner.partial.trials) as usize).min(BLOCK_TRIALS);
        runner.run_block(n)?;
        met = target_met(&runner.partial);
    }
    opts.progress.finish();
    let result = summarise(ctx, study, &runner.partial, restored, started, opts.threads);
    Ok((result, met))
}

/// `[sweep] until_decided`: the study's `trials` machines, then blocks of
/// machines until no combination's interval holds the threshold where it
/// would change the answer ([`crate::metrics::ranking::undecided`]), or
/// `max_trials`. Deterministic: a prefix of the same streams, checked after
/// whole blocks. The bool: the study decided.
pub fn run_until_decided<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
    max_trials: u64,
    opts: RunOptions,
) -> Result<(SweepResult, bool)> {
    let started = std::time::Instant::now();
    let min_trials = opts.trials;
    let mut runner = BlockRunner::new(ctx, 0, opts.threads, opts.sink)?;
    runner.report_to(opts.progress);
    let resumed = runner.resume(opts.resume);
    runner.start(resumed)?;
    let restored = runner.done();
    opts.progress.start(max_trials, restored);
    let decided = |p: &Partial| {
        let r = finalize(ctx, study, &[p]);
        crate::metrics::ranking::undecided(&r.ranking).is_empty()
    };
    let done = loop {
        let have = runner.partial.trials;
        if have >= min_trials {
            let d = decided(&runner.partial);
            if d || have >= max_trials {
                break d;
            }
        }
        let goal = if have < min_trials {
            min_trials
        } else {
            max_trials
        };
        let n = ((goal - have) as usize).min(BLOCK_TRIALS);
        runner.run_block(n)?;
    };
    opts.progress.finish();
    let result = summarise(ctx, study, &runner.partial, restored, started, opts.threads);
    Ok((result, done))
}

/// The result of the trials a stopping rule ran (`restored` of them
/// recovered by --resume), timed from `started`.
fn summarise<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
    partial: &Partial,
    restored: u64,
    started: std::time::Instant,
    threads: usize,
) -> SweepResult {
    let trials_seconds = started.elapsed().as_secs_f64();
    let mut result = finalize(ctx, study, &[partial]);
    result.trials_seconds = trials_seconds;
    result.summary_seconds = started.elapsed().as_secs_f64() - trials_seconds;
    result.computed = (partial.trials - restored) * ctx.grades.len() as u64;
    result.trials = partial.trials;
    result.calibrations = partial.trials * ctx.grades.len() as u64;
    result.wall_seconds = started.elapsed().as_secs_f64();
    result.threads = threads;
    result
}

/// The adaptive stopping rule on the trials so far: for every grade the
/// relative 95 % half-width of mean μ (and, when the decision uses ratio_p95,
/// that of ratio_p95) is at most `target_rel`. Computes exactly the values
/// [`finalize`] reports, but only those, in O(n) per check (no sorting), so
/// checking after every block stays cheap for long runs.
fn target_met<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
    p: &Partial,
    target_rel: f64,
) -> bool {
    let g = ctx.grades.len();
    let need_p95 = study.decision.metric.uses_ratio_p95();
    let series = study
        .decision
        .metric
        .volumetric_series()
        .filter(|_| p.volumetric);
    let mut mu = Vec::with_capacity(p.trials as usize);
    let mut ratio = Vec::with_capacity(if need_p95 { p.trials as usize } else { 0 });
    let mut dv = Vec::with_capacity(if series.is_some() {
        p.trials as usize
    } else {
        0
    });
    (0..g).all(|gi| {
        mu.clear();
        ratio.clear();
        dv.clear();
        for t in 0..p.trials as usize {
            let k = t * g + gi;
            if p.failure_at(k) != Failure::ForwardKinematics {
                mu.push(p.mu[k]);
                if need_p95 {
                    ratio.push(p.mu[k] / p.mu0[t]);
                }
                if let Some((i, _)) = series {
                    let v = p.dv[DV_PER_CALIBRATION * k + i];
                    if v.is_finite() {
                        dv.push(v);
                    }
                }
            }
        }
        let (mean, half) = stats::mean_ci95(&mu);
        let ok_mu = mu.len() >= 2 && half / mean <= target_rel;
        let ok_ratio = !need_p95 || {
            match stats::quantile_with_ci95(&mut ratio, 0.95) {
                (q, Some(lo), Some(hi)) => (hi - lo) / 2.0 / q <= target_rel,
                _ => false,
            }
        };
        // The deciding workspace metric itself: its quantile's
        // order-statistics CI, or the t CI of its mean.
        let ok_dv = match series {
            None => true,
            Some(_) if dv.len() < 2 => false,
            Some((_, Some(q))) => match stats::quantile_with_ci95(&mut dv, q) {
                (v, Some(lo), Some(hi)) => (hi - lo) / 2.0 / v <= target_rel,
                _ => false,
            },
            Some((_, None)) => {
                let (m, h) = stats::mean_ci95(&dv);
                h / m <= target_rel
            }
        };
        ok_mu && ok_ratio && ok_dv
    })
}
