//! One self-calibration from a validated [`Config`], end to end: simulated
//! readings of the config's machine, identification from readings (real or
//! simulated), the volumetric map before and after compensation, and the
//! compensated commands for targets. `simulate`, `identify`, `compensate`
//! and `reproduce` all go through here; errors name the file and line.

pub mod readings_check;

use crate::compensate::{volumetric_map, VolumetricMap};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::curves::{self, CurveEstimate};
use crate::identify::{
    design_matrix, identify, Estimate, IdentifyOptions, LinearSolver, Method, Weighting,
};
use crate::io::data_line;
use crate::model::check_pose;
use crate::model::poses::{iso9283_positions, midplane_grid, workspace_grid};
use crate::model::{file_values, Joints, Machine, NominalPoses, N_READINGS, READINGS};
use crate::montecarlo::simulate_stream;
use crate::sensors::{observation_vector, simulate_readings, Reading};
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
}

/// Is every target reachable by the nominal machine? The error names the
/// line of `file`.
fn check_targets(cfg: &Config, targets: &[Vector3<f64>], file: &str) -> Result<()> {
    let nominal = cfg.nominal();
    for (k, r) in targets.iter().enumerate() {
        check_pose(&nominal, r, cfg.max_tilt_deg).map_err(|why| {
            Error::csv(
                file,
                format!(
                    "line {}: target ({}, {}, {}) mm is not reachable: {why}",
                    data_line(k),
                    r.x,
                    r.y,
                    r.z
                ),
            )
        })?;
    }
    Ok(())
}

/// Identify from readings (the poses are the readings' targets) with the
/// config's `[identification]`; errors name `file` and the line.
pub fn identify_from(cfg: &Config, readings: &[Reading], file: &str) -> Result<Calibration> {
    identify_with(cfg, readings, file, &cfg.identification)
}

/// [`identify_from`] with other identification options.
pub fn identify_with(
    cfg: &Config,
    readings: &[Reading],
    file: &str,
    options: &IdentifyOptions,
) -> Result<Calibration> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    check_readings(cfg, readings, file)?;
    let at_line = |e: crate::error::PoseError| {
        Error::csv(file, format!("line {}: {}", data_line(e.index), e.source))
    };
    let poses = NominalPoses::new(&nominal, &targets).map_err(at_line)?;
    let h = design_matrix(&nominal, &poses).map_err(at_line)?;
    let weighting = options
        .method
        .weighting(&cfg.sensors, &poses.joints)
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    let solver = LinearSolver::new(&h, &weighting, options.rank_tolerance);
    if solver.analysis.rank == 0 {
        return Err(Error::csv(
            file,
            "no error can be identified from these rows (the design matrix has rank 0: every target reads like the reference)",
        ));
    }
    refuse_below_layout(cfg, &solver, readings.len(), file, options.rank_tolerance)?;
    let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
    let l = observation_vector(&poses.joints, &joints);
    let (estimate, solver) = identify(&cfg.geometry, &poses, &solver, &l, options)
        .map_err(|e| {
            Error::Internal(format!(
                "Gauss-Newton identification failed: the estimated machine cannot reach the pose of line {}: {}",
                data_line(e.index),
                e.source
            ))
        })?;
    Ok(Calibration {
        estimate,
        solver,
        poses,
    })
}

/// The rank the config's own pose layout (`[poses]`) reaches with these
/// sensors: what a calibration of this machine can identify (None when the
/// layout cannot be built).
pub fn layout_rank(cfg: &Config, rank_tolerance: f64) -> Option<usize> {
    let nominal = cfg.nominal();
    let poses = cfg.nominal_poses().ok()?;
    let h = design_matrix(&nominal, &poses).ok()?;
    Some(crate::identify::analysis::analyse(&h, rank_tolerance).rank)
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
    file: &str,
    rank_tolerance: f64,
) -> Result<()> {
    let a = &solver.analysis;
    let Some(reach) = layout_rank(cfg, rank_tolerance) else {
        return Ok(());
    };
    if a.rank >= reach {
        return Ok(());
    }
    Err(Error::csv(
        file,
        format!(
            "{poses} poses ({} observation rows) identify only {} of the {} error combinations that the config's pose layout identifies ({reach} of {}); these cannot be told apart and would be fitted to anything: {}. Log more poses spread over the workspace (design-poses proposes a set), or identify from the config's [poses]",
            solver.rows(),
            a.rank,
            reach,
            a.parameters,
            a.unidentifiable_combinations.join("; ")
        ),
    ))
}

