//! One self-calibration from a validated [`Config`], end to end: simulated
//! readings of the config's machine, identification from readings (real or
//! simulated), the volumetric map before and after compensation, and the
//! compensated commands for targets. `simulate`, `identify`, `compensate`
//! and `reproduce` all go through here; errors name the file and line.

use crate::compensate::{volumetric_map, VolumetricMap};
use crate::config::{check_reachable, Config};
use crate::error::{Error, Result};
use crate::identify::{design_matrix, identify, Estimate, IdentifyOptions, LinearSolver};
use crate::io::data_line;
use crate::model::poses::midplane_grid;
use crate::model::{Machine, NominalPoses};
use crate::montecarlo::simulate_stream;
use crate::sensors::{observation_vector, simulate_readings, Reading};
use nalgebra::Vector3;

/// Readings of the config's true machine at `poses`, noise drawn from the
/// stream of `seed` (none when `noise_free`).
pub fn simulate(
    cfg: &Config,
    poses: &NominalPoses,
    seed: u64,
    noise_free: bool,
) -> Result<Vec<Reading>> {
    let mut rng = simulate_stream(seed);
    let sensors = if noise_free { None } else { Some(&cfg.sensors) };
    simulate_readings(poses, &cfg.truth(), sensors, &mut rng).map_err(|e| {
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
        check_reachable(&nominal, r, cfg.max_tilt_deg).map_err(|why| {
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
    let at_line = |e: crate::error::PoseError| {
        Error::csv(file, format!("line {}: {}", data_line(e.index), e.source))
    };
    let poses = NominalPoses::new(&nominal, &targets).map_err(at_line)?;
    let h = design_matrix(&nominal, &poses).map_err(at_line)?;
    let w = options.method.row_weights(h.nrows(), &cfg.sensors);
    let solver = LinearSolver::new(&h, &w, options.rank_tolerance);
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

/// dV over the config's map plane of its true machine, commanded by the
/// nominal and by the `identified` model.
pub fn map(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = midplane_grid(&cfg.workspace, cfg.grid_step_mm, cfg.plane_z_mm);
    volumetric_map(&cfg.nominal(), identified, &cfg.truth(), &grid).map_err(|e| {
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
