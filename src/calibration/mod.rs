//! One self-calibration from a validated [`Config`], end to end: simulated
//! readings of the config's machine, identification from readings (real or
//! simulated), the volumetric map before and after compensation, and the
//! compensated commands for targets. `simulate`, `identify`, `compensate`
//! and `reproduce` all go through here; errors name the file and line.

mod axes;
pub mod checks;
pub mod geometry;
pub mod readings_check;
mod reference;
mod repeats;
mod verify;

pub use axes::{analyse_poses, AxesFit, HookeAxes, PoseAnalysis};
pub use checks::{
    checks, estimate_covariance, held_out, loose, misfit, misfit_cause, predicted_accuracy, Checks,
    HeldOut, Misfit, PredictedAccuracy, HELD_OUT_FOLDS, MISFIT_LEVEL,
};
pub use reference::{add_reference, Fit, ReferenceUpdate};
pub use repeats::{by_pose, ByPose};
pub use verify::{reference_rows, untested, verify, Untested, VerifyRow};

use crate::compensate::{volumetric_map, VolumetricMap};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::curves::{self, CurveEstimate};
use crate::identify::tricept::simulate_readings;
use crate::identify::tricept::{design_matrix, identify, Estimate, LinearSolver};
use crate::identify::{IdentifyOptions, Method};
use crate::io::Source;
use crate::mechanism::tricept::second_class::with_angles;
use crate::mechanism::tricept::{
    file_values, Joints, Machine, NominalPoses, Reading, Tricept, N_PARAMS, N_READINGS, READINGS,
};
use crate::mechanism::workspace::{iso9283_positions, midplane_grid, workspace_grid};
use crate::montecarlo::simulate_stream;
use crate::sensors::{observation_vector, ObservationCovariance};
use nalgebra::{DVector, Vector3};
use readings_check::{describe, out_of_order, plausible};

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

/// An identification and what it was computed from.
#[derive(Debug, Clone)]
pub struct Calibration {
    pub estimate: Estimate,
    /// The operator of the last linearisation (its analysis is the nominal one).
    pub solver: LinearSolver,
    pub poses: NominalPoses,
    /// The Hooke axes' angles, identified with the 15 errors
    /// (`[identification] second_class = true`).
    pub axes: Option<AxesFit>,
    /// The declared sensors' covariance of the homed observation, with the
    /// interpolation error's kernel, at the measured readings: what every
    /// stated number propagates ([`stated_covariance`]).
    pub stated: ObservationCovariance,
    /// The readings' joint values as measured (reference first): where GLS
    /// evaluates its weighting.
    pub measured: Vec<Joints>,
    /// The estimate's covariance after external reference points were
    /// added ([`add_reference`]); None: the readings' own.
    pub covariance: Option<nalgebra::DMatrix<f64>>,
    /// Each pose's distinct pose where the log repeats poses as fresh
    /// readings ([`by_pose`]): the held-out folds leave out whole poses.
    /// Empty: every pose its own.
    pub groups: Vec<usize>,
}

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

/// A log's checks: every target reachable, then every reading near what
/// the nominal machine reads there; a refusal names the line of `file`.
pub fn check_log(cfg: &Config, readings: &[Reading], file: Source) -> Result<()> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    check_readings(cfg, readings, file)
}

/// Is every target reachable by the config's nominal machine? The error
/// names the line of `file`.
fn check_targets(cfg: &Config, targets: &[Vector3<f64>], file: Source) -> Result<()> {
    verify::check_targets(&cfg.reach(), targets, file)
}

