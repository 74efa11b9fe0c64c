//! The trial kernel (SPEC §10 `sweep`): trial k draws one true machine,
//! computes its exact passive-joint values at every pose once (forward
//! kinematics near the first-order prediction, four poses in lock-step:
//! the cost, shared by all grades), then draws one unit noise per reading,
//! shared by every grade (common random numbers). With white-noise sensors
//! and one linearisation every estimate is linear in that draw, so each
//! operator is applied once to the exact observation and once to each
//! sensor's noise ([`LinearSolver::apply_split`]) and a grade's estimate is
//! their combination with its own σ; otherwise each grade's observation is
//! formed and identified in full. A trial is a pure function of
//! (context, k): no allocation, no shared mutable state.

use super::streams::{stream, trial_errors};
use crate::compensate::volumetric_error;
use crate::config::{Config, ErrorDraw, Study};
use crate::error::{Error, Result};
use crate::identify::{design_matrix, identify, IdentifyOptions, LinearSolver, Method, NoiseSplit};
use crate::metrics::{mu, mu0, stats};
use crate::model::geometry::SecondClass;
use crate::model::jacobian::position_sensitivity;
use crate::model::poses::FirstOrder;
use crate::model::poses::{iso9283_positions, workspace_grid};
use crate::model::{ErrorJacobian, ErrorVector, Geometry, Joints, Machine, NominalPoses};
use crate::sensors::{
    homed_unit_noise, observation_into, structured_observation, SensorModel, ARCSEC_PER_RAD,
};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

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
    /// The `failure` column of trials.csv.
    pub fn label(&self) -> &'static str {
        match self {
            Failure::None => "",
            Failure::ForwardKinematics => "fk_failed",
            Failure::NotConverged => "not_converged",
        }
    }

    /// The byte stored in a partial result.
    pub fn code(&self) -> u8 {
        match self {
            Failure::None => 0,
            Failure::ForwardKinematics => 1,
            Failure::NotConverged => 2,
        }
    }

    /// Inverse of [`Failure::code`] (None for a byte no failure has).
    pub fn from_code(code: u8) -> Option<Self> {
        [
            Failure::None,
            Failure::ForwardKinematics,
            Failure::NotConverged,
        ]
        .into_iter()
        .find(|f| f.code() == code)
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
    /// Max, mean and 95th percentile of dV after compensation over the
    /// workspace grid, mm (NaN when off or when some point failed).
    pub dv_after_max: f64,
    pub dv_after_mean: f64,
    pub dv_after_p95: f64,
    /// Worst ISO 9283 pose accuracy AP at P1–P5 after compensation, mm.
    pub ap_after_max: f64,
    /// Max dV before compensation (nominal commands), mm (NaN when off).
    pub dv_before_max: f64,
}

/// Points where a calibration's accuracy is judged, with their nominal
/// solutions and the first-order position sensitivity S = ∂r/∂ε at the
/// nominal commands (a 3 × 15 matrix per point, computed once per study).
#[derive(Debug, Clone, Default)]
pub struct MapGrid {
    pub points: Vec<Vector3<f64>>,
    pub nominal: Vec<Joints>,
    pub commands: Vec<[f64; 3]>,
    pub sensitivity: Vec<ErrorJacobian>,
}

/// Everything a trial needs, built once and shared read-only.
pub struct SweepContext {
    pub geometry: Geometry,
    pub poses: NominalPoses,
    pub grades: Vec<Grade>,
    pub sensors: Vec<SensorModel>,
    /// One prebuilt operator per grade (OLS shared across sensor grades).
    pub solvers: Vec<LinearSolver>,
    /// For each grade, the first grade with the same operator (OLS grades
    /// share one): the noise split of a trial is computed once per operator.
    pub split_of: Vec<usize>,
    /// Every grade's estimate is linear in one shared unit noise (white-noise
    /// sensors, one linearisation): the fast path of [`run_trial`].
    pub linear: bool,
    /// Forward kinematics of a trial's machine starts from the first-order
    /// prediction nominal + J·ε at each calibration pose.
    pub first_order: FirstOrder,
    pub h: DMatrix<f64>,
    pub options: IdentifyOptions,
    pub draw: ErrorDraw,
    pub fixed_errors: ErrorVector,
    pub bound_mm: f64,
    pub seed: u64,
    /// Second-class errors every simulated machine carries.
    pub second_class: Option<SecondClass>,
    /// The workspace grid (empty when volumetric is off) and the ISO 9283
    /// positions P1–P5.
    pub grid: MapGrid,
    pub iso: MapGrid,
    /// dV by exact kinematics instead of first-order propagation.
    pub exact: bool,
}

