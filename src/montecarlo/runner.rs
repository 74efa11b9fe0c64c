//! The batch runner: whole blocks of trials on a rayon pool, gathered in
//! trial order into a [`Partial`], rows and block records to a
//! [`TrialSink`]. Results do not depend on the thread count; each
//! calibration's records do not depend on the block size either (the
//! per-block sums of the estimates' errors do: every Tricept study runs
//! blocks of [`BLOCK_TRIALS`]).

use super::outcome::Outcome;
use super::partial::Partial;
use super::sink::{NoRows, RowEncoder, TrialSink, ROWS_PER_RUN};
use super::summary::{finalize, SweepResult};
use super::trial::{run_trial, Scratch, Studied, SweepContext};
use crate::config::{Config, ConfigStudy, Study};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// Trials processed (and written) per block of a Tricept study; memory is
/// bounded by this, and a calibration's records do not depend on it.
pub const BLOCK_TRIALS: usize = 8192;

/// Trials between two progress reports inside a block.
const PROGRESS_STEP: usize = 2048;

/// Where a run reports how far it is (the CLI draws a bar or a heartbeat;
/// the library prints nothing). Called from the thread driving the run.
pub trait Progress: Sync {
    /// `total` trials will have run at the end, `done` of them already.
    fn start(&self, _total: u64, _done: u64) {}
    /// `trials` more are done.
    fn advance(&self, _trials: u64) {}
    fn finish(&self) {}
}

/// No progress reports.
pub struct Silent;

impl Progress for Silent {}

/// Options of one run.
pub struct RunOptions<'a> {
    pub trials: u64,
    pub threads: usize,
    pub progress: &'a dyn Progress,
    /// Where trials.csv rows and the block log go ([`NoRows`] for
    /// --no-trials without a log).
    pub sink: &'a mut dyn TrialSink,
    /// What a previous run left, verified (`--resume`): the sink holds
    /// exactly its rows and continues its block log.
    pub resume: Option<Partial>,
}

/// Computes whole blocks of trials, in order, into a [`Partial`], writing
/// trials.csv rows as it goes.
pub struct BlockRunner<'c, 'w, M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>
{
    ctx: &'c SweepContext<M, P, R, A>,
    pool: rayon::ThreadPool,
    outcomes: Vec<Outcome>,
    /// The previous block's outcomes while their records are written.
    spare: Vec<Outcome>,
    /// The block's linearisation errors of the context's `recorded`
    /// grades (one a trial and recorded grade; one slot a trial when none
    /// is recorded), and the previous block's.
    lin: Vec<f64>,
    lin_spare: Vec<f64>,
    /// Each calibration's estimate − truth (trial-major, grade-minor, as
    /// the outcomes), and the previous block's.
    err: Vec<f64>,
    err_spare: Vec<f64>,
    sink: &'w mut dyn TrialSink,
    progress: &'w dyn Progress,
    pub partial: Partial,
    next_trial: u64,
    /// Trials a block (at most [`BLOCK_TRIALS`]).
    block: usize,
    /// Errors whose estimate − truth the partial sums a calibration:
    /// the study's, or 0 where only the records are kept
    /// ([`BlockRunner::records_only`]).
    kept: usize,
}