/// Identify from readings (the poses are the readings' targets) with the
/// config's `[identification]`; errors name `file` and the line.
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
    check_readings(cfg, readings, file)?;
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
        refuse_below_layout(cfg, &solver, readings.len(), file, options.rank_tolerance)?;
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
        Some(axes::identify_axes(
            cfg,
            &poses,
            &solver,
            (&l, &stated),
            &mut estimate,
            options,
            file,
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

/// Refuse readings whose poses identify fewer error combinations than the
/// config's pose layout does: the estimate would move along the null
/// directions with nothing to hold it (12 rows for 15 errors fit exactly
/// and give tens of millimetres). The sentence names the rows, the rank,
/// and every null direction.
fn refuse_below_layout(
    cfg: &Config,
    solver: &LinearSolver,
    poses: usize,
    file: Source,
    rank_tolerance: f64,
) -> Result<()> {
    let a = &solver.analysis;
    let Some(reach) = layout_rank(cfg, rank_tolerance) else {
        return Ok(());
    };
    if a.rank >= reach {
        return Ok(());
    }
    // One sentence a first-time user can act on: how many rows, how many
    // combinations, how many more poses at the least. The null directions
    // themselves are long; `identifiability` lists them.
    let more = match reach.saturating_sub(solver.rows()).div_ceil(3) {
        0 => "log poses spread over more of the workspace".to_string(),
        n => format!("log at least {n} more pose(s) spread over the workspace"),
    };
    Err(Error::csv(
        file.name,
        format!(
            "{poses} poses ({} observation rows) identify {} of the {reach} error combinations this machine's own pose layout identifies, so the fit would be underdetermined: {more} (design-poses proposes a set), or identify from the config's [poses]",
            solver.rows(),
            a.rank,
        ),
    ))
}

/// Refuse readings that cannot come from the machine at their targets, and
/// say what they look like (units, column order, sign). Rows are compared
/// relative to the reference row, as the observation uses them, so a
/// controller that logs a homing offset passes; when every other row is off,
/// the reference row is the one blamed. How far a reading may plausibly be
/// from its nominal joint is the mechanism's fact
/// ([`crate::mechanism::tricept::ReadingFact::plausible`]); the diagnosis reads only the
/// readings' facts ([`readings_check`]), in the files' units.
fn check_readings(cfg: &Config, readings: &[Reading], file: Source) -> Result<()> {
    let nominal = cfg.nominal();
    let mut rows = Vec::with_capacity(readings.len());
    for r in readings {
        let Ok(pose) = nominal.inverse(&r.target) else {
            return Ok(()); // check_targets reports it
        };
        rows.push((file_values(&r.joints), file_values(&pose.joints)));
    }
    let minus = |a: &[f64; N_READINGS], b: &[f64; N_READINGS]| -> [f64; N_READINGS] {
        std::array::from_fn(|k| a[k] - b[k])
    };
    let (r0, n0) = rows[0];
    let offset = minus(&r0, &n0);
    let bad: Vec<usize> = (1..rows.len())
        .filter(|&j| !plausible(READINGS, &minus(&minus(&rows[j].0, &offset), &rows[j].1)))
        .collect();
    let Some(&first) = bad.first() else {
        return Ok(());
    };
    // Every row off by the same story: the reference row is the odd one.
    let (k, read, nom) =
        if bad.len() == rows.len() - 1 && rows.len() > 2 && !plausible(READINGS, &offset) {
            (0, r0, n0)
        } else {
            (first, minus(&rows[first].0, &offset), rows[first].1)
        };
    let offset_removed = k > 0 && offset.iter().any(|x| *x != 0.0);
    // Rows out of order: the readings fit another row's target, and that
    // row is off too (a row whose columns are swapped can fit a mirror
    // pose's target, but the mirror row then reads its own target).
    let own = |i: usize| {
        if i == 0 || k == 0 {
            rows[i].0
        } else {
            minus(&rows[i].0, &offset)
        }
    };
    let spread = |d: &[f64; N_READINGS]| {
        READINGS
            .iter()
            .zip(d)
            .map(|(f, x)| x.abs() / f.plausible)
            .fold(0.0, f64::max)
    };
    let elsewhere = (0..rows.len())
        .filter(|&i| i != k)
        .filter(|&i| plausible(READINGS, &minus(&read, &rows[i].1)))
        .filter(|&i| !plausible(READINGS, &minus(&own(i), &rows[i].1)))
        .min_by(|&a, &b| {
            spread(&minus(&read, &rows[a].1)).total_cmp(&spread(&minus(&read, &rows[b].1)))
        });
    if let Some(i) = elsewhere {
        return Err(Error::csv(
            file.name,
            format!(
                "line {}: rows out of order: {}",
                file.line(k),
                out_of_order(
                    READINGS,
                    &read,
                    &readings[k].target,
                    file.line(i) as usize,
                    &readings[i].target
                )
            ),
        ));
    }
    Err(Error::csv(
        file.name,
        format!(
            "line {}: {}",
            file.line(k),
            describe(READINGS, &read, &nom, offset_removed)
        ),
    ))
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
    map_of(cfg, identified, &cfg.truth("a before/after map")?, &grid)
}

/// dV before and after compensation over the workspace grid of docs/method.md §12
/// (`[compensation] layers` planes), exact kinematics.
pub fn workspace_map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = workspace_grid(&cfg.workspace, cfg.grid_step_mm, cfg.layers);
    map_of(cfg, identified, &cfg.truth("workspace accuracy")?, &grid)
}

/// Pose accuracy AP (ISO 9283) at P1–P5 before and after compensation:
/// without a repeatability model, the distance from the commanded to the
/// attained position of one approach.
pub fn iso9283_map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let points = iso9283_positions(&cfg.workspace);
    map_of(
        cfg,
        identified,
        &cfg.truth("ISO 9283 pose accuracy")?,
        &points,
    )
}

