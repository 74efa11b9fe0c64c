//! The Monte-Carlo encoder-grade study (SPEC §10 `sweep`).
//!
//! Trial k draws one true error set (uniform in ±bound, or the fixed [errors]
//! table), computes the machine's exact passive-joint values at every pose
//! once (forward kinematics is the cost, and it is shared by all grades),
//! then for every grade (encoder × scale × method) adds that grade's sensor
//! noise and identifies with the same [`LinearSolver`] that `identify` uses.
//! Randomness is a pure function of (seed, trial, stream): the error set uses
//! stream 0 and the noise of sensor grade s uses stream 1 + s, so every method
//! and every grade sees the same machines (common random numbers), and the
//! thread count cannot change a byte. Results are gathered in trial order.

pub mod stats;

use crate::config::{Config, ErrorDraw};
use crate::error::{Error, Result};
use crate::identify::solver::identify;
use crate::identify::{design_matrix, IdentifyOptions, LinearSolver, Method};
use crate::model::params::{mu, mu0};
use crate::model::{ErrorVector, Geometry, Machine, N_PARAMS};
use crate::sensors::{NominalPoses, SensorModel};
use nalgebra::{DMatrix, DVector, Vector3};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;
use std::io::Write;

/// Trials processed (and written) per block; memory is bounded by this, and
/// results do not depend on it.
pub const BLOCK_TRIALS: usize = 8192;

/// SplitMix64 finaliser.
#[inline]
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of (seed, trial, stream).
pub fn stream(seed: u64, trial: u64, stream: u64) -> Xoshiro256PlusPlus {
    let s = splitmix(seed ^ splitmix(trial ^ splitmix(stream.wrapping_add(0x5EED))));
    Xoshiro256PlusPlus::seed_from_u64(s)
}

/// Trial k's true errors.
pub fn trial_errors(
    draw: ErrorDraw,
    fixed: &ErrorVector,
    bound_mm: f64,
    seed: u64,
    trial: u64,
) -> ErrorVector {
    match draw {
        ErrorDraw::Fixed => *fixed,
        ErrorDraw::Random => {
            let mut rng = stream(seed, trial, 0);
            ErrorVector::from_fn(|_, _| rng.random_range(-bound_mm..=bound_mm))
        }
    }
}

/// One grade of the study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Grade {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: Method,
    /// Index of the (encoder, scale) pair: selects the noise stream.
    pub sensor_index: usize,
}

/// Why a calibration produced no estimate or a doubtful one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Failure {
    #[default]
    None,
    /// Forward kinematics of the true machine failed at some pose.
    ForwardKinematics,
    /// Gauss–Newton hit its iteration limit (estimate kept, counted).
    NotConverged,
}

impl Failure {
    pub fn label(&self) -> &'static str {
        match self {
            Failure::None => "",
            Failure::ForwardKinematics => "fk_failed",
            Failure::NotConverged => "not_converged",
        }
    }
}

/// One calibration's outcome.
#[derive(Debug, Clone, Copy, Default)]
pub struct Outcome {
    pub mu: f64,
    pub mu0: f64,
    pub rank: u8,
    pub failure: Failure,
    /// Estimate − truth, mm.
    pub error: ErrorVector,
    /// Max and mean dV after compensation on the map plane, mm (NaN when off).
    pub dv_after_max: f64,
    pub dv_after_mean: f64,
    /// Max dV before compensation (nominal commands), mm (NaN when off).
    pub dv_before_max: f64,
}

/// Everything a trial needs, built once and shared read-only.
pub struct SweepContext {
    pub geometry: Geometry,
    pub poses: NominalPoses,
    pub grades: Vec<Grade>,
    pub sensors: Vec<SensorModel>,
    pub solvers: Vec<LinearSolver>,
    pub h: DMatrix<f64>,
    pub options: IdentifyOptions,
    pub draw: ErrorDraw,
    pub fixed_errors: ErrorVector,
    pub bound_mm: f64,
    pub seed: u64,
    /// Second-class errors every simulated machine carries.
    pub second_class: Option<crate::model::geometry::SecondClass>,
    /// Map points and their nominal configurations (empty when volumetric is off).
    pub grid: Vec<Vector3<f64>>,
    pub grid_nominal: Vec<crate::model::Joints>,
    pub grid_commands: Vec<[f64; 3]>,
}