impl<'c, 'w, M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>
    BlockRunner<'c, 'w, M, P, R, A>
{
    pub fn new(
        ctx: &'c SweepContext<M, P, R, A>,
        first_trial: u64,
        threads: usize,
        sink: &'w mut dyn TrialSink,
    ) -> Result<Self> {
        Self::with_blocks(ctx, (first_trial, BLOCK_TRIALS), threads, sink)
    }

    /// A runner of blocks of `block` trials (1 to [`BLOCK_TRIALS`]): fewer
    /// hold less where a calibration estimates many errors. Only the
    /// partial's per-block error sums depend on it, not a calibration's
    /// records.
    pub fn with_blocks(
        ctx: &'c SweepContext<M, P, R, A>,
        (first_trial, block): (u64, usize),
        threads: usize,
        sink: &'w mut dyn TrialSink,
    ) -> Result<Self> {
        Self::build(ctx, (first_trial, block), threads, sink, ctx.errors())
    }

    /// A runner that keeps each calibration's records alone (μ, failure,
    /// workspace and orientation errors; [`Partial::records_only`]), not
    /// the per-block sums of its estimates' errors, in blocks of `block`
    /// trials from trial 0: what a study that reads only its
    /// calibrations' judgements needs, in memory that grows with its
    /// calibrations alone.
    pub fn records_only(
        ctx: &'c SweepContext<M, P, R, A>,
        block: usize,
        threads: usize,
        sink: &'w mut dyn TrialSink,
    ) -> Result<Self> {
        Self::build(ctx, (0, block), threads, sink, 0)
    }

    fn build(
        ctx: &'c SweepContext<M, P, R, A>,
        (first_trial, block): (u64, usize),
        threads: usize,
        sink: &'w mut dyn TrialSink,
        kept: usize,
    ) -> Result<Self> {
        let block = block.clamp(1, BLOCK_TRIALS);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Error::Internal(format!("cannot start {threads} worker threads: {e}")))?;
        Ok(BlockRunner {
            ctx,
            pool,
            outcomes: vec![Outcome::default(); block * ctx.grades.len()],
            spare: vec![Outcome::default(); block * ctx.grades.len()],
            lin: vec![0.0; block * ctx.recorded.len().max(1) * kept],
            lin_spare: vec![0.0; block * ctx.recorded.len().max(1) * kept],
            err: vec![0.0; block * ctx.grades.len() * kept],
            err_spare: vec![0.0; block * ctx.grades.len() * kept],
            sink,
            progress: &Silent,
            partial: match kept {
                0 => Partial::records_only(ctx),
                _ => Partial::new(ctx, first_trial),
            },
            next_trial: first_trial,
            block,
            kept,
        })
    }

    /// Bytes a runner's buffers hold per trial of a block (its outcomes,
    /// estimates − truth and linearisation errors, and the previous
    /// block's while it is recorded), for the caller to count before work.
    /// With `sums`, the runner of [`BlockRunner::with_blocks`]; without,
    /// of [`BlockRunner::records_only`].
    pub fn bytes_per_trial(ctx: &SweepContext<M, P, R, A>, sums: bool) -> usize {
        let g = ctx.grades.len();
        let kept = if sums { ctx.errors() } else { 0 };
        let floats = (g + ctx.recorded.len().max(1)) * kept;
        2 * (g * std::mem::size_of::<Outcome>() + floats * std::mem::size_of::<f64>())
    }

    /// Continue after a previous run's records (the sink must already
    /// hold exactly its rows). Returns true when it resumed.
    pub fn resume(&mut self, from: Option<Partial>) -> bool {
        match from {
            Some(p)
                if p.first_trial == self.next_trial
                    && p.grades == self.ctx.grades.len()
                    && p.errors == self.kept
                    && (p.volumetric, p.oriented)
                        == (self.ctx.volumetric(), self.ctx.oriented()) =>
            {
                self.next_trial = p.first_trial + p.trials;
                self.partial = p;
                true
            }
            _ => false,
        }
    }

    /// Start a new run: the trials.csv header (skipped after a resume).
    pub fn start(&mut self, resumed: bool) -> Result<()> {
        if resumed {
            Ok(())
        } else {
            self.write_header()
        }
    }

    /// Write the trials.csv header.
    pub fn write_header(&mut self) -> Result<()> {
        self.sink.write_header()
    }

    /// Run the next `count` (≤ the runner's block) trials as one block.
    pub fn run_block(&mut self, count: usize) -> Result<()> {
        if count > self.block {
            return Err(Error::Internal(format!(
                "a block of {count} trials in a runner of {}",
                self.block
            )));
        }
        let Self {
            ctx,
            pool,
            outcomes,
            lin,
            err,
            sink,
            progress,
            partial,
            next_trial,
            kept,
            ..
        } = self;
        let start = *next_trial;
        let block = &mut outcomes[..count * ctx.grades.len()];
        let p = *kept;
        let err = &mut err[..count * ctx.grades.len() * p];
        let lin = &mut lin[..count * ctx.recorded.len().max(1) * p];
        let rows = sink.rows();
        let texts =
            pool.install(|| compute_block(ctx, *progress, start, (block, err, lin, p), rows));
        let mut books = Books {
            sink: &mut **sink,
            partial,
        };
        books.record(ctx, start, (block, err, lin), &texts)?;
        *next_trial += count as u64;
        Ok(())
    }

    /// Run `count` more trials in blocks, pipelined: while the pool computes
    /// a block, one of its threads writes the previous block's rows and
    /// records (the same files and bytes as block by block).
    pub fn run_trials(&mut self, count: u64) -> Result<()> {
        let Self {
            ctx,
            pool,
            outcomes,
            spare,
            lin,
            lin_spare,
            err,
            err_spare,
            sink,
            progress,
            partial,
            next_trial,
            block,
            kept,
        } = self;
        let block = *block;
        let g = ctx.grades.len();
        let r = ctx.recorded.len().max(1);
        let p = *kept;
        let rows = sink.rows();
        let mut books = Books {
            sink: &mut **sink,
            partial,
        };
        let end = *next_trial + count;
        // The computed block awaiting its records: (first trial, trials, rows).
        let mut pending: Option<(u64, usize, Vec<Vec<u8>>)> = None;
        while *next_trial < end || pending.is_some() {
            let start = *next_trial;
            let n = ((end - start) as usize).min(block);
            let (current, previous) = (&mut outcomes[..n * g], &spare[..]);
            let (current_lin, previous_lin) = (&mut lin[..n * r * p], &lin_spare[..]);
            let (current_err, previous_err) = (&mut err[..n * g * p], &err_spare[..]);
            let (texts, recorded) = pool.install(|| {
                rayon::join(
                    || {
                        compute_block(
                            ctx,
                            *progress,
                            start,
                            (current, current_err, current_lin, p),
                            rows,
                        )
                    },
                    || match &pending {
                        Some((first, done, texts)) => books.record(
                            ctx,
                            *first,
                            (
                                &previous[..done * g],
                                &previous_err[..done * g * p],
                                &previous_lin[..done * r * p],
                            ),
                            texts,
                        ),
                        None => Ok(()),
                    },
                )
            });
            recorded?;
            pending = (n > 0).then_some((start, n, texts));
            *next_trial += n as u64;
            std::mem::swap(outcomes, spare);
            std::mem::swap(lin, lin_spare);
            std::mem::swap(err, err_spare);
        }
        Ok(())
    }
}