/// Refuse readings that cannot come from the machine at their targets, and
/// say what they look like (units, column order, sign). Rows are compared
/// relative to the reference row, as the observation uses them, so a
/// controller that logs a homing offset passes; when every other row is off,
/// the reference row is the one blamed. How far a reading may plausibly be
/// from its nominal joint is the mechanism's fact
/// ([`crate::model::ReadingFact::plausible`]); the diagnosis reads only the
/// readings' facts ([`readings_check`]), in the files' units.
fn check_readings(cfg: &Config, readings: &[Reading], file: &str) -> Result<()> {
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
            file,
            format!(
                "line {}: rows out of order: {}",
                data_line(k),
                out_of_order(
                    READINGS,
                    &read,
                    &readings[k].target,
                    data_line(i),
                    &readings[i].target
                )
            ),
        ));
    }
    Err(Error::csv(
        file,
        format!(
            "line {}: {}",
            data_line(k),
            describe(READINGS, &read, &nom, offset_removed)
        ),
    ))
}

/// How far the fit's residual is from the declared sensor noise: the RMS of
/// each row's residual over the standard deviation of that row's observation
/// (√2·σ of its sensor: the row differs two noisy readings); with GLS the
/// RMS of the residual whitened by the sensors' covariance Σ. About 1 when
/// the readings carry the declared noise; None without sensor noise or
/// degrees of freedom.
pub fn noise_ratio(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<f64> {
    let sigma = cfg.sensors.reading_sigma();
    if cal.estimate.dof == 0 || sigma.iter().any(|s| *s <= 0.0) {
        return None;
    }
    let r = fit_residual(cfg, cal, readings)?;
    if let Weighting::Whiten(_) = cal.solver.weighting() {
        // GLS: the residual whitened by the sensors' covariance (its
        // reference reading's share included).
        let white = cal.solver.weighting().apply_vector(&r);
        return Some((white.norm_squared() / cal.estimate.dof as f64).sqrt());
    }
    let sum: f64 = r
        .iter()
        .enumerate()
        .map(|(i, x)| (x / (sigma[i % 3] * std::f64::consts::SQRT_2)).powi(2))
        .sum();
    Some((sum / cal.estimate.dof as f64).sqrt())
}

/// The fit's misfit against the sensors the config declares: χ² of the
/// residual whitened by their covariance Σ, after the best linear
/// correction of the identifiable errors (GLS's own residual, whatever the
/// estimator), on m − rank degrees of freedom.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Misfit {
    pub chi2: f64,
    pub dof: usize,
    /// P(χ²_dof ≥ chi2): the chance of a misfit this large from the
    /// declared sensors alone.
    pub p_value: f64,
    /// √(χ²/dof): how many times the declared noise the residual is; the
    /// factor the uncertainties are scaled by when the test rejects.
    pub ratio: f64,
    /// The test rejects the model at 1 %.
    pub rejected: bool,
}

/// Significance of the misfit test.
pub const MISFIT_LEVEL: f64 = 0.01;

/// The misfit of `cal` (None without degrees of freedom, a positive
/// definite Σ or a residual).
pub fn misfit(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<Misfit> {
    // Dense Σ: within the rows a dense covariance is built for.
    crate::identify::check_dense_rows(cal.solver.rows()).ok()?;
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let r = fit_residual(cfg, cal, readings)?;
    let sigma =
        crate::sensors::observation_covariance(&cfg.sensors.covariances(), &cal.poses.joints);
    let w = Weighting::whiten(sigma).ok()?;
    let rw = w.apply_vector(&r);
    let h = cal.solver.design();
    let active: Vec<usize> = (0..h.ncols())
        .filter(|&c| cal.solver.analysis.identifiable[c])
        .collect();
    let hw = w.apply(&h.select_columns(&active));
    let rank = active.len();
    let dof = hw.nrows().checked_sub(rank).filter(|&d| d > 0)?;
    let resid = if rank > 0 {
        let q = hw.qr().q();
        &rw - &q * (q.transpose() * &rw)
    } else {
        rw
    };
    let chi2 = resid.norm_squared();
    let p_value = ChiSquared::new(dof as f64).ok()?.sf(chi2);
    Some(Misfit {
        chi2,
        dof,
        p_value,
        ratio: (chi2 / dof as f64).sqrt(),
        rejected: p_value < MISFIT_LEVEL,
    })
}

/// The likely cause of a rejected misfit, in words.
pub fn misfit_cause(m: &Misfit, iterations: usize) -> &'static str {
    if m.ratio > 30.0 {
        "readings in other units or column order, readings of another machine, or a geometry ([geometry]) far from this machine's"
    } else if iterations <= 1 {
        "the single linearisation (errors of tenths of a millimetre leave a second-order residual: set [identification] iterations = 5), or errors the model leaves out"
    } else {
        "errors the model leaves out (the UP limb's second-class errors, thermal drift, play) or sensors noisier than [sensors] declares"
    }
}