impl SweepContext {
    /// Grades, solvers and the map of a study of `cfg`'s machine.
    pub fn new(cfg: &Config, study: &Study) -> Result<Self> {
        let nominal = cfg.nominal();
        let poses = NominalPoses::new(&nominal, &study.poses)
            .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
        let h = design_matrix(&nominal, &poses)
            .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
        let sw = &study.sweep;
        let mut sensors = Vec::new();
        for &s in &sw.scale_um {
            for &e in &sw.encoder_arcsec {
                // The grade axis sets a datasheet model's accuracy (SPEC §11).
                let structured = cfg
                    .sensors
                    .structured
                    .map(|st| st.at_grades(e / ARCSEC_PER_RAD, s * 1e-3));
                sensors.push(SensorModel {
                    encoder_arcsec: e,
                    scale_um: s,
                    structured,
                    ..cfg.sensors
                });
            }
        }
        let tol = study.identification.rank_tolerance;
        let ols = LinearSolver::new(&h, &DVector::from_element(h.nrows(), 1.0), tol);
        if ols.analysis.rank == 0 {
            return Err(Error::config(
                &cfg.source,
                "poses: no error can be identified from these poses (the design matrix has rank 0: every pose reads like the reference)",
            ));
        }
        let mut grades = Vec::new();
        let mut solvers = Vec::new();
        let mut split_of = Vec::new();
        let mut first_ols = None;
        for &method in &sw.methods {
            for (si, s) in sensors.iter().enumerate() {
                grades.push(Grade {
                    encoder_arcsec: s.encoder_arcsec,
                    scale_um: s.scale_um,
                    method,
                    sensor_index: si,
                });
                let gi = solvers.len();
                split_of.push(match method {
                    Method::Ols => *first_ols.get_or_insert(gi),
                    Method::Wls => gi,
                });
                solvers.push(match method {
                    Method::Ols => ols.clone(),
                    Method::Wls => LinearSolver::new(&h, &method.row_weights(h.nrows(), s), tol),
                });
            }
        }
        if sw.errors == ErrorDraw::Fixed {
            let mut x = vec![Vector3::zeros(); poses.len()];
            let truth = cfg.truth("sweep.errors = \"fixed\"")?;
            poses.actual_joints_into(&truth, &mut x).map_err(|e| {
                Error::config(
                    &cfg.source,
                    format!(
                        "errors: the machine with these [errors] cannot reach calibration pose {}: {}",
                        e.index, e.source
                    ),
                )
            })?;
        }
        let (grid, iso) = match sw.volumetric_step_mm {
            Some(step) => {
                let ws = &cfg.workspace;
                let points = workspace_grid(ws, step, cfg.layers);
                let iso = iso9283_positions(ws).to_vec();
                (
                    map_grid(cfg, points, "sweep.volumetric_grid_step")?,
                    map_grid(cfg, iso, "workspace (ISO 9283 positions)")?,
                )
            }
            None => (MapGrid::default(), MapGrid::default()),
        };
        let first_order = FirstOrder::new(&nominal, &poses)
            .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
        let linear =
            study.identification.iterations <= 1 && sensors.iter().all(|s| s.structured.is_none());
        Ok(SweepContext {
            split_of,
            linear,
            first_order,
            second_class: cfg.second_class,
            grid,
            iso,
            exact: sw.volumetric_exact,
            geometry: cfg.geometry,
            poses,
            grades,
            sensors,
            solvers,
            h,
            options: study.identification,
            draw: sw.errors,
            fixed_errors: cfg.errors,
            bound_mm: sw.error_bound_mm,
            seed: sw.seed,
        })
    }

    /// Rows of l: 3 per pose after the reference.
    pub fn rows(&self) -> usize {
        self.h.nrows()
    }

    /// Is dV computed per calibration?
    pub fn volumetric(&self) -> bool {
        !self.grid.points.is_empty()
    }
}

