//! One self-calibration from a validated [`Config`], end to end: simulated
//! readings of the config's machine, identification from readings (real or
//! simulated), the volumetric map before and after compensation, and the
//! compensated commands for targets. `simulate`, `identify`, `compensate`
//! and `reproduce` all go through here; errors name the file and line.
//! This file reads the Tricept's config; what it runs (a
//! calibration's checks, its second-class angles, the maps and commands,
//! verify, reference points, geometry.json, a log's checks) is written
//! for any mechanism of fixed sizes, in the files beside it.

mod axes;
pub mod checks;
pub mod geometry;
mod maps;
pub mod readings_check;
mod reference;
mod repeats;
mod verify;

pub use axes::{identify_axes, AxesAnalysis, AxesFit, AxesInputs, PoseAnalysis};
pub use checks::{
    checks_of, estimate_covariance, held_out_of, loose, misfit_of, predicted_of,
    refuse_below_layout, Checks, FitInputs, Folds, Grid, HeldOut, Misfit, PredictedAccuracy,
    HELD_OUT_FOLDS, MISFIT_LEVEL,
};
pub use maps::{commands, correction_vectors, map_of};
pub use reference::{add_reference, Fit, ReferenceUpdate};
pub use repeats::{by_pose, ByPose};
pub use verify::{reference_rows, untested, verify, Untested, VerifyRow};

use crate::compensate::VolumetricMap;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::curves::{self, CurveEstimate};
use crate::identify::tricept::simulate_readings;
use crate::identify::tricept::{angle_design, design_matrix, identify, AxesSolver, LinearSolver};
use crate::identify::{EstimateOf, IdentifyOptions, Method, Solver};
use crate::io::Source;
use crate::mechanism::tricept::second_class::{with_angles, Angles, N_ANGLES};
use crate::mechanism::tricept::{
    Joints, Machine, NominalPoses, Reading, N_PARAMS, N_READINGS, PARAM_NAMES,
};
use crate::mechanism::workspace::{iso9283_positions, midplane_grid, workspace_grid};
use crate::mechanism::Unknowns;
use crate::montecarlo::simulate_stream;
use crate::sensors::{observation_vector, ObservationCovariance};
use nalgebra::{DVector, Vector3};

/// Readings of the config's true machine at `poses`, noise drawn from the
/// stream of `seed` (none when `noise_free`).
pub fn simulate(
    cfg: &Config,
    poses: &NominalPoses,
    seed: u64,
    noise_free: bool,
) -> Result<Vec<Reading>> {
    let truth = cfg.truth("simulating readings")?;
    let mut rng = simulate_stream(seed);
    let sensors = if noise_free { None } else { Some(&cfg.sensors) };
    simulate_readings(poses, &truth, sensors, &mut rng).map_err(|e| {
        Error::config(
            &cfg.source,
            format!(
                "errors: the machine with these errors cannot reach pose {}: {}",
                e.index, e.source
            ),
        )
    })
}

/// An identification and what it was computed from, for a mechanism with
/// P errors, R readings a pose and A second-class angles: `Q` its nominal
/// poses, `J` a pose's readings as measured. The checks ([`checks_of`])
/// read any mechanism's; the Tricept's is [`Calibration`].
#[derive(Debug, Clone)]
pub struct CalibrationOf<Q, J, const P: usize, const R: usize, const A: usize> {
    pub estimate: EstimateOf<P>,
    /// The operator of the last linearisation (its analysis is the nominal one).
    pub solver: Solver<P, R>,
    pub poses: Q,
    /// The second-class angles (the Tricept's Hooke axes), identified with
    /// the errors (`[identification] second_class = true`).
    pub axes: Option<AxesFit<P, R, A>>,
    /// The names of the errors and angles.
    pub unknowns: &'static Unknowns<P, A>,
    /// The declared sensors' covariance of the homed observation, with the
    /// interpolation error's kernel, at the measured readings: what every
    /// stated number propagates ([`stated_covariance`]).
    pub stated: ObservationCovariance,
    /// The readings as measured (reference first): where GLS evaluates its
    /// weighting.
    pub measured: Vec<J>,
    /// The estimate's covariance after external reference points were
    /// added ([`add_reference`]); None: the readings' own.
    pub covariance: Option<nalgebra::DMatrix<f64>>,
    /// Each pose's distinct pose where the log repeats poses as fresh
    /// readings ([`by_pose`]): the held-out folds leave out whole poses.
    /// Empty: every pose its own.
    pub groups: Vec<usize>,
}