/// The residual the estimator minimised: of the linear model after one
/// linearisation, of the exact model after Gauss–Newton (None when the
/// estimated machine cannot reach a pose).
fn fit_residual(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<DVector<f64>> {
    let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
    let l = observation_vector(&cal.poses.joints, &joints);
    if cal.estimate.iterations <= 1 {
        return Some(&l - cal.solver.design() * cal.estimate.values);
    }
    let machine = Machine::with_errors(&cfg.geometry, &cal.estimate.values);
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
            ..cfg.identification
        };
        own = identify_with(cfg, readings, "readings", &options).ok()?;
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

fn map_of(
    cfg: &Config,
    identified: &Machine,
    truth: &Machine,
    grid: &[Vector3<f64>],
) -> Result<VolumetricMap> {
    volumetric_map(&cfg.nominal(), identified, truth, grid).map_err(|e| {
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
    file: &str,
) -> Result<Vec<[f64; 3]>> {
    check_targets(cfg, targets, file)?;
    targets
        .iter()
        .enumerate()
        .map(|(k, r)| {
            identified
                .commands(r)
                .map_err(|e| Error::csv(file, format!("line {}: {e}", data_line(k))))
        })
        .collect()
}

/// One row of a verification: where the log's passive limb says the tool
/// was, against where the identified model says it should be.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VerifyRow {
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    /// Expected position: the target (compensated commands), or the
    /// identified machine at the nominal commands.
    pub expected_x_mm: f64,
    pub expected_y_mm: f64,
    pub expected_z_mm: f64,
    /// Position measured by the passive limb's readings.
    pub measured_x_mm: f64,
    pub measured_y_mm: f64,
    pub measured_z_mm: f64,
    pub error_mm: f64,
}

/// Check an identified model against a fresh log of the machine. With
/// `nominal_commands` false the log was taken with the commands `compensate`
/// wrote for its targets, so the tool should be at each target; with it
/// true the log was taken with the nominal commands (as a calibration log
/// is), and the identified machine at those commands says where the tool
/// should be. Either way the passive limb's readings say where it was —
/// relative to the reference pose (the first row), where the sensors were
/// homed: the log's readings are taken back to absolute joints by the
/// offset at which the identified model puts the reference, so a constant
/// offset no reading can see (an unidentifiable error) is not measured.
pub fn verify(
    cfg: &Config,
    identified: &Machine,
    readings: &[Reading],
    nominal_commands: bool,
    file: &str,
) -> Result<Vec<VerifyRow>> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    let expected_joints = |k: usize, r: &Reading| -> Result<Joints> {
        if !nominal_commands {
            return crate::model::kinematics::passive_joints(&r.target)
                .map_err(|e| Error::csv(file, format!("line {}: {e}", data_line(k))));
        }
        let bad = |e: crate::error::KinematicsError| {
            Error::csv(file, format!("line {}: {e}", data_line(k)))
        };
        let pose = nominal.inverse(&r.target).map_err(bad)?;
        let q = nominal.commands(&r.target).map_err(bad)?;
        identified.forward(&q, &pose.joints).map_err(|e| {
            Error::csv(
                file,
                format!(
                    "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                    data_line(k)
                ),
            )
        })
    };
    let Some(first) = readings.first() else {
        return Ok(Vec::new());
    };
    let offset = expected_joints(0, first)?.as_vector() - first.joints.as_vector();
    readings
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let expected = if nominal_commands {
                let bad = |e: crate::error::KinematicsError| {
                    Error::csv(file, format!("line {}: {e}", data_line(k)))
                };
                let pose = nominal.inverse(&r.target).map_err(bad)?;
                let q = nominal.commands(&r.target).map_err(bad)?;
                let j = identified.forward(&q, &pose.joints).map_err(|e| {
                    Error::csv(
                        file,
                        format!(
                            "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                            data_line(k)
                        ),
                    )
                })?;
                identified.position(&j)
            } else {
                r.target
            };
            let measured = crate::model::kinematics::platform_position(&Joints::from_vector(
                &(r.joints.as_vector() + offset),
            ));
            Ok(VerifyRow {
                x_mm: r.target.x,
                y_mm: r.target.y,
                z_mm: r.target.z,
                expected_x_mm: expected.x,
                expected_y_mm: expected.y,
                expected_z_mm: expected.z,
                measured_x_mm: measured.x,
                measured_y_mm: measured.y,
                measured_z_mm: measured.z,
                error_mm: (measured - expected).norm(),
            })
        })
        .collect()
}