/// Nominal solutions and sensitivities at `points`; errors name `key`.
fn map_grid(cfg: &Config, points: Vec<Vector3<f64>>, key: &str) -> Result<MapGrid> {
    let nominal = cfg.nominal();
    let mut grid = MapGrid {
        points,
        ..MapGrid::default()
    };
    for r in &grid.points {
        let fail = |e: crate::error::KinematicsError| {
            Error::config(&cfg.source, format!("{key}: map point {r:?}: {e}"))
        };
        let pose = nominal.inverse(r).map_err(fail)?;
        grid.sensitivity
            .push(position_sensitivity(&pose).map_err(fail)?);
        grid.nominal.push(pose.joints);
        grid.commands.push(pose.legs_mm);
    }
    Ok(grid)
}

/// Per-worker buffers, reused across trials (no allocation per pose).
pub struct Scratch {
    actual: Vec<Vector3<f64>>,
    /// First-order prediction of the joints (3 per pose).
    guess: Vec<f64>,
    /// Readings of structured sensors at every pose.
    readings: Vec<Vector3<f64>>,
    /// dV at every grid point of each grade's calibration (grade-major).
    dv: Vec<f64>,
    /// Truth − estimate of each grade's calibration.
    residual: Vec<ErrorVector>,
    l0: Vec<f64>,
    /// The trial's homed unit noise, shared by every grade (see
    /// [`homed_unit_noise`]).
    dz: Vec<f64>,
    /// Each operator's estimate split by noise source (fast path).
    splits: Vec<NoiseSplit>,
    /// Noisy observation per sensor grade (sensor-major; general path).
    l: Vec<f64>,
}

impl Scratch {
    pub fn new(ctx: &SweepContext) -> Self {
        Scratch {
            actual: vec![Vector3::zeros(); ctx.poses.len()],
            guess: vec![0.0; 3 * ctx.poses.len()],
            readings: vec![Vector3::zeros(); ctx.poses.len()],
            dv: vec![0.0; ctx.grid.points.len() * ctx.grades.len()],
            residual: vec![ErrorVector::zeros(); ctx.grades.len()],
            l0: vec![0.0; ctx.rows()],
            dz: vec![0.0; ctx.rows()],
            splits: vec![NoiseSplit::default(); ctx.grades.len()],
            l: vec![0.0; ctx.rows() * ctx.sensors.len()],
        }
    }

    /// The noisy observation of sensor grade `s` in the last trial.
    pub fn observation(&self, s: usize) -> &[f64] {
        let m = self.l0.len();
        &self.l[s * m..(s + 1) * m]
    }

    /// Write every sensor grade's noisy observation (the fast path forms
    /// none; tests and the general path read them here).
    pub fn form_observations(&mut self, ctx: &SweepContext) {
        let m = self.l0.len();
        for (si, sensor) in ctx.sensors.iter().enumerate() {
            let sc = sensor.unit_scale();
            let out = &mut self.l[si * m..(si + 1) * m];
            for (r, o) in out.iter_mut().enumerate() {
                *o = self.l0[r] + sc[r % 3] * self.dz[r];
            }
        }
    }
}