/// The Tricept's calibration: its 15 errors from the passive limb's three
/// readings, and its Hooke axes' three angles.
pub type Calibration = CalibrationOf<NominalPoses, Joints, N_PARAMS, N_READINGS, N_ANGLES>;

/// The covariance every stated number of a calibration propagates: the
/// declared sensors' (their curves and the interpolation error's kernel,
/// [`crate::sensors::SensorModel::stated_covariances`]) at the readings as
/// measured — a machine's errors move its readings by a good part of a
/// signal period, so the nominal joint values would not do.
pub fn stated_covariance(cfg: &Config, readings: &[Reading]) -> ObservationCovariance {
    let measured: Vec<Joints> = readings.iter().map(|r| r.joints).collect();
    ObservationCovariance::new(&cfg.sensors.stated_covariances(), &measured)
}

impl Calibration {
    /// The identified machine: the nominal geometry with the estimated
    /// errors, and the identified Hooke axes when there are some.
    pub fn machine(&self, cfg: &Config) -> Machine {
        let m = Machine::with_errors(&cfg.geometry, &self.estimate.values);
        match &self.axes {
            Some(a) => with_angles(&m, &a.angles),
            None => m,
        }
    }

    /// Add externally measured absolute positions to the calibration
    /// ([`add_reference`]: the points beside the readings, to first order);
    /// its covariance becomes the points' and readings' together. Not yet
    /// with the Hooke axes identified.
    pub fn add_reference(
        &mut self,
        cfg: &Config,
        points: &[(Vector3<f64>, Vector3<f64>)],
        sigma_mm: f64,
        file: Source,
    ) -> Result<ReferenceUpdate> {
        if self.axes.is_some() {
            return Err(Error::Argument(
                "--reference cannot yet be combined with [identification] second_class = true: identify without one of them".into(),
            ));
        }
        let size = cfg.resolved().geometry.a.min(cfg.resolved().geometry.b);
        let bound = crate::store::inputs::identified_bound_mm(size);
        let identified = self.machine(cfg);
        let fit = Fit {
            covariance: checks::estimate_covariance(self),
            fixed: &self.solver.constraints().fixed.clone(),
            estimate: &mut self.estimate,
        };
        let (done, c) = add_reference(
            (&cfg.reach(), &identified),
            fit,
            points,
            sigma_mm,
            (file, bound),
        )?;
        self.covariance = Some(c);
        Ok(done)
    }
}

/// The Tricept's fit as its checks read it: the declared sensors' Σ and
/// the residual the estimator minimised (None when the estimated machine
/// cannot reach a pose).
fn fit_inputs(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<FitInputs> {
    Some(FitInputs {
        sigma: cal.stated.clone(),
        resid: fit_residual(cfg, cal, readings)?,
    })
}

/// What the held-out folds read of `cfg`.
fn folds(cfg: &Config) -> Folds<'_, N_READINGS> {
    Folds {
        sensors: &cfg.sensors,
        method: cfg.identification.method,
        rank_tolerance: cfg.identification.rank_tolerance,
    }
}

/// The predicted accuracy's workspace grid: `[compensation] layers`
/// planes at the map's step, no finer than a twentieth of the radius.
fn accuracy_points(cfg: &Config) -> Vec<Vector3<f64>> {
    let step = cfg.grid_step_mm.max(cfg.workspace.radius_mm / 20.0);
    workspace_grid(&cfg.workspace, step, cfg.layers)
}