/// Poses left out in folds: each fold's readings predicted from a fit to
/// the others, against what was read, in units of the prediction's own
/// standard deviation (the readings' covariance and the fit's, by the
/// exact linear propagation: the held-out and fitted rows share the
/// reference reading and, with datasheet sensors, the curves).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct HeldOut {
    pub folds: usize,
    /// Readings predicted (three per held-out pose).
    pub rows: usize,
    /// RMS of the standardised prediction errors: about 1 when the model
    /// predicts poses it was not fitted to as well as the sensors allow.
    pub rms_z: f64,
    pub max_abs_z: f64,
    /// CSV line of the pose with the largest.
    pub worst_line: usize,
    /// Folds skipped because the poses left identified fewer errors.
    pub folds_skipped: usize,
}

/// Folds of the held-out check.
pub const HELD_OUT_FOLDS: usize = 5;

/// The linear operator of `solver` as a matrix (P × rows): its estimate of
/// each unit observation.
fn operator(solver: &LinearSolver) -> nalgebra::DMatrix<f64> {
    let m = solver.rows();
    let mut op = nalgebra::DMatrix::zeros(crate::model::N_PARAMS, m);
    let mut unit = vec![0.0; m];
    let mut out = crate::model::ErrorVector::zeros();
    for j in 0..m {
        unit[j] = 1.0;
        solver.apply(&unit, &mut out);
        op.set_column(j, &out);
        unit[j] = 0.0;
    }
    op
}

/// The held-out check of `cal` with the config's estimator (None without
/// enough poses or a residual).
pub fn held_out(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<HeldOut> {
    // Dense Σ: within the rows a dense covariance is built for.
    crate::identify::check_dense_rows(cal.solver.rows()).ok()?;
    let n = cal.poses.len();
    if n < 2 * HELD_OUT_FOLDS {
        return None;
    }
    let h = cal.solver.design();
    // The observation linearised where the fit ended.
    let y = fit_residual(cfg, cal, readings)? + h * cal.estimate.values;
    let sigma =
        crate::sensors::observation_covariance(&cfg.sensors.covariances(), &cal.poses.joints);
    let method = cfg.identification.method;
    let (mut sum, mut count, mut worst, mut worst_pose, mut skipped) = (0.0, 0, 0.0f64, 0, 0);
    for f in 0..HELD_OUT_FOLDS {
        let held: Vec<usize> = (1..n).filter(|j| j % HELD_OUT_FOLDS == f).collect();
        let kept: Vec<usize> = (1..n).filter(|j| j % HELD_OUT_FOLDS != f).collect();
        let rows_of = |poses: &[usize]| -> Vec<usize> {
            poses
                .iter()
                .flat_map(|&j| (0..3).map(move |k| 3 * (j - 1) + k))
                .collect()
        };
        let (rh, rk) = (rows_of(&held), rows_of(&kept));
        let hk = h.select_rows(&rk);
        let joints: Vec<Joints> = std::iter::once(cal.poses.joints[0])
            .chain(kept.iter().map(|&j| cal.poses.joints[j]))
            .collect();
        let Ok(weighting) = method.weighting(&cfg.sensors, &joints) else {
            skipped += 1;
            continue;
        };
        let solver = LinearSolver::new(&hk, &weighting, cfg.identification.rank_tolerance);
        if solver.analysis.rank < cal.solver.analysis.rank {
            skipped += 1;
            continue;
        }
        let op = operator(&solver);
        let hh = h.select_rows(&rh);
        let yk = nalgebra::DVector::from_iterator(rk.len(), rk.iter().map(|&r| y[r]));
        let pred = &hh * (&op * &yk);
        // A: the prediction error as a linear map of every row of y.
        let m = y.len();
        let mut a = nalgebra::DMatrix::zeros(rh.len(), m);
        let g = -(&hh * &op);
        for (c, &r) in rk.iter().enumerate() {
            a.set_column(r, &g.column(c));
        }
        for (i, &r) in rh.iter().enumerate() {
            a[(i, r)] += 1.0;
        }
        let var = &a * &sigma * a.transpose();
        for (i, &r) in rh.iter().enumerate() {
            let sd = var[(i, i)].max(0.0).sqrt();
            if sd <= 0.0 || sd.is_nan() {
                continue;
            }
            let z = (y[r] - pred[i]) / sd;
            sum += z * z;
            count += 1;
            if z.abs() > worst {
                worst = z.abs();
                worst_pose = r / 3 + 1;
            }
        }
    }
    (count > 0).then(|| HeldOut {
        folds: HELD_OUT_FOLDS,
        rows: count,
        rms_z: (sum / count as f64).sqrt(),
        max_abs_z: worst,
        worst_line: data_line(worst_pose),
        folds_skipped: skipped,
    })
}

/// The accuracy the compensated machine is predicted to reach over the
/// workspace from the estimate's uncertainty alone (first order, the
/// identifiable errors; an unidentifiable error's true value is not in it):
/// for each of `DRAWS` draws of the estimate's error, dV at every grid
/// point; the median and the 2.5–97.5 % range over draws of the largest,
/// the 95th percentile and the mean.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct PredictedAccuracy {
    pub draws: usize,
    pub points: usize,
    /// (median, 2.5 %, 97.5 %) over draws, mm.
    pub max_mm: [f64; 3],
    pub p95_mm: [f64; 3],
    pub mean_mm: [f64; 3],
}