/// Compute one block's outcomes in the current pool (and its trials.csv
/// rows, encoded by `rows`, when asked).
fn compute_block<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    progress: &dyn Progress,
    start: u64,
    (block, err, lin, p): (&mut [Outcome], &mut [f64], &mut [f64], usize),
    rows: Option<RowEncoder>,
) -> Vec<Vec<u8>> {
    let g = ctx.grades.len();
    let r = ctx.recorded.len().max(1);
    if p == 0 {
        // The records alone: no estimate's error is copied out.
        for (c, part) in block.chunks_mut(PROGRESS_STEP * g).enumerate() {
            let first = start + (c * PROGRESS_STEP) as u64;
            part.par_chunks_mut(g).enumerate().for_each_init(
                || Scratch::new(ctx),
                |s, (i, slot)| run_trial(ctx, first + i as u64, s, slot),
            );
            progress.advance((part.len() / g) as u64);
        }
        return encoded(ctx, start, block, rows);
    }
    for (c, ((part, err_part), lin_part)) in block
        .chunks_mut(PROGRESS_STEP * g)
        .zip(err.chunks_mut(PROGRESS_STEP * g * p))
        .zip(lin.chunks_mut(PROGRESS_STEP * r * p))
        .enumerate()
    {
        let first = start + (c * PROGRESS_STEP) as u64;
        part.par_chunks_mut(g)
            .zip(err_part.par_chunks_mut(g * p))
            .zip(lin_part.par_chunks_mut(r * p))
            .enumerate()
            .for_each_init(
                || Scratch::new(ctx),
                |s, (i, ((slot, err_slot), lin_slot))| {
                    run_trial(ctx, first + i as u64, s, slot);
                    for (gi, x) in err_slot.chunks_exact_mut(p).enumerate() {
                        x.copy_from_slice(s.error(gi).as_slice());
                    }
                    for (x, &gi) in lin_slot.chunks_exact_mut(p).zip(&ctx.recorded) {
                        x.copy_from_slice(s.linearisation(gi).as_slice());
                    }
                },
            );
        progress.advance((part.len() / g) as u64);
    }
    encoded(ctx, start, block, rows)
}

