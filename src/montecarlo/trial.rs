//! The trial kernel (SPEC §10 `sweep`): trial k draws one true machine,
//! computes its exact passive-joint values at every pose once (forward
//! kinematics is the cost, shared by all grades), then for every sensor
//! grade draws that grade's noise and, for every estimator, identifies with
//! the [`LinearSolver`] built once per study. A trial is a pure function of
//! (context, k): no allocation per pose, no shared mutable state.

use super::streams::{stream, trial_errors};
use crate::compensate::volumetric_error;
use crate::config::{Config, ErrorDraw, Study};
use crate::error::{Error, Result};
use crate::identify::{design_matrix, identify, IdentifyOptions, LinearSolver, Method};
use crate::metrics::{mu, mu0};
use crate::model::geometry::SecondClass;
use crate::model::poses::midplane_grid;
use crate::model::{ErrorVector, Geometry, Joints, Machine, NominalPoses};
use crate::sensors::{noisy_observation, observation_into, SensorModel};
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
    /// Max and mean dV after compensation on the map plane, mm (NaN when off).
    pub dv_after_max: f64,
    pub dv_after_mean: f64,
    /// Max dV before compensation (nominal commands), mm (NaN when off).
    pub dv_before_max: f64,
}

/// The per-calibration volumetric map: points and their nominal solutions.
#[derive(Debug, Clone, Default)]
pub struct MapGrid {
    pub points: Vec<Vector3<f64>>,
    pub nominal: Vec<Joints>,
    pub commands: Vec<[f64; 3]>,
}