impl SweepContext {
    /// Build grades and solvers from a validated config.
    pub fn new(cfg: &Config) -> Result<Self> {
        let nominal = cfg.nominal();
        let poses = NominalPoses::new(&nominal, &cfg.poses)
            .map_err(|(k, e)| Error::config(&cfg.source, format!("poses: pose {k}: {e}")))?;
        let h = design_matrix(&nominal, &poses)
            .map_err(|(k, e)| Error::config(&cfg.source, format!("poses: pose {k}: {e}")))?;
        let mut sensors = Vec::new();
        for &s in &cfg.sweep.scale_um {
            for &e in &cfg.sweep.encoder_arcsec {
                sensors.push(SensorModel {
                    encoder_arcsec: e,
                    scale_um: s,
                    ..cfg.sensors
                });
            }
        }
        let mut grades = Vec::new();
        let mut solvers: Vec<LinearSolver> = Vec::new();
        let ols = LinearSolver::new(
            &h,
            &DVector::from_element(h.nrows(), 1.0),
            cfg.identification.rank_tolerance,
        );
        for &method in &cfg.sweep.methods {
            for (si, s) in sensors.iter().enumerate() {
                grades.push(Grade {
                    encoder_arcsec: s.encoder_arcsec,
                    scale_um: s.scale_um,
                    method,
                    sensor_index: si,
                });
                solvers.push(match method {
                    Method::Ols => ols.clone(),
                    Method::Wls => LinearSolver::new(
                        &h,
                        &method.row_weights(h.nrows(), s),
                        cfg.identification.rank_tolerance,
                    ),
                });
            }
        }
        let mut grid = Vec::new();
        let mut grid_nominal = Vec::new();
        let mut grid_commands = Vec::new();
        if let Some(step) = cfg.sweep.volumetric_step_mm {
            grid = crate::model::poses::midplane_grid(&cfg.workspace, step, cfg.plane_z_mm);
            for r in &grid {
                let pose = nominal.inverse(r).map_err(|e| {
                    Error::config(
                        &cfg.source,
                        format!("sweep.volumetric_grid_step: map point {r:?}: {e}"),
                    )
                })?;
                grid_nominal.push(pose.joints);
                grid_commands.push(pose.legs_mm);
            }
        }
        Ok(SweepContext {
            second_class: cfg.second_class,
            grid,
            grid_nominal,
            grid_commands,
            geometry: cfg.geometry,
            poses,
            grades,
            sensors,
            solvers,
            h,
            options: cfg.identification,
            draw: cfg.sweep.errors,
            fixed_errors: cfg.errors,
            bound_mm: cfg.sweep.error_bound_mm,
            seed: cfg.sweep.seed,
        })
    }

    /// Rows of l: 3 per pose after the reference.
    pub fn rows(&self) -> usize {
        self.h.nrows()
    }
}

/// Per-worker buffers, reused across trials (no allocation per pose).
pub struct Scratch {
    actual: Vec<Vector3<f64>>,
    l0: Vec<f64>,
    l: Vec<f64>,
    noise: Vec<Vector3<f64>>,
}

impl Scratch {
    pub fn new(ctx: &SweepContext) -> Self {
        Scratch {
            actual: vec![Vector3::zeros(); ctx.poses.len()],
            l0: vec![0.0; ctx.rows()],
            l: vec![0.0; ctx.rows()],
            noise: vec![Vector3::zeros(); ctx.poses.len()],
        }
    }
}