/// Trial k: one true machine, every grade. Writes one outcome per grade.
pub fn run_trial(ctx: &SweepContext, k: u64, s: &mut Scratch, out: &mut [Outcome]) {
    let truth_e = trial_errors(ctx.draw, &ctx.fixed_errors, ctx.bound_mm, ctx.seed, k);
    let m0 = mu0(&truth_e);
    let truth = Machine {
        second: ctx.second_class,
        ..Machine::with_errors(&ctx.geometry, &truth_e)
    };
    ctx.first_order.predict(&truth_e, &mut s.guess);
    let fk = ctx
        .poses
        .actual_joints_near(&truth, &s.guess, &mut s.actual);
    if fk.is_err() {
        out.fill(Outcome {
            mu: f64::NAN,
            mu0: m0,
            rank: 0,
            failure: Failure::ForwardKinematics,
            error: ErrorVector::zeros(),
            dv_after_max: f64::NAN,
            dv_after_mean: f64::NAN,
            dv_after_p95: f64::NAN,
            ap_after_max: f64::NAN,
            dv_before_max: f64::NAN,
        });
        return;
    }
    let dv_before_max = match (ctx.volumetric(), ctx.exact) {
        (false, _) => f64::NAN,
        (true, true) => volumetric_before(ctx, &truth),
        (true, false) => first_order_max(&ctx.grid, &truth_e),
    };
    observation_into(&ctx.poses.joints, &s.actual, &mut s.l0);
    // Common random numbers: every grade reads the same draws of stream 1,
    // scaled by its own grade.
    if ctx.linear {
        homed_unit_noise(&ctx.sensors[0], &mut stream(ctx.seed, k, 1), &mut s.dz);
        for (gi, &first) in ctx.split_of.iter().enumerate() {
            if first == gi {
                s.splits[gi] = ctx.solvers[gi].apply_split(&s.l0, &s.dz);
            }
        }
    } else {
        sensor_observations(ctx, k, s);
    }
    for (gi, (g, o)) in ctx.grades.iter().zip(out.iter_mut()).enumerate() {
        let (est, failure) = if ctx.linear {
            let scale = ctx.sensors[g.sensor_index].unit_scale();
            (s.splits[ctx.split_of[gi]].estimate(&scale), Failure::None)
        } else {
            calibrate(ctx, gi, s.observation(g.sensor_index))
        };
        if ctx.volumetric() {
            s.residual[gi] = truth_e - est;
        }
        let acc = match (ctx.volumetric(), ctx.exact) {
            (true, true) => {
                let n = ctx.grid.points.len();
                volumetric_after(ctx, &truth, &est, &mut s.dv[..n])
            }
            _ => Accuracy::NONE,
        };
        *o = Outcome {
            mu: mu(&truth_e, &est),
            mu0: m0,
            rank: ctx.solvers[gi].analysis.rank as u8,
            failure,
            error: est - truth_e,
            dv_after_max: acc.max,
            dv_after_mean: acc.mean,
            dv_after_p95: acc.p95,
            ap_after_max: acc.ap_max,
            dv_before_max,
        };
    }
    if ctx.volumetric() && !ctx.exact {
        first_order_after(ctx, s, out);
    }
}

/// Every sensor grade's noisy observation of trial k (general path): white
/// noise from the shared unit draw; structured sensors read stream 1 afresh
/// per grade, so every grade sees the same phases and jitter draws.
fn sensor_observations(ctx: &SweepContext, k: u64, s: &mut Scratch) {
    if ctx.sensors.iter().all(|x| x.structured.is_none()) {
        homed_unit_noise(&ctx.sensors[0], &mut stream(ctx.seed, k, 1), &mut s.dz);
        s.form_observations(ctx);
        return;
    }
    let m = ctx.rows();
    for (si, sensor) in ctx.sensors.iter().enumerate() {
        let out = &mut s.l[si * m..(si + 1) * m];
        let mut rng = stream(ctx.seed, k, 1);
        match &sensor.structured {
            Some(st) => structured_observation(
                st,
                sensor.samples,
                &mut rng,
                &ctx.poses.joints,
                &s.actual,
                &mut s.readings,
                out,
            ),
            None => {
                homed_unit_noise(sensor, &mut rng, &mut s.dz);
                let sc = sensor.unit_scale();
                for (r, o) in out.iter_mut().enumerate() {
                    *o = s.l0[r] + sc[r % 3] * s.dz[r];
                }
            }
        }
    }
}

/// One calibration of grade `gi` from its observation `l`: the prebuilt
/// operator, then Gauss–Newton when the study iterates.
fn calibrate(ctx: &SweepContext, gi: usize, l: &[f64]) -> (ErrorVector, Failure) {
    let solver = &ctx.solvers[gi];
    let mut est = ErrorVector::zeros();
    if ctx.options.iterations <= 1 {
        solver.apply(l, &mut est);
        return (est, Failure::None);
    }
    let lv = DVector::from_column_slice(l);
    match identify(&ctx.geometry, &ctx.poses, solver, &lv, &ctx.options) {
        Ok((e, _)) if e.termination.converged() => (e.values, Failure::None),
        Ok((e, _)) => (e.values, Failure::NotConverged),
        Err(_) => {
            solver.apply(l, &mut est);
            (est, Failure::NotConverged)
        }
    }
}

/// Max dV of `truth` commanded by the nominal model over the map (NaN if any
/// point fails).
fn volumetric_before(ctx: &SweepContext, truth: &Machine) -> f64 {
    let g = &ctx.grid;
    let mut mx = 0.0f64;
    for ((q, j), r) in g.commands.iter().zip(&g.nominal).zip(&g.points) {
        match volumetric_error(truth, q, r, j) {
            Ok(dv) => mx = mx.max(dv),
            Err(_) => return f64::NAN,
        }
    }
    mx
}

