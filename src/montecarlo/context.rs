//! What a sweep's trials share, built once per study: the grades (sensor
//! set × estimator × pose count), one prebuilt operator per grade, the
//! calibration poses with their first-order start for forward kinematics,
//! and the workspace grid where accuracy is judged.

use crate::config::{Config, ErrorDraw, Products, Study};
use crate::error::{Error, Result};
use crate::identify::{design_matrix, IdentifyOptions, LinearSolver, Method};
use crate::model::geometry::SecondClass;
use crate::model::jacobian::position_sensitivity;
use crate::model::poses::FirstOrder;
use crate::model::poses::{iso9283_positions, workspace_grid};
use crate::model::{ErrorJacobian, ErrorVector, Geometry, Joints, NominalPoses};
use crate::sensors::{SensorModel, ARCSEC_PER_RAD};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

/// One grade of the study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Grade {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: Method,
    /// Index of the sensor set (grade pair or catalogue pair, scale-major).
    pub sensor_index: usize,
    /// Calibration poses used, the reference included.
    pub pose_count: usize,
    /// Index of that pose subset in [`SweepContext::subsets`].
    pub subset: usize,
}

/// The calibration poses of one pose count: which poses, and which rows of
/// the full observation they give.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSubset {
    pub poses: Vec<usize>,
    /// Rows of l (3 per pose after the reference); all rows when `full`.
    pub rows: Vec<usize>,
    pub full: bool,
}

impl PoseSubset {
    /// `count` of `total` poses by [`spread_poses`].
    pub fn new(total: usize, count: usize) -> Self {
        let poses = spread_poses(total, count);
        let rows = poses[1..]
            .iter()
            .flat_map(|&p| (3 * (p - 1))..(3 * p))
            .collect();
        PoseSubset {
            poses,
            rows,
            full: count == total,
        }
    }
}

/// The poses of a pose-count study (README "Pose count"): the reference
/// (pose 0) and the `count − 1` poses at indices round(k·(total − 1)/(count − 1)),
/// k = 1 … count − 1, spread evenly along the config's pose list (for the
/// default pattern: across layers and rings). Deterministic; `count = total`
/// gives every pose.
pub fn spread_poses(total: usize, count: usize) -> Vec<usize> {
    if count >= total {
        return (0..total).collect();
    }
    let step = (total - 1) as f64 / (count - 1) as f64;
    (0..count)
        .map(|k| (k as f64 * step).round() as usize)
        .collect()
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
    /// One prebuilt operator per grade (OLS shared across sensor grades);
    /// a pose subset's operator maps that subset's rows of l.
    pub solvers: Vec<LinearSolver>,
    /// The pose subsets of `[sweep] pose_counts`, in that order.
    pub subsets: Vec<PoseSubset>,
    /// Catalogue products, when the study compares them.
    pub products: Option<Products>,
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
        let sensors = sensor_sets(cfg, study);
        let tol = study.identification.rank_tolerance;
        let subsets: Vec<PoseSubset> = sw
            .pose_counts
            .iter()
            .map(|&n| PoseSubset::new(poses.len(), n))
            .collect();
        let mut grades = Vec::new();
        let mut solvers: Vec<LinearSolver> = Vec::new();
        let mut split_of = Vec::new();
        for (pi, sub) in subsets.iter().enumerate() {
            let h_sub = DMatrix::from_fn(sub.rows.len(), h.ncols(), |r, c| h[(sub.rows[r], c)]);
            let ols = LinearSolver::new(&h_sub, &DVector::from_element(h_sub.nrows(), 1.0), tol);
            if ols.analysis.rank == 0 {
                return Err(Error::config(
                    &cfg.source,
                    format!("poses: no error can be identified from {} of these poses (the design matrix has rank 0: every pose reads like the reference)", sub.poses.len()),
                ));
            }
            let mut first_ols = None;
            for &method in &sw.methods {
                for (si, s) in sensors.iter().enumerate() {
                    grades.push(Grade {
                        encoder_arcsec: s.encoder_arcsec,
                        scale_um: s.scale_um,
                        method,
                        sensor_index: si,
                        pose_count: sub.poses.len(),
                        subset: pi,
                    });
                    let gi = solvers.len();
                    split_of.push(match method {
                        Method::Ols => *first_ols.get_or_insert(gi),
                        Method::Wls => gi,
                    });
                    solvers.push(match method {
                        Method::Ols => ols.clone(),
                        Method::Wls => {
                            LinearSolver::new(&h_sub, &method.row_weights(h_sub.nrows(), s), tol)
                        }
                    });
                }
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
            subsets,
            products: sw.products.clone(),
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

/// The sensor sets of a study, scale-major: catalogue pairs (their
/// datasheet models), or the grade lists (the grade axis sets a datasheet
/// model's accuracy, SPEC §11; the paper's reading without one).
fn sensor_sets(cfg: &Config, study: &Study) -> Vec<SensorModel> {
    let sw = &study.sweep;
    if let Some(p) = &sw.products {
        return (0..p.models.len())
            .map(|i| {
                let (e, s) = p.pair(i);
                SensorModel {
                    encoder_arcsec: e.grade,
                    scale_um: s.grade,
                    structured: Some(p.models[i]),
                    ..cfg.sensors
                }
            })
            .collect();
    }
    let mut sensors = Vec::new();
    for &s in &sw.scale_um {
        for &e in &sw.encoder_arcsec {
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
    sensors
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