/// Trial k: one error set, every grade. Writes one outcome per grade.
pub fn run_trial(ctx: &SweepContext, k: u64, s: &mut Scratch, out: &mut [Outcome]) {
    let truth_e = trial_errors(ctx.draw, &ctx.fixed_errors, ctx.bound_mm, ctx.seed, k);
    let m0 = mu0(&truth_e);
    let truth = Machine {
        second: ctx.second_class,
        ..Machine::with_errors(&ctx.geometry, &truth_e)
    };
    if ctx.poses.actual_joints_into(&truth, &mut s.actual).is_err() {
        for o in out.iter_mut() {
            *o = Outcome {
                mu: f64::NAN,
                mu0: m0,
                rank: 0,
                failure: Failure::ForwardKinematics,
                error: ErrorVector::zeros(),
                dv_after_max: f64::NAN,
                dv_after_mean: f64::NAN,
                dv_before_max: f64::NAN,
            };
        }
        return;
    }
    let dv_before_max = if ctx.grid.is_empty() {
        f64::NAN
    } else {
        let mut mx = 0.0f64;
        for ((q, g), r) in ctx
            .grid_commands
            .iter()
            .zip(&ctx.grid_nominal)
            .zip(&ctx.grid)
        {
            let dv = crate::compensate::volumetric_error(&truth, q, r, g).unwrap_or(f64::NAN);
            mx = if dv.is_nan() { f64::NAN } else { mx.max(dv) };
        }
        mx
    };
    // Noise-free observation l0_j = (actual_j − actual_0) − (nominal_j − nominal_0).
    let n = ctx.poses.len();
    let a0 = s.actual[0];
    let n0 = ctx.poses.joints[0].as_vector();
    for j in 1..n {
        let d = (s.actual[j] - a0) - (ctx.poses.joints[j].as_vector() - n0);
        s.l0[3 * (j - 1)..3 * j].copy_from_slice(d.as_slice());
    }
    let mut last_sensor = usize::MAX;
    let mut est = ErrorVector::zeros();
    for (gi, (g, o)) in ctx.grades.iter().zip(out.iter_mut()).enumerate() {
        if g.sensor_index != last_sensor {
            let mut rng = stream(ctx.seed, k, 1 + g.sensor_index as u64);
            let sensor = &ctx.sensors[g.sensor_index];
            for v in s.noise.iter_mut() {
                *v = sensor.draw(&mut rng);
            }
            last_sensor = g.sensor_index;
        }
        let e0 = s.noise[0];
        for j in 1..n {
            let d = s.noise[j] - e0;
            for c in 0..3 {
                s.l[3 * (j - 1) + c] = s.l0[3 * (j - 1) + c] + d[c];
            }
        }
        let solver = &ctx.solvers[gi];
        let mut failure = Failure::None;
        if ctx.options.iterations > 1 {
            let l = DVector::from_column_slice(&s.l);
            let weights = g
                .method
                .row_weights(ctx.rows(), &ctx.sensors[g.sensor_index]);
            let opts = IdentifyOptions {
                method: g.method,
                ..ctx.options
            };
            match identify(&ctx.geometry, &ctx.poses, &ctx.h, &weights, &l, &opts) {
                Ok((e, _)) => {
                    est = e.values;
                    if !e.converged {
                        failure = Failure::NotConverged;
                    }
                }
                Err(_) => {
                    solver.apply(&s.l, &mut est);
                    failure = Failure::NotConverged;
                }
            }
        } else {
            solver.apply(&s.l, &mut est);
        }
        let (dv_after_max, dv_after_mean) = if ctx.grid.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            volumetric_after(ctx, &truth, &est)
        };
        *o = Outcome {
            mu: mu(&truth_e, &est),
            mu0: m0,
            rank: solver.analysis.rank as u8,
            failure,
            error: est - truth_e,
            dv_after_max,
            dv_after_mean,
            dv_before_max,
        };
    }
}

/// Max and mean dV of `truth` commanded by the model identified as `est`,
/// over the context's map points (NaN if any point fails).
fn volumetric_after(ctx: &SweepContext, truth: &Machine, est: &ErrorVector) -> (f64, f64) {
    let identified = Machine::with_errors(&ctx.geometry, est);
    let mut mx = 0.0f64;
    let mut sum = 0.0;
    for (r, g) in ctx.grid.iter().zip(&ctx.grid_nominal) {
        let dv = identified
            .commands(r)
            .ok()
            .and_then(|q| crate::compensate::volumetric_error(truth, &q, r, g).ok());
        match dv {
            Some(d) => {
                mx = mx.max(d);
                sum += d;
            }
            None => return (f64::NAN, f64::NAN),
        }
    }
    (mx, sum / ctx.grid.len() as f64)
}

/// Summary of one grade (one row of summary.csv).
#[derive(Debug, Clone, Serialize)]
pub struct GradeSummary {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: &'static str,
    pub trials: u64,
    pub failed: u64,
    pub not_converged: u64,
    pub mu_mean: f64,
    pub mu_mean_ci_low: f64,
    pub mu_mean_ci_high: f64,
    pub mu_median: f64,
    pub mu_p05: f64,
    pub mu_p95: f64,
    pub mu0_mean: f64,
    pub ratio_mean: f64,
    pub ratio_median: f64,
    pub ratio_p05: f64,
    pub ratio_p95: f64,
    pub ratio_p95_ci_low: f64,
    pub ratio_p95_ci_high: f64,
    pub rank: u8,
    /// Volumetric accuracy after compensation (empty unless sweep.volumetric).
    pub dv_after_max_median: Option<f64>,
    pub dv_after_max_p95: Option<f64>,
    pub dv_after_mean_mean: Option<f64>,
    pub dv_before_max_median: Option<f64>,
    pub meets_target: bool,
}