/// One calibration's accuracy over the workspace.
#[derive(Debug, Clone, Copy)]
struct Accuracy {
    max: f64,
    mean: f64,
    p95: f64,
    ap_max: f64,
}

impl Accuracy {
    const NONE: Accuracy = Accuracy {
        max: f64::NAN,
        mean: f64::NAN,
        p95: f64::NAN,
        ap_max: f64::NAN,
    };

    /// Max, mean and p95 of the grid's dV (reorders `dv`), with the worst AP.
    fn of(dv: &mut [f64], ap_max: f64) -> Accuracy {
        let (mx, sum) = dv
            .iter()
            .fold((0.0f64, 0.0), |(m, s), &d| (m.max(d), s + d));
        Accuracy {
            max: mx,
            mean: sum / dv.len() as f64,
            p95: stats::quantile_unsorted(dv, 0.95),
            ap_max,
        }
    }
}

/// |S·e| at a point: the first-order position error of a machine whose
/// errors differ from the commanding model's by `e`.
#[inline]
fn first_order_dv(s: &ErrorJacobian, e: &ErrorVector) -> f64 {
    // Fixed-size arrays: no bounds checks, the three dot products vectorise.
    let s: &[[f64; 3]; 15] = &s.data.0;
    let e: &[f64; 15] = &e.data.0[0];
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    for c in 0..15 {
        x += s[c][0] * e[c];
        y += s[c][1] * e[c];
        z += s[c][2] * e[c];
    }
    (x * x + y * y + z * z).sqrt()
}

/// Max of |S·e| over a grid.
fn first_order_max(grid: &MapGrid, e: &ErrorVector) -> f64 {
    grid.sensitivity
        .iter()
        .map(|s| first_order_dv(s, e))
        .fold(0.0, f64::max)
}

/// Accuracy after compensation by first-order propagation for every grade
/// of the trial: the machine's errors minus the identified ones (in
/// `s.residual`), through each point's sensitivity. Each sensitivity is read
/// once for all grades (the grid's sensitivities are larger than the cache).
fn first_order_after(ctx: &SweepContext, s: &mut Scratch, out: &mut [Outcome]) {
    let n = ctx.grid.points.len();
    let g = out.len();
    for (p, sens) in ctx.grid.sensitivity.iter().enumerate() {
        for (gi, r) in s.residual[..g].iter().enumerate() {
            s.dv[gi * n + p] = first_order_dv(sens, r);
        }
    }
    for (gi, o) in out.iter_mut().enumerate() {
        let ap = first_order_max(&ctx.iso, &s.residual[gi]);
        let acc = Accuracy::of(&mut s.dv[gi * n..(gi + 1) * n], ap);
        o.dv_after_max = acc.max;
        o.dv_after_mean = acc.mean;
        o.dv_after_p95 = acc.p95;
        o.ap_after_max = acc.ap_max;
    }
}

/// dV of `truth` at point `r` commanded by `identified` (exact kinematics).
fn exact_dv(identified: &Machine, truth: &Machine, r: &Vector3<f64>, j: &Joints) -> Option<f64> {
    identified
        .commands(r)
        .ok()
        .and_then(|q| volumetric_error(truth, &q, r, j).ok())
}

/// Accuracy after compensation by exact kinematics at every point (all NaN
/// if any point fails).
fn volumetric_after(
    ctx: &SweepContext,
    truth: &Machine,
    est: &ErrorVector,
    dv: &mut [f64],
) -> Accuracy {
    let identified = Machine::with_errors(&ctx.geometry, est);
    for ((d, r), j) in dv.iter_mut().zip(&ctx.grid.points).zip(&ctx.grid.nominal) {
        match exact_dv(&identified, truth, r, j) {
            Some(x) => *d = x,
            None => return Accuracy::NONE,
        }
    }
    let mut ap = 0.0f64;
    for (r, j) in ctx.iso.points.iter().zip(&ctx.iso.nominal) {
        match exact_dv(&identified, truth, r, j) {
            Some(x) => ap = ap.max(x),
            None => return Accuracy::NONE,
        }
    }
    Accuracy::of(dv, ap)
}

#[cfg(test)]
#[path = "trial_tests.rs"]
mod tests;