const DRAWS: usize = 1000;

/// [`PredictedAccuracy`] with the estimate's covariance op·Σ·opᵀ scaled by
/// `scale²` (the misfit's, when its test rejects).
pub fn predicted_accuracy(
    cfg: &Config,
    cal: &Calibration,
    scale: f64,
) -> Option<PredictedAccuracy> {
    crate::identify::check_dense_rows(cal.solver.rows()).ok()?;
    use rand::SeedableRng;
    let sigma =
        crate::sensors::observation_covariance(&cfg.sensors.covariances(), &cal.poses.joints);
    let op = operator(&cal.solver);
    let cov = &op * &sigma * op.transpose() * (scale * scale);
    let eig = cov.symmetric_eigen();
    let root = &eig.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let nominal = cfg.nominal();
    let step = cfg.grid_step_mm.max(cfg.workspace.radius_mm / 20.0);
    let s: Vec<crate::model::ErrorJacobian> = workspace_grid(&cfg.workspace, step, cfg.layers)
        .iter()
        .filter_map(|r| nominal.inverse(r).ok())
        .filter_map(|p| crate::model::jacobian::position_sensitivity(&p).ok())
        .collect();
    if s.is_empty() {
        return None;
    }
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let (mut mx, mut p95, mut mean) = (Vec::new(), Vec::new(), Vec::new());
    let mut dv = vec![0.0; s.len()];
    for _ in 0..DRAWS {
        let z = nalgebra::DVector::from_fn(crate::model::N_PARAMS, |_, _| {
            rand::RngExt::sample::<f64, _>(&mut rng, rand_distr::StandardNormal)
        });
        let d = &root * z;
        let delta = crate::model::ErrorVector::from_iterator(d.iter().copied());
        for (v, sk) in dv.iter_mut().zip(&s) {
            *v = (sk * delta).norm();
        }
        mean.push(dv.iter().sum::<f64>() / dv.len() as f64);
        dv.sort_by(f64::total_cmp);
        mx.push(dv[dv.len() - 1]);
        p95.push(crate::metrics::stats::quantile_sorted(&dv, 0.95));
    }
    let band = |v: &mut Vec<f64>| -> [f64; 3] {
        v.sort_by(f64::total_cmp);
        [0.5, 0.025, 0.975].map(|p| crate::metrics::stats::quantile_sorted(v, p))
    };
    Some(PredictedAccuracy {
        draws: DRAWS,
        points: s.len(),
        max_mm: band(&mut mx),
        p95_mm: band(&mut p95),
        mean_mm: band(&mut mean),
    })
}