/// Everything a trial needs, built once and shared read-only.
pub struct SweepContext {
    pub geometry: Geometry,
    pub poses: NominalPoses,
    pub grades: Vec<Grade>,
    pub sensors: Vec<SensorModel>,
    /// One prebuilt operator per grade (OLS shared across sensor grades).
    pub solvers: Vec<LinearSolver>,
    pub h: DMatrix<f64>,
    pub options: IdentifyOptions,
    pub draw: ErrorDraw,
    pub fixed_errors: ErrorVector,
    pub bound_mm: f64,
    pub seed: u64,
    /// Second-class errors every simulated machine carries.
    pub second_class: Option<SecondClass>,
    /// The map (empty when volumetric is off).
    pub grid: MapGrid,
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
                sensors.push(SensorModel {
                    encoder_arcsec: e,
                    scale_um: s,
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
        for &method in &sw.methods {
            for (si, s) in sensors.iter().enumerate() {
                grades.push(Grade {
                    encoder_arcsec: s.encoder_arcsec,
                    scale_um: s.scale_um,
                    method,
                    sensor_index: si,
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
        let grid = match sw.volumetric_step_mm {
            Some(step) => map_grid(cfg, step)?,
            None => MapGrid::default(),
        };
        Ok(SweepContext {
            second_class: cfg.second_class,
            grid,
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

/// The map plane's grid with nominal solutions.
fn map_grid(cfg: &Config, step: f64) -> Result<MapGrid> {
    let nominal = cfg.nominal();
    let mut grid = MapGrid {
        points: midplane_grid(&cfg.workspace, step, cfg.plane_z_mm),
        ..MapGrid::default()
    };
    for r in &grid.points {
        let pose = nominal.inverse(r).map_err(|e| {
            Error::config(
                &cfg.source,
                format!("sweep.volumetric_grid_step: map point {r:?}: {e}"),
            )
        })?;
        grid.nominal.push(pose.joints);
        grid.commands.push(pose.legs_mm);
    }
    Ok(grid)
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

    /// The noisy observation of sensor grade `s` in the last trial.
    pub fn observation(&self, s: usize) -> &[f64] {
        let m = self.l0.len();
        &self.l[s * m..(s + 1) * m]
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
    if ctx.poses.actual_joints_into(&truth, &mut s.actual).is_err() {
        out.fill(Outcome {
            mu: f64::NAN,
            mu0: m0,
            rank: 0,
            failure: Failure::ForwardKinematics,
            error: ErrorVector::zeros(),
            dv_after_max: f64::NAN,
            dv_after_mean: f64::NAN,
            dv_before_max: f64::NAN,
        });
        return;
    }
    let dv_before_max = if ctx.volumetric() {
        volumetric_before(ctx, &truth)
    } else {
        f64::NAN
    };
    // The noisy observation of every sensor grade, drawn once per trial and
    // shared by every estimator that uses that grade.
    observation_into(&ctx.poses.joints, &s.actual, &mut s.l0);
    let m = ctx.rows();
    for si in 0..ctx.sensors.len() {
        let mut rng = stream(ctx.seed, k, 1 + si as u64);
        noisy_observation(
            &ctx.sensors[si],
            &mut rng,
            &s.l0,
            &mut s.l[si * m..(si + 1) * m],
        );
    }
    for (gi, (g, o)) in ctx.grades.iter().zip(out.iter_mut()).enumerate() {
        let (est, failure) = calibrate(ctx, gi, s.observation(g.sensor_index));
        let (dv_after_max, dv_after_mean) = if ctx.volumetric() {
            volumetric_after(ctx, &truth, &est)
        } else {
            (f64::NAN, f64::NAN)
        };
        *o = Outcome {
            mu: mu(&truth_e, &est),
            mu0: m0,
            rank: ctx.solvers[gi].analysis.rank as u8,
            failure,
            error: est - truth_e,
            dv_after_max,
            dv_after_mean,
            dv_before_max,
        };
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

/// Max and mean dV of `truth` commanded by the model identified as `est`,
/// over the map (NaN if any point fails).
fn volumetric_after(ctx: &SweepContext, truth: &Machine, est: &ErrorVector) -> (f64, f64) {
    let identified = Machine::with_errors(&ctx.geometry, est);
    let mut mx = 0.0f64;
    let mut sum = 0.0;
    for (r, j) in ctx.grid.points.iter().zip(&ctx.grid.nominal) {
        let dv = identified
            .commands(r)
            .ok()
            .and_then(|q| volumetric_error(truth, &q, r, j).ok());
        match dv {
            Some(d) => {
                mx = mx.max(d);
                sum += d;
            }
            None => return (f64::NAN, f64::NAN),
        }
    }
    (mx, sum / ctx.grid.points.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::{observation_vector, simulate_readings};

    fn paper_context(encoder_arcsec: f64) -> (Config, SweepContext) {
        let cfg = Config::paper().unwrap();
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .encoder_arcsec(&[encoder_arcsec])
            .scale_um(&[0.5])
            .methods(&[Method::Ols, Method::Wls])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(&cfg, &study).unwrap();
        (cfg, ctx)
    }

    #[test]
    fn trial_sees_what_simulate_reads_from_the_same_stream() {
        let (cfg, ctx) = paper_context(4.0);
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        let k = 17;
        run_trial(&ctx, k, &mut s, &mut out);
        // The readings file `simulate` would write with the trial's noise stream.
        let mut rng = stream(ctx.seed, k, 1);
        let readings = simulate_readings(
            &ctx.poses,
            &cfg.truth("test").unwrap(),
            Some(&ctx.sensors[0]),
            &mut rng,
        )
        .unwrap();
        let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
        let l = observation_vector(&ctx.poses.joints, &joints);
        let trial_l = s.observation(0);
        let diff = l
            .iter()
            .zip(trial_l)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(diff < 1e-12, "readings and trial differ by {diff:e}");
        // Noise is really there: the trial's l is not the noise-free one.
        let exact: f64 = trial_l.iter().zip(&s.l0).map(|(a, b)| (a - b).abs()).sum();
        assert!(exact > 1e-6);
        // Both estimators identify from that observation.
        for (gi, o) in out.iter().enumerate() {
            let est = ctx.solvers[gi].estimate(&l);
            let d = (mu(&cfg.errors, &est.values) - o.mu).abs();
            assert!(d < 1e-9, "grade {gi}: mu differs by {d:e}");
            assert_eq!(o.mu0, mu0(&cfg.errors));
            assert!((o.error - (est.values - cfg.errors)).amax() < 1e-9);
            assert_eq!(o.failure, Failure::None);
        }
    }

    #[test]
    fn failure_codes_round_trip() {
        for f in [
            Failure::None,
            Failure::ForwardKinematics,
            Failure::NotConverged,
        ] {
            assert_eq!(Failure::from_code(f.code()), Some(f));
        }
        assert_eq!(Failure::from_code(9), None);
        assert_eq!(Failure::NotConverged.label(), "not_converged");
    }

    #[test]
    fn gauss_newton_in_a_trial_beats_one_linearisation_without_noise() {
        let cfg = Config::paper().unwrap();
        let mu_with = |iterations: usize| {
            let study = cfg
                .study()
                .errors(ErrorDraw::Fixed)
                .encoder_arcsec(&[1e-9])
                .scale_um(&[1e-9])
                .trials(1)
                .iterations(iterations)
                .build()
                .unwrap();
            let ctx = SweepContext::new(&cfg, &study).unwrap();
            let mut s = Scratch::new(&ctx);
            let mut out = vec![Outcome::default(); 1];
            run_trial(&ctx, 0, &mut s, &mut out);
            assert_eq!(out[0].failure, Failure::None);
            out[0].mu
        };
        let (one, gn) = (mu_with(1), mu_with(10));
        // dyA3 (0.2 mm in Table 2) cannot be identified: μ ≥ 0.2/15 ≈ 0.0133;
        // one linearisation leaves ≈ 0.0142, Gauss–Newton ≈ 0.0135.
        let floor = cfg.errors[11].abs() / 15.0;
        assert!(gn > floor && gn < floor + 2e-4, "Gauss-Newton mu {gn}");
        assert!(
            one > gn + 5e-4,
            "one linearisation {one} vs Gauss-Newton {gn}"
        );
    }
}