impl GradeSummary {
    /// A summary column by name (for the decision rule).
    pub fn metric(&self, name: &str) -> Option<f64> {
        Some(match name {
            "mu_mean" => self.mu_mean,
            "mu_median" => self.mu_median,
            "mu_p95" => self.mu_p95,
            "ratio_mean" => self.ratio_mean,
            "ratio_median" => self.ratio_median,
            "ratio_p95" => self.ratio_p95,
            "mu_mean_ci_high" => self.mu_mean_ci_high,
            "ratio_p95_ci_high" => self.ratio_p95_ci_high,
            "dv_after_max_p95" => self.dv_after_max_p95?,
            "dv_after_max_median" => self.dv_after_max_median?,
            "dv_after_mean_mean" => self.dv_after_mean_mean?,
            _ => return None,
        })
    }
}

/// Per parameter and grade: Monte-Carlo spread of the estimate against the
/// standard deviation the linear covariance predicts (parameters.csv).
#[derive(Debug, Clone, Serialize)]
pub struct ParameterRow {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: &'static str,
    pub parameter: &'static str,
    pub identifiable: bool,
    pub bias_mm: f64,
    pub mc_std_mm: f64,
    pub predicted_std_mm: f64,
    pub ratio_mc_to_predicted: f64,
}

/// The coarsest encoder grade meeting the target, per (method, scale).
#[derive(Debug, Clone, Serialize)]
pub struct DecisionRow {
    pub method: &'static str,
    pub scale_um: f64,
    pub metric: String,
    pub threshold: f64,
    /// Empty when no grade meets the target.
    pub chosen_encoder_arcsec: Option<f64>,
    pub value_at_choice: Option<f64>,
    pub verdict: String,
}

/// Streaming accumulators of one grade.
#[derive(Default, Clone)]
struct Acc {
    mu: Vec<f64>,
    ratio: Vec<f64>,
    mu0_sum: f64,
    failed: u64,
    not_converged: u64,
    err_sum: ErrorVector,
    err_sq: ErrorVector,
    rank: u8,
    dv_max: Vec<f64>,
    dv_mean: Vec<f64>,
    dv_before: Vec<f64>,
}

/// What a sweep returns.
#[derive(Debug, Clone)]
pub struct SweepResult {
    pub summary: Vec<GradeSummary>,
    pub parameters: Vec<ParameterRow>,
    pub decisions: Vec<DecisionRow>,
    pub calibrations: u64,
    pub trials: u64,
    pub wall_seconds: f64,
    pub threads: usize,
}

impl SweepResult {
    pub fn calibrations_per_second(&self) -> f64 {
        self.calibrations as f64 / self.wall_seconds.max(1e-9)
    }
}

/// Header of trials.csv.
pub const TRIALS_HEADER: &str =
    "encoder_arcsec,scale_um,method,trial,mu,mu0,ratio,rank,failure,dv_after_max_mm,dv_after_mean_mm,dv_before_max_mm\n";

/// A number, or an empty cell for NaN.
struct Cell(f64);

impl std::fmt::Display for Cell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_nan() {
            Ok(())
        } else {
            write!(f, "{}", self.0)
        }
    }
}

fn format_rows(ctx: &SweepContext, start: u64, outcomes: &[Outcome], buf: &mut Vec<u8>) {
    let g = ctx.grades.len();
    for (i, trial) in outcomes.chunks(g).enumerate() {
        let k = start + i as u64;
        for (grade, o) in ctx.grades.iter().zip(trial) {
            if o.failure == Failure::ForwardKinematics {
                let _ = writeln!(
                    buf,
                    "{},{},{},{},,{},,{},{},,,",
                    grade.encoder_arcsec,
                    grade.scale_um,
                    grade.method.name(),
                    k,
                    o.mu0,
                    o.rank,
                    o.failure.label()
                );
            } else {
                let _ = writeln!(
                    buf,
                    "{},{},{},{},{},{},{},{},{},{},{},{}",
                    grade.encoder_arcsec,
                    grade.scale_um,
                    grade.method.name(),
                    k,
                    o.mu,
                    o.mu0,
                    o.mu / o.mu0,
                    o.rank,
                    o.failure.label(),
                    Cell(o.dv_after_max),
                    Cell(o.dv_after_mean),
                    Cell(o.dv_before_max)
                );
            }
        }
    }
}