/// Every check of a Tricept calibration ([`checks_of`]) from `cfg`.
pub fn checks(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Checks {
    let (homed, points) = (cfg.homed(), accuracy_points(cfg));
    let grid = Grid {
        homed: &homed,
        points: &points,
        reference: cal.poses.targets.first().copied(),
    };
    checks_of(cal, fit_inputs(cfg, cal, readings), &folds(cfg), &grid)
}

/// The misfit of a Tricept calibration ([`misfit_of`]).
pub fn misfit(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<Misfit> {
    misfit_of(cal, &fit_inputs(cfg, cal, readings)?)
}

/// The held-out check of a Tricept calibration with the config's
/// estimator ([`held_out_of`]).
pub fn held_out(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<HeldOut> {
    held_out_of(&folds(cfg), cal, &fit_inputs(cfg, cal, readings)?)
}

/// The predicted accuracy of a Tricept calibration over the config's
/// workspace ([`predicted_of`]), its covariance scaled by `scale²`.
pub fn predicted_accuracy(
    cfg: &Config,
    cal: &Calibration,
    scale: f64,
) -> Option<PredictedAccuracy> {
    let (homed, points) = (cfg.homed(), accuracy_points(cfg));
    let grid = Grid {
        homed: &homed,
        points: &points,
        reference: cal.poses.targets.first().copied(),
    };
    predicted_of(&grid, cal, scale)
}

/// A log's checks: every target reachable, then every reading near what
/// the nominal machine reads there; a refusal names the line of `file`.
pub fn check_log(cfg: &Config, readings: &[Reading], file: Source) -> Result<()> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    readings_check::check_readings(&cfg.homed(), readings, file)
}

/// Is every target reachable by the config's nominal machine? The error
/// names the line of `file`.
fn check_targets(cfg: &Config, targets: &[Vector3<f64>], file: Source) -> Result<()> {
    verify::check_targets(&cfg.reach(), targets, file)
}

/// Numbers the config's estimator keeps per observation row for its
/// weighting: the factored Σ's columns for GLS, 0 for row weights.
pub fn weight_columns(cfg: &Config) -> u64 {
    if cfg.identification.method != crate::identify::Method::Gls {
        return 0;
    }
    cfg.sensors
        .covariances()
        .iter()
        .map(crate::sensors::factored::factor_columns)
        .max()
        .unwrap_or(1) as u64
}

/// Identify from readings (the poses are the readings' targets) with the
/// config's `[identification]`; errors name `file` and the line.
pub fn identify_from(cfg: &Config, readings: &[Reading], file: Source) -> Result<Calibration> {
    identify_with(cfg, readings, file, &cfg.identification)
}

/// [`identify_from`] with other identification options.
pub fn identify_with(
    cfg: &Config,
    readings: &[Reading],
    file: Source,
    options: &IdentifyOptions<N_PARAMS>,
) -> Result<Calibration> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    readings_check::check_readings(&cfg.homed(), readings, file)?;
    let at_line = |e: crate::error::PoseError| {
        Error::csv(
            file.name,
            format!("line {}: {}", file.line(e.index), e.source),
        )
    };
    let poses = NominalPoses::new(&nominal, &targets).map_err(at_line)?;
    let h = design_matrix(&nominal, &poses).map_err(at_line)?;
    // GLS weights the interpolation error by its kernel where the readings
    // fell: at the measured values (a machine's errors move its readings by
    // a good part of a signal period; docs/method.md §18).
    let measured: Vec<Joints> = readings.iter().map(|r| r.joints).collect();
    let solver = options
        .method
        .solver(
            (&cfg.sensors, &measured),
            &h,
            options.rank_tolerance,
            (
                &options.constraints,
                &crate::mechanism::tricept::PARAM_NAMES,
            ),
        )
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    if solver.analysis.rank == 0 {
        return Err(Error::csv(
            file.name,
            "no error can be identified from these rows (the design matrix has rank 0: every target reads like the reference)",
        ));
    }
    // A prior keeps what the readings leave at the prior (reported as
    // such); without one, fewer independent rows than the layout reaches
    // are refused.
    if options.constraints.prior_std_mm.is_none() {
        let layout = layout_rank(cfg, options.rank_tolerance);
        refuse_below_layout(&solver, layout, readings.len(), file)?;
    }
    let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
    let l = observation_vector(&poses.joints, &joints);
    let (mut estimate, solver) = identify(&cfg.geometry, &poses, &solver, &l, options)
        .map_err(|e| {
            Error::Internal(format!(
                "Gauss-Newton identification failed: the estimated machine cannot reach the pose of line {}: {}",
                file.line(e.index),
                e.source
            ))
        })?;
    let stated = stated_covariance(cfg, readings);
    let axes = if options.second_class {
        let h3 = angle_design(&nominal, &Angles::zeros(), &poses.joints).map_err(at_line)?;
        let inputs = AxesInputs {
            h3: &h3,
            rank_tolerance: options.rank_tolerance,
            layout: layout_angles(cfg, options.rank_tolerance),
            unknowns: cfg.unknowns(),
            poses: poses.len(),
            file,
            config: &cfg.source,
        };
        Some(identify_axes(
            inputs,
            &solver,
            (&l, &stated),
            &mut estimate,
        )?)
    } else {
        // The stated uncertainty, whatever the estimator: √diag(op·Σ·opᵀ)
        // under the declared sensors at the measured readings (a prior's
        // posterior covariance keeps what the readings leave at the prior).
        if options.constraints.prior_std_mm.is_none() {
            let sd = solver.predicted_std_under(&stated);
            for k in 0..crate::mechanism::tricept::N_PARAMS {
                if estimate.identifiable[k] && !estimate.std_mm[k].is_nan() {
                    estimate.std_mm[k] = sd[k];
                }
            }
        }
        None
    };
    Ok(Calibration {
        estimate,
        solver,
        poses,
        axes,
        unknowns: cfg.unknowns(),
        stated,
        measured,
        covariance: None,
        groups: Vec::new(),
    })
}

/// The rank the config's own pose layout (`[poses]`) reaches with these
/// sensors: what a calibration of this machine can identify (None when the
/// layout cannot be built).
pub fn layout_rank(cfg: &Config, rank_tolerance: f64) -> Option<usize> {
    let nominal = cfg.nominal();
    let poses = cfg.nominal_poses().ok()?;
    let h = design_matrix(&nominal, &poses).ok()?;
    Some(
        crate::identify::analysis::analyse_named(
            &h,
            rank_tolerance,
            &crate::mechanism::tricept::PARAM_NAMES,
        )
        .rank,
    )
}

/// The residual the estimator minimised: of the linear model after one
/// linearisation, of the exact model after Gauss–Newton (None when the
/// estimated machine cannot reach a pose).
fn fit_residual(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<DVector<f64>> {
    let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
    let l = observation_vector(&cal.poses.joints, &joints);
    if cal.estimate.iterations <= 1 {
        let mut r = &l - cal.solver.design() * cal.estimate.values;
        if let Some(a) = &cal.axes {
            r -= a.solver.design() * a.angles;
        }
        return Some(r);
    }
    let machine = cal.machine(cfg);
    let mut x = vec![Vector3::zeros(); cal.poses.len()];
    cal.poses.actual_joints_into(&machine, &mut x).ok()?;
    Some(&l - observation_vector(&cal.poses.joints, &x))
}

/// The analysis of the config's poses ([`PoseAnalysis`]).
pub fn analyse_poses(cfg: &Config) -> Result<PoseAnalysis> {
    let poses = cfg.nominal_poses()?;
    let h = design_matrix(&cfg.nominal(), &poses)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let solver = cfg
        .identification
        .method
        .solver(
            (&cfg.sensors, &poses.joints),
            &h,
            cfg.identification.rank_tolerance,
            (&Default::default(), &PARAM_NAMES),
        )
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    let axes = match cfg.identification.second_class {
        true => Some(stated_axes(cfg, &poses, &h, &solver)?),
        false => None,
    };
    Ok(PoseAnalysis {
        poses: poses.len(),
        rows: h.nrows(),
        analysis: solver.analysis,
        axes,
    })
}

/// Which Hooke-axis angles the config's own pose layout identifies (with
/// OLS; None when the layout cannot be built).
fn layout_angles(cfg: &Config, rank_tolerance: f64) -> Option<[bool; N_ANGLES]> {
    let nominal = cfg.nominal();
    let poses = cfg.nominal_poses().ok()?;
    let h = design_matrix(&nominal, &poses).ok()?;
    let h3 = angle_design(&nominal, &Angles::zeros(), &poses.joints).ok()?;
    let base = LinearSolver::unweighted(&h, rank_tolerance);
    AxesSolver::new(&base, &h3, rank_tolerance)
        .ok()
        .map(|e| e.identifiable())
}

/// What the declared sensors let the readings at `poses` say of the Hooke
/// axes' angles, beside the 15 errors' operator `solver` of design `h`:
/// stated at the nominal readings, or, where the datasheets' interpolation
/// error varies within a signal period, averaged over the machines a study
/// draws, each weighted and stated at its own readings as identify would.
fn stated_axes(
    cfg: &Config,
    poses: &NominalPoses,
    h: &nalgebra::DMatrix<f64>,
    solver: &LinearSolver,
) -> Result<AxesAnalysis> {
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let fail =
        |why: String| Error::config(&cfg.source, format!("identification.second_class {why}"));
    let ext = AxesSolver::new(solver, &h3, cfg.identification.rank_tolerance).map_err(fail)?;
    let stated = cfg.sensors.stated_covariances();
    let at_nominal = AxesAnalysis::of(
        solver,
        &ext,
        &ObservationCovariance::new(&stated, &poses.joints),
        cfg.unknowns(),
    );
    let varies = cfg.sensors.structured.is_some_and(|st| {
        st.axes
            .iter()
            .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0)
    });
    if !varies {
        return Ok(at_nominal);
    }
    // As identify would state it on each machine: weighted and stated at
    // that machine's readings.
    let method = cfg.identification.method;
    let tol = cfg.identification.rank_tolerance;
    let mut sum = [0.0; N_ANGLES];
    let machines = over_machines(cfg, poses, |measured| {
        let solver = method
            .solver(
                (&cfg.sensors, measured),
                h,
                tol,
                (&Default::default(), &PARAM_NAMES),
            )
            .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
        let ext = AxesSolver::new(&solver, &h3, tol).map_err(fail)?;
        let x = AxesAnalysis::of(
            &solver,
            &ext,
            &ObservationCovariance::new(&stated, measured),
            cfg.unknowns(),
        );
        for (s, sd) in sum.iter_mut().zip(&x.predicted_std_deg) {
            *s += sd.map_or(0.0, |x| x * x);
        }
        Ok(())
    })?;
    if machines == 0 {
        return Ok(at_nominal);
    }
    Ok(AxesAnalysis {
        predicted_std_deg: (0..N_ANGLES)
            .map(|k| at_nominal.predicted_std_deg[k].map(|_| (sum[k] / f64::from(machines)).sqrt()))
            .collect(),
        ..at_nominal
    })
}

/// Machines a statement without readings averages the interpolation
/// error's kernel over.
const STATED_MACHINES: u64 = 64;

/// Call `each` with the homed true readings of each of [`STATED_MACHINES`]
/// machines drawn as the study draws them (`[sweep] errors`,
/// `error_bound`, `seed`): the interpolation error's kernel depends on
/// where within its signal period each reading falls, which a machine's
/// errors move by a good part of a period, so a statement without
/// readings averages over them. Returns how many machines reached every
/// pose.
fn over_machines(
    cfg: &Config,
    poses: &NominalPoses,
    mut each: impl FnMut(&[Joints]) -> Result<()>,
) -> Result<u32> {
    let sw = &cfg.sweep;
    let mut actual = vec![nalgebra::Vector3::zeros(); poses.len()];
    let mut machines = 0u32;
    for k in 0..STATED_MACHINES {
        let e =
            crate::montecarlo::trial_errors(sw.errors, &cfg.errors, sw.error_bound_mm, sw.seed, k);
        let machine = Machine::with_errors(&cfg.geometry, &e);
        if poses.actual_joints_into(&machine, &mut actual).is_err() {
            continue;
        }
        // Homed at the reference, as the controller reports them.
        let j0 = poses.joints[0].as_vector();
        let measured: Vec<Joints> = actual
            .iter()
            .map(|a| Joints::from_vector(&(j0 + a - actual[0])))
            .collect();
        each(&measured)?;
        machines += 1;
    }
    Ok(machines)
}

/// The likely cause of a rejected misfit of a Tricept calibration, in
/// words.
/// `axes`: the Hooke axes were identified (`second_class = true`);
/// `fixed`: the errors `[identification] fix` holds (a held value that is
/// not the machine's leaves a residual the others cannot absorb).
pub fn misfit_cause(m: &Misfit, iterations: usize, axes: bool, fixed: &[&str]) -> String {
    let base = match (m.ratio > 30.0, iterations <= 1, axes) {
        (true, _, _) => "readings in other units or column order, readings of another machine, or a geometry ([geometry]) far from this machine's",
        (false, true, false) => "the single linearisation (errors of tenths of a millimetre leave a second-order residual: set [identification] iterations = 5), errors the model leaves out (misaligned Hooke axes: identify them with [identification] second_class = true), or sensors noisier than [sensors] declares",
        (false, true, true) => "the single linearisation (errors of tenths of a millimetre leave a second-order residual, which second_class cannot yet iterate away), errors the model leaves out (the guide's twist, thermal drift, play), or sensors noisier than [sensors] declares",
        (false, false, _) => "errors the model leaves out (the UP limb's second-class errors: [identification] second_class = true identifies the Hooke axes; thermal drift, play) or sensors noisier than [sensors] declares",
    };
    if fixed.is_empty() {
        base.to_string()
    } else {
        format!(
            "the values [identification] fix holds ({}: one that is not this machine's leaves a residual the other errors cannot take up; identify without it to compare), or {base}",
            fixed.join(", ")
        )
    }
}

/// Linearisations of the GLS fit the sensor curves are read from: the
/// residual of one linearisation carries the model's second-order error
/// (at ±0.5 mm it inflates the curves' spread by about a fifth), the
/// converged fit's does not.
const CURVE_ITERATIONS: usize = 5;

/// Each datasheet sensor's curve on this machine (posterior mean and
/// standard deviation of its harmonic coefficients, see
/// [`crate::identify::curves`]), from a GLS Gauss–Newton fit of the
/// readings: the calibration's own when it is one, else a fit of the same
/// readings with `method = "gls"` and at least [`CURVE_ITERATIONS`]
/// linearisations. None without datasheet sensors, or when that fit fails.
pub fn sensor_curves(
    cfg: &Config,
    cal: &Calibration,
    readings: &[Reading],
) -> Option<Vec<CurveEstimate>> {
    cfg.sensors.structured.as_ref()?;
    let own;
    let cal = if cfg.identification.method == Method::Gls && cal.estimate.iterations > 1 {
        cal
    } else {
        let options = IdentifyOptions {
            method: Method::Gls,
            iterations: cfg.identification.iterations.max(CURVE_ITERATIONS),
            // The curves' fit is of the 15 errors (Gauss–Newton does not
            // carry the Hooke axes yet).
            second_class: false,
            ..cfg.identification
        };
        own = identify_with(cfg, readings, Source::new("readings", &[]), &options).ok()?;
        &own
    };
    if cal.estimate.values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let r = fit_residual(cfg, cal, readings)?;
    // The curves are read at the joint values of the fitted machine, not
    // the nominal ones: at ±0.5 mm a scale's q4 moves by a fraction of a
    // mm, enough to shift its curve by more than its jitter.
    let machine = Machine::with_errors(&cfg.geometry, &cal.estimate.values);
    let mut x = vec![Vector3::zeros(); cal.poses.len()];
    cal.poses.actual_joints_into(&machine, &mut x).ok()?;
    let at: Vec<Joints> = x.iter().map(Joints::from_vector).collect();
    let s = &cal.solver;
    curves::sensor_curves(s.design(), &s.analysis, &cfg.sensors, &at, &r)
}

/// dV over the config's map plane of its true machine, commanded by the
/// nominal and by the `identified` model.
pub fn map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = midplane_grid(&cfg.workspace, cfg.grid_step_mm, cfg.plane_z_mm);
    let truth = cfg.truth("a before/after map")?;
    map_of(&cfg.homed(), (identified, &truth), &grid, &cfg.source)
}

/// dV before and after compensation over the workspace grid of docs/method.md §12
/// (`[compensation] layers` planes), exact kinematics.
pub fn workspace_map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = workspace_grid(&cfg.workspace, cfg.grid_step_mm, cfg.layers);
    let truth = cfg.truth("workspace accuracy")?;
    map_of(&cfg.homed(), (identified, &truth), &grid, &cfg.source)
}

/// Pose accuracy AP (ISO 9283) at P1–P5 before and after compensation:
/// without a repeatability model, the distance from the commanded to the
/// attained position of one approach.
pub fn iso9283_map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let points = iso9283_positions(&cfg.workspace);
    let truth = cfg.truth("ISO 9283 pose accuracy")?;
    map_of(&cfg.homed(), (identified, &truth), &points, &cfg.source)
}

/// For a real machine (no truth): the identified model's correction map —
/// `before_mm` is the position error the identified model predicts for the
/// nominal commands (what compensation corrects), `after_mm` what it
/// predicts for the compensated commands (zero up to round-off).
pub fn correction_map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = midplane_grid(&cfg.workspace, cfg.grid_step_mm, cfg.plane_z_mm);
    map_of(&cfg.homed(), (identified, identified), &grid, &cfg.source)
}
