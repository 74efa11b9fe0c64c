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
    /// Noisy observation per sensor grade (sensor-major).
    l: Vec<f64>,
}

impl Scratch {
    pub fn new(ctx: &SweepContext) -> Self {
        Scratch {
            actual: vec![Vector3::zeros(); ctx.poses.len()],
            l0: vec![0.0; ctx.rows()],
            l: vec![0.0; ctx.rows() * ctx.sensors.len()],
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
    // The noisy observation of every sensor grade, drawn once per trial and
    // shared by every method that uses that grade.
    let m = ctx.rows();
    for (si, sensor) in ctx.sensors.iter().enumerate() {
        let mut rng = stream(ctx.seed, k, 1 + si as u64);
        let e0 = sensor.draw(&mut rng);
        let l = &mut s.l[si * m..(si + 1) * m];
        for j in 1..n {
            let d = sensor.draw(&mut rng) - e0;
            for c in 0..3 {
                l[3 * (j - 1) + c] = s.l0[3 * (j - 1) + c] + d[c];
            }
        }
    }
    let mut est = ErrorVector::zeros();
    for (gi, (g, o)) in ctx.grades.iter().zip(out.iter_mut()).enumerate() {
        let l = &s.l[g.sensor_index * m..(g.sensor_index + 1) * m];
        let solver = &ctx.solvers[gi];
        let mut failure = Failure::None;
        if ctx.options.iterations > 1 {
            let lv = DVector::from_column_slice(l);
            let weights = g
                .method
                .row_weights(ctx.rows(), &ctx.sensors[g.sensor_index]);
            let opts = IdentifyOptions {
                method: g.method,
                ..ctx.options
            };
            match identify(&ctx.geometry, &ctx.poses, &ctx.h, &weights, &lv, &opts) {
                Ok((e, _)) => {
                    est = e.values;
                    if !e.converged {
                        failure = Failure::NotConverged;
                    }
                }
                Err(_) => {
                    solver.apply(l, &mut est);
                    failure = Failure::NotConverged;
                }
            }
        } else {
            solver.apply(l, &mut est);
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
    /// Achieved 95 % CI half-widths relative to the value (adaptive stopping).
    pub mu_mean_ci_rel: f64,
    pub ratio_p95_ci_rel: f64,
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
    /// The final path of trials.csv, for messages.
    pub trials_path: std::path::PathBuf,
    /// Append-only block log for `--resume`, and what a previous run left.
    pub checkpoint: Option<Checkpoint>,
}

/// A block log: after every block, the bytes of trials.csv written so far and
/// the block's records are appended, so a killed run can continue from its
/// last complete block and still produce the same bytes.
pub struct Checkpoint {
    pub file: std::fs::File,
    pub path: std::path::PathBuf,
    /// Records and trials.csv length recovered from a previous run.
    pub resume: Option<(Partial, u64)>,
}

impl Checkpoint {
    /// Read a block log: the concatenated records of its complete blocks, the
    /// trials.csv length after the last of them, and the log's length up to
    /// there (None if it has no complete block).
    pub fn read(bytes: &[u8]) -> Option<(Partial, u64, u64)> {
        let mut pos = 0usize;
        let mut acc: Option<Partial> = None;
        let mut trials_bytes = 0;
        while pos + 16 <= bytes.len() {
            let tb = u64::from_le_bytes(bytes[pos..pos + 8].try_into().ok()?);
            let len = u64::from_le_bytes(bytes[pos + 8..pos + 16].try_into().ok()?) as usize;
            let Some(rec) = bytes.get(pos + 16..pos + 16 + len) else {
                break;
            };
            let Some(part) = Partial::from_bytes(rec) else {
                break;
            };
            match acc.as_mut() {
                Some(a) if a.first_trial + a.trials == part.first_trial => a.append(&part),
                Some(_) => break,
                None => acc = Some(part),
            }
            trials_bytes = tb;
            pos += 16 + len;
        }
        acc.map(|a| (a, trials_bytes, pos as u64))
    }
}

/// Failure codes stored in a [`Partial`].
const FAIL_NONE: u8 = 0;
const FAIL_FK: u8 = 1;
const FAIL_GN: u8 = 2;

/// The per-calibration records of a range of whole blocks: everything the
/// summary needs. A single run is one partial; the shards of a sharded run
/// are partials over consecutive block ranges, and [`finalize`] of their
/// concatenation gives exactly the bytes of the single run (sums run in the
/// same order: per-trial values in trial order, parameter-error sums per
/// block, then over blocks).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Partial {
    pub first_trial: u64,
    pub trials: u64,
    pub grades: usize,
    pub volumetric: bool,
    /// μ0 per trial.
    pub mu0: Vec<f64>,
    /// μ per trial × grade (NaN when forward kinematics failed).
    pub mu: Vec<f64>,
    /// Failure code per trial × grade.
    pub failure: Vec<u8>,
    /// Rank of the design per grade.
    pub rank: Vec<u8>,
    /// (dV after max, dV after mean, dV before max) per trial × grade, when volumetric.
    pub dv: Vec<f64>,
    /// Σ(estimate − truth) and Σ(estimate − truth)² per block × grade.
    pub block_err_sum: Vec<ErrorVector>,
    pub block_err_sq: Vec<ErrorVector>,
}

const PARTIAL_MAGIC: &[u8; 8] = b"TCPART01";

impl Partial {
    fn new(ctx: &SweepContext, first_trial: u64) -> Self {
        Partial {
            first_trial,
            grades: ctx.grades.len(),
            volumetric: !ctx.grid.is_empty(),
            rank: ctx.solvers.iter().map(|s| s.analysis.rank as u8).collect(),
            ..Default::default()
        }
    }

    /// Append one block of outcomes (trial-major, grade-minor).
    fn push_block(&mut self, outcomes: &[Outcome]) {
        let g = self.grades;
        let mut sum = vec![ErrorVector::zeros(); g];
        let mut sq = vec![ErrorVector::zeros(); g];
        for trial in outcomes.chunks(g) {
            self.mu0.push(trial[0].mu0);
            for (k, o) in trial.iter().enumerate() {
                self.mu.push(o.mu);
                let code = match o.failure {
                    Failure::None => FAIL_NONE,
                    Failure::ForwardKinematics => FAIL_FK,
                    Failure::NotConverged => FAIL_GN,
                };
                self.failure.push(code);
                if self.volumetric {
                    self.dv
                        .extend([o.dv_after_max, o.dv_after_mean, o.dv_before_max]);
                }
                if code != FAIL_FK {
                    sum[k] += o.error;
                    sq[k] += o.error.component_mul(&o.error);
                }
            }
            self.trials += 1;
        }
        self.block_err_sum.extend(sum);
        self.block_err_sq.extend(sq);
    }

    /// Append the records of the partial that follows this one.
    pub fn append(&mut self, next: &Partial) {
        self.trials += next.trials;
        self.mu0.extend_from_slice(&next.mu0);
        self.mu.extend_from_slice(&next.mu);
        self.failure.extend_from_slice(&next.failure);
        self.dv.extend_from_slice(&next.dv);
        self.block_err_sum.extend_from_slice(&next.block_err_sum);
        self.block_err_sq.extend_from_slice(&next.block_err_sq);
    }

    /// Binary form (little-endian), for shards.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b =
            Vec::with_capacity(64 + self.mu.len() * 9 + self.mu0.len() * 8 + self.dv.len() * 8);
        b.extend_from_slice(PARTIAL_MAGIC);
        for v in [
            self.first_trial,
            self.trials,
            self.grades as u64,
            self.volumetric as u64,
            (self.block_err_sum.len() / self.grades.max(1)) as u64,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.rank);
        for v in self.mu0.iter().chain(&self.mu).chain(&self.dv) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.failure);
        for e in self.block_err_sum.iter().chain(&self.block_err_sq) {
            for v in e.iter() {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        b
    }

    /// Parse [`Partial::to_bytes`]; `None` when the bytes are not a complete partial.
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        let mut pos = 0usize;
        let mut take = |n: usize| -> Option<&[u8]> {
            let s = b.get(pos..pos.checked_add(n)?)?;
            pos += n;
            Some(s)
        };
        if take(8)? != PARTIAL_MAGIC {
            return None;
        }
        let mut u = || -> Option<u64> { Some(u64::from_le_bytes(take(8)?.try_into().ok()?)) };
        let (first_trial, trials, grades, volumetric, blocks) =
            (u()?, u()?, u()? as usize, u()? != 0, u()? as usize);
        let calib = (trials as usize).checked_mul(grades)?;
        let rank = take(grades)?.to_vec();
        let f64s = |s: &[u8]| -> Vec<f64> {
            s.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                .collect()
        };
        let mu0 = f64s(take((trials as usize).checked_mul(8)?)?);
        let mu = f64s(take(calib.checked_mul(8)?)?);
        let dv = if volumetric {
            f64s(take(calib.checked_mul(24)?)?)
        } else {
            Vec::new()
        };
        let failure = take(calib)?.to_vec();
        let vecs = |n: usize,
                    take: &mut dyn FnMut(usize) -> Option<Vec<u8>>|
         -> Option<Vec<ErrorVector>> {
            let raw = take(n.checked_mul(grades)?.checked_mul(N_PARAMS * 8)?)?;
            Some(
                f64s(&raw)
                    .chunks_exact(N_PARAMS)
                    .map(ErrorVector::from_column_slice)
                    .collect(),
            )
        };
        let mut take_vec = |n: usize| take(n).map(|s| s.to_vec());
        let block_err_sum = vecs(blocks, &mut take_vec)?;
        let block_err_sq = vecs(blocks, &mut take_vec)?;
        if pos != b.len() {
            return None;
        }
        Some(Partial {
            first_trial,
            trials,
            grades,
            volumetric,
            mu0,
            mu,
            failure,
            rank,
            dv,
            block_err_sum,
            block_err_sq,
        })
    }
}

/// Computes whole blocks of trials, in order, into a [`Partial`], writing
/// trials.csv rows as it goes.
pub struct BlockRunner<'c, 'w> {
    ctx: &'c SweepContext,
    pool: rayon::ThreadPool,
    outcomes: Vec<Outcome>,
    trials_out: Option<&'w mut dyn Write>,
    trials_path: std::path::PathBuf,
    pub partial: Partial,
    next_trial: u64,
    trials_bytes: u64,
    checkpoint: Option<Checkpoint>,
}

impl<'c, 'w> BlockRunner<'c, 'w> {
    pub fn new(
        ctx: &'c SweepContext,
        first_trial: u64,
        threads: usize,
        trials_out: Option<&'w mut dyn Write>,
        trials_path: std::path::PathBuf,
    ) -> Result<Self> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Error::Internal(format!("cannot start {threads} worker threads: {e}")))?;
        Ok(BlockRunner {
            ctx,
            pool,
            outcomes: vec![Outcome::default(); BLOCK_TRIALS * ctx.grades.len()],
            trials_out,
            trials_path,
            partial: Partial::new(ctx, first_trial),
            next_trial: first_trial,
            trials_bytes: 0,
            checkpoint: None,
        })
    }