/// Options of one run.
pub struct RunOptions<'a> {
    pub trials: u64,
    pub threads: usize,
    pub progress: bool,
    /// Where trials.csv goes (None: --no-trials).
    pub trials_out: Option<&'a mut dyn Write>,
}

/// Run the study. Results are identical for any thread count.
pub fn run(ctx: &SweepContext, cfg: &Config, mut opts: RunOptions) -> Result<SweepResult> {
    let started = std::time::Instant::now();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| {
            Error::Internal(format!("cannot start {} worker threads: {e}", opts.threads))
        })?;
    let g = ctx.grades.len();
    let mut acc = vec![Acc::default(); g];
    let bar = if opts.progress {
        let b = indicatif::ProgressBar::new(opts.trials);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} trials  {per_sec}  eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    if let Some(w) = opts.trials_out.as_deref_mut() {
        w.write_all(TRIALS_HEADER.as_bytes())
            .map_err(|e| Error::io("write", "trials.csv", e))?;
    }
    let mut outcomes = vec![Outcome::default(); BLOCK_TRIALS * g];
    let mut start = 0u64;
    let write_rows = opts.trials_out.is_some();
    while start < opts.trials {
        let count = ((opts.trials - start) as usize).min(BLOCK_TRIALS);
        let block = &mut outcomes[..count * g];
        let texts: Vec<Vec<u8>> = pool.install(|| {
            block.par_chunks_mut(g).enumerate().for_each_init(
                || Scratch::new(ctx),
                |s, (i, slot)| run_trial(ctx, start + i as u64, s, slot),
            );
            if write_rows {
                block
                    .par_chunks(256 * g)
                    .enumerate()
                    .map(|(c, part)| {
                        let mut buf = Vec::with_capacity(part.len() * 64);
                        format_rows(ctx, start + (c * 256) as u64, part, &mut buf);
                        buf
                    })
                    .collect()
            } else {
                Vec::new()
            }
        });
        if let Some(w) = opts.trials_out.as_deref_mut() {
            for t in &texts {
                w.write_all(t)
                    .map_err(|e| Error::io("write", "trials.csv", e))?;
            }
        }
        for trial in block.chunks(g) {
            for (a, o) in acc.iter_mut().zip(trial) {
                a.rank = o.rank;
                match o.failure {
                    Failure::ForwardKinematics => {
                        a.failed += 1;
                        continue;
                    }
                    Failure::NotConverged => a.not_converged += 1,
                    Failure::None => {}
                }
                a.mu.push(o.mu);
                a.ratio.push(o.mu / o.mu0);
                a.mu0_sum += o.mu0;
                a.err_sum += o.error;
                a.err_sq += o.error.component_mul(&o.error);
                if !ctx.grid.is_empty() {
                    a.dv_max.push(o.dv_after_max);
                    a.dv_mean.push(o.dv_after_mean);
                    a.dv_before.push(o.dv_before_max);
                }
            }
        }
        start += count as u64;
        bar.set_position(start);
    }
    bar.finish_and_clear();
    let mut summary = Vec::with_capacity(g);
    let mut parameters = Vec::new();
    for ((grade, a), solver) in ctx.grades.iter().zip(acc.iter_mut()).zip(&ctx.solvers) {
        let n = a.mu.len();
        let (mu_mean, mu_half) = stats::mean_ci95(&a.mu);
        let (ratio_mean, _) = stats::mean_ci95(&a.ratio);
        a.mu.sort_by(f64::total_cmp);
        a.ratio.sort_by(f64::total_cmp);
        let (r95_lo, r95_hi) = stats::quantile_ci95(&a.ratio, 0.95);
        let mut row = GradeSummary {
            encoder_arcsec: grade.encoder_arcsec,
            scale_um: grade.scale_um,
            method: grade.method.name(),
            trials: n as u64,
            failed: a.failed,
            not_converged: a.not_converged,
            mu_mean,
            mu_mean_ci_low: mu_mean - mu_half,
            mu_mean_ci_high: mu_mean + mu_half,
            mu_median: stats::quantile_sorted(&a.mu, 0.5),
            mu_p05: stats::quantile_sorted(&a.mu, 0.05),
            mu_p95: stats::quantile_sorted(&a.mu, 0.95),
            mu0_mean: a.mu0_sum / n.max(1) as f64,
            ratio_mean,
            ratio_median: stats::quantile_sorted(&a.ratio, 0.5),
            ratio_p05: stats::quantile_sorted(&a.ratio, 0.05),
            ratio_p95: stats::quantile_sorted(&a.ratio, 0.95),
            ratio_p95_ci_low: r95_lo,
            ratio_p95_ci_high: r95_hi,
            rank: a.rank,
            dv_after_max_median: None,
            dv_after_max_p95: None,
            dv_after_mean_mean: None,
            dv_before_max_median: None,
            meets_target: false,
        };
        if !ctx.grid.is_empty() {
            let finite = |v: &mut Vec<f64>| {
                v.retain(|x| x.is_finite());
                v.sort_by(f64::total_cmp);
            };
            finite(&mut a.dv_max);
            finite(&mut a.dv_before);
            a.dv_mean.retain(|x| x.is_finite());
            row.dv_after_max_median = Some(stats::quantile_sorted(&a.dv_max, 0.5));
            row.dv_after_max_p95 = Some(stats::quantile_sorted(&a.dv_max, 0.95));
            row.dv_after_mean_mean = Some(stats::mean_ci95(&a.dv_mean).0);
            row.dv_before_max_median = Some(stats::quantile_sorted(&a.dv_before, 0.5));
        }
        row.meets_target = row
            .metric(&cfg.decision.metric)
            .is_some_and(|v| v <= cfg.decision.threshold);
        summary.push(row);
        let predicted = solver.predicted_std(&ctx.sensors[grade.sensor_index].reading_sigma());
        let ident = solver.identifiable();
        for p in 0..N_PARAMS {
            let nf = n.max(1) as f64;
            let mean = a.err_sum[p] / nf;
            let var = if n > 1 {
                (a.err_sq[p] - nf * mean * mean).max(0.0) / (nf - 1.0)
            } else {
                0.0
            };
            let sd = var.sqrt();
            parameters.push(ParameterRow {
                encoder_arcsec: grade.encoder_arcsec,
                scale_um: grade.scale_um,
                method: grade.method.name(),
                parameter: crate::model::PARAM_NAMES[p],
                identifiable: ident[p],
                bias_mm: mean,
                mc_std_mm: sd,
                predicted_std_mm: predicted[p],
                ratio_mc_to_predicted: if predicted[p] > 0.0 {
                    sd / predicted[p]
                } else {
                    f64::NAN
                },
            });
        }
    }
    let decisions = decide(cfg, &summary);
    let calibrations = opts.trials * g as u64;
    Ok(SweepResult {
        summary,
        parameters,
        decisions,
        calibrations,
        trials: opts.trials,
        wall_seconds: started.elapsed().as_secs_f64(),
        threads: opts.threads,
    })
}