/// For a real machine (no truth): the identified model's correction map —
/// `before_mm` is the position error the identified model predicts for the
/// nominal commands (what compensation corrects), `after_mm` what it
/// predicts for the compensated commands (zero up to round-off).
pub fn correction_map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = midplane_grid(&cfg.workspace, cfg.grid_step_mm, cfg.plane_z_mm);
    map_of(cfg, identified, identified, &grid)
}

/// For a real machine: at each map point, the position error (attained −
/// target, mm) the identified model predicts for the nominal commands —
/// the vector whose length is [`correction_map`]'s `before_mm`.
pub fn correction_vectors(
    cfg: &Config,
    identified: &Machine,
    map: &VolumetricMap,
) -> Result<Vec<Vector3<f64>>> {
    let nominal = cfg.nominal();
    map.points
        .iter()
        .map(|r| {
            let nom = nominal.inverse(r).ok()?;
            let q = [nom.legs_mm[0], nom.legs_mm[1], nom.legs_mm[2]];
            crate::compensate::position_error::<Tricept, N_PARAMS, N_READINGS>(
                identified,
                &q,
                r,
                &nom.joints.as_vector(),
            )
            .ok()
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            Error::config(
                &cfg.source,
                "compensation: a map point the correction map reached fails again",
            )
        })
}

fn map_of(
    cfg: &Config,
    identified: &Machine,
    truth: &Machine,
    grid: &[Vector3<f64>],
) -> Result<VolumetricMap> {
    volumetric_map::<Tricept, N_PARAMS, N_READINGS>(&cfg.nominal(), identified, truth, grid)
        .map_err(|e| {
            let p = grid[e.index];
            Error::config(
                &cfg.source,
                format!(
                    "compensation: map point ({:.1}, {:.1}, {:.1}) mm fails: {}",
                    p.x, p.y, p.z, e.source
                ),
            )
        })
}

/// Leg commands (q1, q2, q3 in mm) that put the `identified` machine's O′ on
/// each target; errors name the line of `file`.
pub fn commands(
    cfg: &Config,
    identified: &Machine,
    targets: &[Vector3<f64>],
    file: Source,
) -> Result<Vec<[f64; 3]>> {
    check_targets(cfg, targets, file)?;
    targets
        .iter()
        .enumerate()
        .map(|(k, r)| {
            identified
                .commands(r)
                .map_err(|e| Error::csv(file.name, format!("line {}: {e}", file.line(k))))
        })
        .collect()
}