    /// Log every block to `cp`; if it carries a previous run's records,
    /// continue after them (the trials.csv writer must already hold exactly
    /// the recovered bytes). Returns true when it resumed.
    pub fn attach_checkpoint(&mut self, mut cp: Checkpoint) -> bool {
        let resumed = match cp.resume.take() {
            Some((part, bytes))
                if part.first_trial == self.next_trial && part.grades == self.ctx.grades.len() =>
            {
                self.next_trial = part.first_trial + part.trials;
                self.partial = part;
                self.trials_bytes = bytes;
                true
            }
            _ => false,
        };
        self.checkpoint = Some(cp);
        resumed
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
        if let Some(w) = self.trials_out.as_deref_mut() {
            w.write_all(TRIALS_HEADER.as_bytes())
                .map_err(|e| Error::io("write", &self.trials_path, e))?;
            self.trials_bytes += TRIALS_HEADER.len() as u64;
        }
        Ok(())
    }

    /// Run the next `count` (≤ BLOCK_TRIALS) trials as one block.
    pub fn run_block(&mut self, count: usize) -> Result<()> {
        let ctx = self.ctx;
        let g = ctx.grades.len();
        let start = self.next_trial;
        let block = &mut self.outcomes[..count * g];
        let write_rows = self.trials_out.is_some();
        let texts: Vec<Vec<u8>> = self.pool.install(|| {
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
        if let Some(w) = self.trials_out.as_deref_mut() {
            for t in &texts {
                w.write_all(t)
                    .map_err(|e| Error::io("write", &self.trials_path, e))?;
                self.trials_bytes += t.len() as u64;
            }
        }
        if let Some(cp) = self.checkpoint.as_mut() {
            // Rows first (flushed to the file), then the block's record.
            if let Some(w) = self.trials_out.as_deref_mut() {
                w.flush()
                    .map_err(|e| Error::io("write", &self.trials_path, e))?;
            }
            let mut one = Partial::new(ctx, start);
            one.push_block(block);
            let rec = one.to_bytes();
            let mut buf = Vec::with_capacity(rec.len() + 16);
            buf.extend_from_slice(&self.trials_bytes.to_le_bytes());
            buf.extend_from_slice(&(rec.len() as u64).to_le_bytes());
            buf.extend_from_slice(&rec);
            cp.file
                .write_all(&buf)
                .map_err(|e| Error::io("write", &cp.path, e))?;
            self.partial.append(&one);
        } else {
            self.partial.push_block(block);
        }
        self.next_trial += count as u64;
        Ok(())
    }

    /// Run trials [first, first + count) in blocks.
    pub fn run_trials(&mut self, count: u64, progress: bool) -> Result<()> {
        let bar = progress_bar(progress, count);
        let end = self.next_trial + count;
        while self.next_trial < end {
            let n = ((end - self.next_trial) as usize).min(BLOCK_TRIALS);
            self.run_block(n)?;
            bar.inc(n as u64);
        }
        bar.finish_and_clear();
        Ok(())
    }
}

fn progress_bar(show: bool, len: u64) -> indicatif::ProgressBar {
    if show {
        let b = indicatif::ProgressBar::new(len);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} trials  {per_sec}  eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    }
}

/// Run the study. Results are identical for any thread count.
pub fn run(ctx: &SweepContext, cfg: &Config, opts: RunOptions) -> Result<SweepResult> {
    let started = std::time::Instant::now();
    let mut runner = BlockRunner::new(ctx, 0, opts.threads, opts.trials_out, opts.trials_path)?;
    let resumed = opts
        .checkpoint
        .map(|cp| runner.attach_checkpoint(cp))
        .unwrap_or(false);
    runner.start(resumed)?;
    let remaining = opts.trials.saturating_sub(runner.partial.trials);
    runner.run_trials(remaining, opts.progress)?;
    let partial = runner.partial;
    let mut result = finalize(ctx, cfg, &[&partial]);
    result.wall_seconds = started.elapsed().as_secs_f64();
    result.threads = opts.threads;
    Ok(result)
}

/// An in-memory study of a validated config: its `[sweep]` trials, no
/// trials.csv, no progress bar, no block log (reports, pose design).
pub fn study(cfg: &Config, threads: usize) -> Result<SweepResult> {
    let ctx = SweepContext::new(cfg)?;
    run(
        &ctx,
        cfg,
        RunOptions {
            trials: cfg.sweep.trials,
            threads,
            progress: false,
            trials_out: None,
            trials_path: std::path::PathBuf::from("trials.csv"),
            checkpoint: None,
        },
    )
}

/// Adaptive stopping (JCGM 101 §7.9 style): blocks of trials until, for every
/// grade, the 95 % half-width of mean μ is at most `target_rel` × mean μ (and,
/// when the decision uses it, the 95 % CI of ratio_p95 has a half-width at
/// most `target_rel` × ratio_p95), or `max_trials` is reached. Deterministic:
/// the trials are a prefix of the same streams, checked after whole blocks.
pub fn run_adaptive(
    ctx: &SweepContext,
    cfg: &Config,
    target_rel: f64,
    max_trials: u64,
    opts: RunOptions,
) -> Result<(SweepResult, bool)> {
    let started = std::time::Instant::now();
    let mut runner = BlockRunner::new(ctx, 0, opts.threads, opts.trials_out, opts.trials_path)?;
    let resumed = opts
        .checkpoint
        .map(|cp| runner.attach_checkpoint(cp))
        .unwrap_or(false);
    runner.start(resumed)?;
    let bar = progress_bar(opts.progress, max_trials);
    let target_met = |p: &Partial| target_met(ctx, cfg, p, target_rel);
    // A resumed run checks what it recovered first, as the killed run did.
    let mut met = runner.partial.trials > 0 && target_met(&runner.partial);
    bar.inc(runner.partial.trials);
    while !met && runner.partial.trials < max_trials {
        let n = ((max_trials - runner.partial.trials) as usize).min(BLOCK_TRIALS);
        runner.run_block(n)?;
        bar.inc(n as u64);
        met = target_met(&runner.partial);
    }
    bar.finish_and_clear();
    let partial = runner.partial;
    let mut result = finalize(ctx, cfg, &[&partial]);
    result.trials = partial.trials;
    result.calibrations = partial.trials * ctx.grades.len() as u64;
    result.wall_seconds = started.elapsed().as_secs_f64();
    result.threads = opts.threads;
    Ok((result, met))
}

/// The adaptive stopping rule on the trials so far: for every grade the
/// relative 95 % half-width of mean μ (and, when the decision uses ratio_p95,
/// that of ratio_p95) is at most `target_rel`. Computes exactly the values
/// [`finalize`] reports, but only those, in O(n) per check (no sorting), so
/// checking after every block stays cheap for long runs.
fn target_met(ctx: &SweepContext, cfg: &Config, p: &Partial, target_rel: f64) -> bool {
    let g = ctx.grades.len();
    let need_p95 = cfg.decision.metric.starts_with("ratio_p95");
    let mut mu = Vec::with_capacity(p.trials as usize);
    let mut ratio = Vec::with_capacity(if need_p95 { p.trials as usize } else { 0 });
    (0..g).all(|gi| {
        mu.clear();
        ratio.clear();
        for t in 0..p.trials as usize {
            let k = t * g + gi;
            if p.failure[k] != FAIL_FK {
                mu.push(p.mu[k]);
                if need_p95 {
                    ratio.push(p.mu[k] / p.mu0[t]);
                }
            }
        }
        let (mean, half) = stats::mean_ci95(&mu);
        let ok_mu = mu.len() >= 2 && half / mean <= target_rel;
        ok_mu && {
            !need_p95 || {
                let (q, lo, hi) = stats::quantile_with_ci95(&mut ratio, 0.95);
                (hi - lo) / 2.0 / q <= target_rel
            }
        }
    })
}

/// Summaries from consecutive partials (a single run is one partial).
pub fn finalize(ctx: &SweepContext, cfg: &Config, parts: &[&Partial]) -> SweepResult {
    let g = ctx.grades.len();
    let trials: u64 = parts.iter().map(|p| p.trials).sum();
    let volumetric = !ctx.grid.is_empty();
    let mut summary = Vec::with_capacity(g);
    let mut parameters = Vec::new();
    for (gi, (grade, solver)) in ctx.grades.iter().zip(&ctx.solvers).enumerate() {
        let mut mu_v = Vec::with_capacity(trials as usize);
        let mut ratio_v = Vec::with_capacity(trials as usize);
        let (mut mu0_sum, mut failed, mut not_converged) = (0.0, 0u64, 0u64);
        let (mut dv_max, mut dv_mean, mut dv_before) = (Vec::new(), Vec::new(), Vec::new());
        let mut err_sum = ErrorVector::zeros();
        let mut err_sq = ErrorVector::zeros();
        let mut rank = solver.analysis.rank as u8;
        for p in parts {
            rank = p.rank.get(gi).copied().unwrap_or(rank);
            for t in 0..p.trials as usize {
                let k = t * g + gi;
                match p.failure[k] {
                    FAIL_FK => {
                        failed += 1;
                        continue;
                    }
                    FAIL_GN => not_converged += 1,
                    _ => {}
                }
                mu_v.push(p.mu[k]);
                ratio_v.push(p.mu[k] / p.mu0[t]);
                mu0_sum += p.mu0[t];
                if volumetric {
                    dv_max.push(p.dv[3 * k]);
                    dv_mean.push(p.dv[3 * k + 1]);
                    dv_before.push(p.dv[3 * k + 2]);
                }
            }
            for b in 0..p.block_err_sum.len() / g.max(1) {
                err_sum += p.block_err_sum[b * g + gi];
                err_sq += p.block_err_sq[b * g + gi];
            }
        }
        let n = mu_v.len();
        let (mu_mean, mu_half) = stats::mean_ci95(&mu_v);
        let (ratio_mean, _) = stats::mean_ci95(&ratio_v);
        mu_v.sort_by(f64::total_cmp);
        ratio_v.sort_by(f64::total_cmp);
        let (r95_lo, r95_hi) = stats::quantile_ci95(&ratio_v, 0.95);
        let mut row = GradeSummary {
            encoder_arcsec: grade.encoder_arcsec,
            scale_um: grade.scale_um,
            method: grade.method.name(),
            trials: n as u64,
            failed,
            not_converged,
            mu_mean,
            mu_mean_ci_low: mu_mean - mu_half,
            mu_mean_ci_high: mu_mean + mu_half,
            mu_median: stats::quantile_sorted(&mu_v, 0.5),
            mu_p05: stats::quantile_sorted(&mu_v, 0.05),
            mu_p95: stats::quantile_sorted(&mu_v, 0.95),
            mu0_mean: mu0_sum / n.max(1) as f64,
            ratio_mean,
            ratio_median: stats::quantile_sorted(&ratio_v, 0.5),
            ratio_p05: stats::quantile_sorted(&ratio_v, 0.05),
            ratio_p95: stats::quantile_sorted(&ratio_v, 0.95),
            ratio_p95_ci_low: r95_lo,
            ratio_p95_ci_high: r95_hi,
            mu_mean_ci_rel: mu_half / mu_mean,
            ratio_p95_ci_rel: (r95_hi - r95_lo) / 2.0 / stats::quantile_sorted(&ratio_v, 0.95),
            rank,
            dv_after_max_median: None,
            dv_after_max_p95: None,
            dv_after_mean_mean: None,
            dv_before_max_median: None,
            meets_target: false,
        };
        if volumetric {
            let finite = |v: &mut Vec<f64>| {
                v.retain(|x| x.is_finite());
                v.sort_by(f64::total_cmp);
            };
            finite(&mut dv_max);
            finite(&mut dv_before);
            dv_mean.retain(|x| x.is_finite());
            row.dv_after_max_median = Some(stats::quantile_sorted(&dv_max, 0.5));
            row.dv_after_max_p95 = Some(stats::quantile_sorted(&dv_max, 0.95));
            row.dv_after_mean_mean = Some(stats::mean_ci95(&dv_mean).0);
            row.dv_before_max_median = Some(stats::quantile_sorted(&dv_before, 0.5));
        }
        row.meets_target = row
            .metric(&cfg.decision.metric)
            .is_some_and(|v| v <= cfg.decision.threshold);
        summary.push(row);
        let predicted = solver.predicted_std(&ctx.sensors[grade.sensor_index].reading_sigma());
        let ident = solver.identifiable();
        for p in 0..N_PARAMS {
            let nf = n.max(1) as f64;
            let mean = err_sum[p] / nf;
            let var = if n > 1 {
                (err_sq[p] - nf * mean * mean).max(0.0) / (nf - 1.0)
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
    SweepResult {
        summary,
        parameters,
        decisions,
        calibrations: trials * g as u64,
        trials,
        wall_seconds: 0.0,
        threads: 0,
    }
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