/// For each (method, scale grade): the coarsest encoder grade whose metric
/// meets the threshold.
pub fn decide(cfg: &Config, summary: &[GradeSummary]) -> Vec<DecisionRow> {
    let mut out = Vec::new();
    for &method in &cfg.sweep.methods {
        for &scale in &cfg.sweep.scale_um {
            let mut rows: Vec<&GradeSummary> = summary
                .iter()
                .filter(|r| r.method == method.name() && r.scale_um == scale)
                .collect();
            rows.sort_by(|a, b| b.encoder_arcsec.total_cmp(&a.encoder_arcsec));
            let chosen = rows.iter().find(|r| r.meets_target);
            let metric = &cfg.decision.metric;
            let verdict = match chosen {
                Some(r) => format!(
                    "{method} with a {scale} um scale: the coarsest encoder meeting {metric} <= {} is {} arcsec ({metric} = {:.4})",
                    cfg.decision.threshold,
                    r.encoder_arcsec,
                    r.metric(metric).unwrap_or(f64::NAN),
                    method = method.name()
                ),
                None => format!(
                    "{method} with a {scale} um scale: no encoder grade studied meets {metric} <= {}",
                    cfg.decision.threshold,
                    method = method.name()
                ),
            };
            out.push(DecisionRow {
                method: method.name(),
                scale_um: scale,
                metric: metric.clone(),
                threshold: cfg.decision.threshold,
                chosen_encoder_arcsec: chosen.map(|r| r.encoder_arcsec),
                value_at_choice: chosen.and_then(|r| r.metric(metric)),
                verdict,
            });
        }
    }
    out
}