/// A computed block's trials.csv rows, encoded by `rows` (none without).
fn encoded<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    start: u64,
    block: &[Outcome],
    rows: Option<RowEncoder>,
) -> Vec<Vec<u8>> {
    let g = ctx.grades.len();
    let Some(encode) = rows else {
        return Vec::new();
    };
    block
        .par_chunks(ROWS_PER_RUN * g)
        .enumerate()
        .map(|(c, part)| {
            encode(
                (&ctx.grades, &ctx.grade_cells),
                start + (c * ROWS_PER_RUN) as u64,
                part,
            )
        })
        .collect()
}

/// Where computed blocks go, in trial order: the sink (trials.csv, the
/// block log) and the partial.
struct Books<'a> {
    sink: &'a mut dyn TrialSink,
    partial: &'a mut Partial,
}

impl Books<'_> {
    /// Write one computed block: its rows, then (with a block log) its
    /// record, and add it to the partial.
    fn record<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
        &mut self,
        ctx: &SweepContext<M, P, R, A>,
        start: u64,
        (block, err, lin): (&[Outcome], &[f64], &[f64]),
        texts: &[Vec<u8>],
    ) -> Result<()> {
        for t in texts {
            self.sink.write(t)?;
        }
        if self.sink.logs_blocks() && self.partial.errors > 0 {
            let mut one = Partial::new(ctx, start);
            one.push_block(block, err, lin, &ctx.recorded);
            self.sink.log_block(&one)?;
            self.partial.append(&one);
        } else {
            self.partial.push_block(block, err, lin, &ctx.recorded);
        }
        Ok(())
    }
}

impl<'c, 'w, M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>
    BlockRunner<'c, 'w, M, P, R, A>
{
    /// Report progress to `p` from now on.
    pub fn report_to(&mut self, p: &'w dyn Progress) {
        self.progress = p;
    }

    /// Trials computed so far, restored ones included.
    pub fn done(&self) -> u64 {
        self.partial.trials
    }
}

/// Run the study. Results are identical for any thread count.
pub fn run<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
    opts: RunOptions,
) -> Result<SweepResult> {
    let started = std::time::Instant::now();
    let mut runner = BlockRunner::new(ctx, 0, opts.threads, opts.sink)?;
    runner.report_to(opts.progress);
    let resumed = runner.resume(opts.resume);
    runner.start(resumed)?;
    let restored = runner.done();
    let remaining = opts.trials.saturating_sub(restored);
    opts.progress.start(opts.trials, restored);
    runner.run_trials(remaining)?;
    opts.progress.finish();
    let trials_seconds = started.elapsed().as_secs_f64();
    let partial = std::mem::take(&mut runner.partial);
    let mut result = runner.pool.install(|| finalize(ctx, study, &[&partial]));
    result.computed = (partial.trials - restored) * ctx.grades.len() as u64;
    result.wall_seconds = started.elapsed().as_secs_f64();
    result.trials_seconds = trials_seconds;
    result.summary_seconds = result.wall_seconds - trials_seconds;
    result.threads = opts.threads;
    Ok(result)
}

/// One study run in memory, without its follow-up studies: no trials.csv,
/// no progress bar, no block log (the follow-ups' own restricted runs;
/// [`super::follow_ups::run_in_memory`] adds them).
pub fn run_alone(cfg: &Config, study: &ConfigStudy, threads: usize) -> Result<SweepResult> {
    let ctx = SweepContext::new(cfg, study)?;
    run(
        &ctx,
        study,
        RunOptions {
            trials: study.sweep.trials,
            threads,
            progress: &Silent,
            sink: &mut NoRows,
            resume: None,
        },
    )
}
