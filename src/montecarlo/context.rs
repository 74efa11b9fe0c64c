//! What a sweep's trials share, built once per study: the grades (sensor
//! set × estimator × pose count), one prebuilt operator per grade, the
//! calibration poses with their first-order start for forward kinematics,
//! and the workspace grid where accuracy is judged.

pub use super::plan::{AxisSharing, KernelPath, NoiseGroup, TrialPlan};
pub use super::subsets::{spread_poses, PoseSubset};
use crate::config::{Config, ErrorDraw, Products, Study};
use crate::config::{SweepConfig, Truth};
use crate::error::{Error, Result};
use crate::identify::tricept::{angle_design, AxesSolver};
use crate::identify::tricept::{design_matrix, LinearSolver};
use crate::identify::{IdentifyOptions, Method};
use crate::mechanism::tricept::geometry::SecondClass;
use crate::mechanism::tricept::jacobian::position_sensitivity;
use crate::mechanism::tricept::poses::FirstOrder;
use crate::mechanism::tricept::second_class::Angles;
use crate::mechanism::tricept::{
    ErrorJacobian, ErrorVector, Geometry, Joints, NominalPoses, N_LEGS, N_PARAMS, N_READINGS,
    PARAM_NAMES,
};
use crate::mechanism::workspace::{iso9283_positions, workspace_grid};
use crate::sensors::{SensorModel, ARCSEC_PER_RAD};
use nalgebra::{DMatrix, Vector3};
use serde::Serialize;

/// One grade of the study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Grade {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: Method,
    /// Index of the sensor set that reads (in [`SweepContext::sensors`]).
    pub sensor_index: usize,
    /// Index of the datasheet's sensor set, the one the estimator assumes
    /// (grade pair or catalogue pair, scale-major; in
    /// [`SweepContext::assumed`]).
    pub product: usize,
    /// How the reading sensors differ from the datasheet's.
    pub truth: Truth,
    /// Calibration poses used, the reference included.
    pub pose_count: usize,
    /// Index of that pose subset in [`SweepContext::subsets`].
    pub subset: usize,
}

/// Points where a calibration's accuracy is judged, with their nominal
/// solutions and the first-order position sensitivity S = ∂r/∂ε at the
/// nominal commands (a 3 × N_PARAMS matrix per point, computed once per study).
#[derive(Debug, Clone, Default)]
pub struct MapGrid {
    pub points: Vec<Vector3<f64>>,
    pub nominal: Vec<Joints>,
    pub commands: Vec<[f64; N_LEGS]>,
    pub sensitivity: Vec<ErrorJacobian>,
    /// The same sensitivities by blocks of [`BLOCK`] points, one array of
    /// lanes per matrix entry: `blocks[b][N·a + c][i]` = S[a][c] of point
    /// BLOCK·b + i (zero past the last point). A block's S·e for many e is
    /// then straight vector arithmetic across its points.
    pub blocks: Vec<[[f64; BLOCK]; 3 * N_PARAMS]>,
}

/// Points per block of [`MapGrid::blocks`].
pub const BLOCK: usize = 8;

impl MapGrid {
    /// Fill [`MapGrid::blocks`] from the sensitivities.
    fn block(&mut self) {
        self.blocks = self
            .sensitivity
            .chunks(BLOCK)
            .map(|chunk| {
                let mut b = [[0.0; BLOCK]; 3 * N_PARAMS];
                for (i, s) in chunk.iter().enumerate() {
                    for a in 0..3 {
                        for c in 0..N_PARAMS {
                            b[N_PARAMS * a + c][i] = s[(a, c)];
                        }
                    }
                }
                b
            })
            .collect();
    }
}

/// Everything a trial needs, built once and shared read-only. Its fields
/// are the study kernel's own (this module's); outside it a study is read
/// through [`SweepContext::grades`], [`SweepContext::grade_cells`],
/// [`SweepContext::plan`], [`SweepContext::solvers`], `rows` and
/// `volumetric`.
pub struct SweepContext {
    pub(super) geometry: Geometry,
    pub(super) poses: NominalPoses,
    pub(super) grades: Vec<Grade>,
    /// The sensor sets that read, truth-amplitude-major over
    /// [`SweepContext::assumed`].
    pub(super) sensors: Vec<SensorModel<N_READINGS>>,
    /// The datasheet sensor sets the estimators assume.
    pub(super) assumed: Vec<SensorModel<N_READINGS>>,
    /// Each grade's trailing trials.csv cells (see
    /// [`grade_cells`]), formed once.
    pub(super) grade_cells: Vec<String>,
    /// One prebuilt operator per grade (OLS shared across sensor grades);
    /// a pose subset's operator maps that subset's rows of l.
    pub(super) solvers: Vec<LinearSolver>,
    /// The pose subsets of `[sweep] pose_counts`, in that order.
    pub(super) subsets: Vec<PoseSubset>,
    /// Each subset's nominal poses (what Gauss–Newton re-linearises at).
    pub(super) subset_poses: Vec<NominalPoses>,
    /// Catalogue products, when the study compares them.
    pub(super) products: Option<Products<N_READINGS>>,
    /// The kernel's path and what its grades and sensor sets share.
    pub(super) plan: TrialPlan<N_READINGS>,
    /// Forward kinematics of a trial's machine starts from the first-order
    /// prediction nominal + J·ε at each calibration pose.
    pub(super) first_order: FirstOrder,
    pub(super) h: DMatrix<f64>,
    pub(super) options: IdentifyOptions<N_PARAMS>,
    pub(super) draw: ErrorDraw,
    pub(super) fixed_errors: ErrorVector,
    pub(super) bound_mm: f64,
    pub(super) seed: u64,
    /// Second-class errors every simulated machine carries.
    pub(super) second_class: Option<SecondClass>,
    /// Or: each machine draws its four second-class angles uniformly within
    /// ± this, degrees (stream 2; a tolerance what-if study).
    pub(super) second_class_draw_deg: Option<f64>,
    /// The sensors whose reading errors are zeroed (the deciding metric's
    /// error budget, see [`super::budget`]).
    pub(super) perfect: [bool; 3],
    /// The workspace grid (empty when volumetric is off) and the ISO 9283
    /// positions P1–P5.
    pub(super) grid: MapGrid,
    pub(super) iso: MapGrid,
    /// dV by exact kinematics instead of first-order propagation.
    pub(super) exact: bool,
    /// With `[identification] second_class = true`: each grade's operator
    /// of the Hooke axes' three angles (empty otherwise).
    pub(super) second_class_solvers: Vec<AxesSolver>,
    /// Per grade: is its operator built per machine, at that machine's
    /// readings (`[sweep] gls_per_machine`: GLS whose datasheet sensors
    /// have an interpolation error weighted by its kernel)?
    pub(super) per_machine: Vec<bool>,
    /// The grades whose trials record their linearisation error (weighted
    /// per machine, datasheet truth: what parameters.csv states), in grade
    /// order; a block holds one error vector per trial for each.
    pub recorded: Vec<usize>,
    /// Each pose subset's rows of the design matrix (what a per-machine
    /// operator is built from).
    pub(super) subset_h: Vec<DMatrix<f64>>,
}

impl SweepContext {
    /// Errors a calibration estimates: the records' error sums' length.
    pub fn errors(&self) -> usize {
        N_PARAMS
    }

    /// The study's grades (calibrations per trial), in trials.csv's order.
    pub fn grades(&self) -> &[Grade] {
        &self.grades
    }

    /// Each grade's trailing trials.csv cells.
    pub fn grade_cells(&self) -> &[String] {
        &self.grade_cells
    }

    /// The kernel's path and its tables of sharing.
    pub fn plan(&self) -> &TrialPlan<N_READINGS> {
        &self.plan
    }

    /// One prebuilt operator per grade.
    pub fn solvers(&self) -> &[LinearSolver] {
        &self.solvers
    }

    /// Grades, solvers and the map of a study of `cfg`'s machine: the
    /// poses, the sensor sets, the grade table, the judging grids, each
    /// built by a function of its own below.
    pub fn new(cfg: &Config, study: &Study) -> Result<Self> {
        let nominal = cfg.nominal();
        let poses = NominalPoses::new(&nominal, &study.poses)
            .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
        let h = design_matrix(&nominal, &poses)
            .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
        let sw = &study.sweep;
        if sw.gls_per_machine == Some(true)
            && (study.identification.second_class || study.identification.iterations > 1)
        {
            return Err(Error::config(
                &cfg.source,
                "sweep.gls_per_machine does not combine with [identification] second_class = true or iterations > 1 yet: the operator per machine is one linearisation of the 15 errors; remove one of the two",
            ));
        }
        let (assumed, sensors) = reading_sets(cfg, study);
        let subsets: Vec<PoseSubset> = sw
            .pose_counts
            .iter()
            .map(|&n| PoseSubset::new(poses.len(), n, N_READINGS))
            .collect();
        let table = grade_table(cfg, study, &poses, &h, &assumed, &subsets)?;
        check_fixed_machine(cfg, study, &poses)?;
        let (grid, iso) = judging_grids(cfg, study)?;
        let first_order = FirstOrder::new(&nominal, &poses)
            .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
        let sensor_of: Vec<usize> = table.grades.iter().map(|g| g.sensor_index).collect();
        let per_machine: Vec<bool> = table
            .grades
            .iter()
            .map(|g| {
                sw.gls_per_machine != Some(false)
                    && g.method == Method::Gls
                    && !study.identification.second_class
                    && study.identification.iterations <= 1
                    && weighs_interpolation(&assumed[g.product])
            })
            .collect();
        let recorded: Vec<usize> = (0..table.grades.len())
            .filter(|&gi| per_machine[gi] && table.grades[gi].truth.is_datasheet())
            .collect();
        let plan = TrialPlan::new(
            &sensor_of,
            &sensors,
            table.split_of,
            study.identification.iterations > 1
                || study.identification.second_class
                || per_machine.iter().any(|&p| p),
        );
        let subset_h = subsets
            .iter()
            .map(|sub| DMatrix::from_fn(sub.rows.len(), h.ncols(), |r, c| h[(sub.rows[r], c)]))
            .collect();
        let subset_poses = subsets.iter().map(|s| poses.pick(&s.poses)).collect();
        let mut ctx = SweepContext {
            grade_cells: Vec::new(),
            assumed,
            subset_poses,
            subsets,
            products: sw.products.clone(),
            plan,
            first_order,
            second_class: cfg.second_class,
            second_class_draw_deg: sw.second_class_draw_deg,
            perfect: sw.perfect_sensors,
            grid,
            iso,
            exact: sw.volumetric_exact,
            second_class_solvers: Vec::new(),
            per_machine,
            recorded,
            subset_h,
            geometry: cfg.geometry,
            poses,
            grades: table.grades,
            sensors,
            solvers: table.solvers,
            h,
            options: study.identification,
            draw: sw.errors,
            fixed_errors: cfg.errors,
            bound_mm: sw.error_bound_mm,
            seed: sw.seed,
        };
        ctx.grade_cells = ctx.grades.iter().map(|g| grade_cells(&ctx, g)).collect();
        if study.identification.second_class {
            ctx.second_class_solvers = angle_solvers(cfg, &ctx)?;
        }
        Ok(ctx)
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

/// Does GLS weight this sensor set's interpolation error by its kernel
/// (some datasheet axis has an interpolation error and an assumed
/// coherence)?
fn weighs_interpolation(s: &SensorModel<N_READINGS>) -> bool {
    s.structured.is_some_and(|st| {
        st.axes
            .iter()
            .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0 && a.weight_coherence > 0.0)
    })
}

/// Each grade's operator of the Hooke axes' angles, from its own operator
/// and its pose subset's rows of the angles' design at the nominal machine.
fn angle_solvers(cfg: &Config, ctx: &SweepContext) -> Result<Vec<AxesSolver>> {
    let fail =
        |why: String| Error::config(&cfg.source, format!("identification.second_class: {why}"));
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &ctx.poses.joints)
        .map_err(|e| fail(format!("poses: {e}")))?;
    let subsets: Vec<DMatrix<f64>> = ctx
        .subsets
        .iter()
        .map(|sub| DMatrix::from_fn(sub.rows.len(), h3.ncols(), |r, c| h3[(sub.rows[r], c)]))
        .collect();
    ctx.grades
        .iter()
        .zip(&ctx.solvers)
        .map(|(g, solver)| {
            AxesSolver::new(solver, &subsets[g.subset], ctx.options.rank_tolerance).map_err(fail)
        })
        .collect()
}

/// The sensor sets of a study: the datasheet's, which the estimators
/// assume, and the ones that read — each datasheet set with its curves as
/// each truth of `[sweep]` has them (the first is the datasheet itself).
fn reading_sets(
    cfg: &Config,
    study: &Study,
) -> (Vec<SensorModel<N_READINGS>>, Vec<SensorModel<N_READINGS>>) {
    let assumed = assumed_sets(cfg, study);
    let sensors: Vec<SensorModel<N_READINGS>> = study
        .sweep
        .truth
        .iter()
        .flat_map(|t| {
            assumed
                .iter()
                .map(move |s| match (t.is_datasheet(), &s.structured) {
                    (false, Some(st)) => SensorModel {
                        structured: Some(t.apply(st)),
                        ..*s
                    },
                    _ => *s,
                })
        })
        .collect();
    (assumed, sensors)
}

/// The grades of a study and one operator each (OLS shared across sensor
/// grades; a set's other truths share its datasheet operator), and which
/// grade's split each grade reads.
struct GradeTable {
    grades: Vec<Grade>,
    solvers: Vec<LinearSolver>,
    split_of: Vec<usize>,
}

fn grade_table(
    cfg: &Config,
    study: &Study,
    poses: &NominalPoses,
    h: &DMatrix<f64>,
    assumed: &[SensorModel<N_READINGS>],
    subsets: &[PoseSubset],
) -> Result<GradeTable> {
    let sw = &study.sweep;
    let tol = study.identification.rank_tolerance;
    let held = study.identification.constraints;
    let mut grades = Vec::new();
    let mut solvers: Vec<LinearSolver> = Vec::new();
    let mut split_of = Vec::new();
    for (pi, sub) in subsets.iter().enumerate() {
        let h_sub = DMatrix::from_fn(sub.rows.len(), h.ncols(), |r, c| h[(sub.rows[r], c)]);
        let joints: Vec<Joints> = sub.poses.iter().map(|&p| poses.joints[p]).collect();
        // OLS's operator (and the subset's rank): no prior, which needs GLS.
        let free = crate::identify::Constraints {
            prior_std_mm: None,
            ..held
        };
        let ols = Method::Ols
            .solver((&cfg.sensors, &joints), &h_sub, tol, (&free, &PARAM_NAMES))
            .map_err(|why| Error::config(&cfg.source, format!("sweep.methods: {why}")))?;
        if ols.analysis.rank == 0 {
            return Err(Error::config(
                &cfg.source,
                format!("poses: no error can be identified from {} of these poses (the design matrix has rank 0: every pose reads like the reference)", sub.poses.len()),
            ));
        }
        let mut first_ols = None;
        for &method in &sw.methods {
            // The grade of the datasheet itself per set: the other truth
            // amplitudes share its operator.
            let mut own = vec![usize::MAX; assumed.len()];
            for (ti, &truth) in sw.truth.iter().enumerate() {
                for (si, s) in assumed.iter().enumerate() {
                    grades.push(Grade {
                        encoder_arcsec: s.encoder_arcsec,
                        scale_um: s.scale_um,
                        method,
                        sensor_index: ti * assumed.len() + si,
                        product: si,
                        truth,
                        pose_count: sub.poses.len(),
                        subset: pi,
                    });
                    let gi = solvers.len();
                    if !method.reads_sensors() {
                        split_of.push(*first_ols.get_or_insert(gi));
                        solvers.push(ols.clone());
                        continue;
                    }
                    if own[si] != usize::MAX {
                        split_of.push(own[si]);
                        solvers.push(solvers[own[si]].clone());
                        continue;
                    }
                    own[si] = gi;
                    split_of.push(gi);
                    // A study weights at the nominal readings, where a
                    // machine's errors have moved the interpolation carrier's
                    // phase: its kernel there is worse than white (the
                    // catalogue study's choice: 0.1787 → 0.2282 mm), so the
                    // study weights the interpolation error as white.
                    let solver = method
                        .solver(
                            (&s.white_interpolation(), &joints),
                            &h_sub,
                            tol,
                            (&held, &PARAM_NAMES),
                        )
                        .map_err(|why| {
                            Error::config(
                                &cfg.source,
                                format!("sweep.methods: {why} ({})", sensor_set_name(sw, si)),
                            )
                        })?;
                    solvers.push(solver);
                }
            }
        }
    }
    Ok(GradeTable {
        grades,
        solvers,
        split_of,
    })
}

/// A study of the config's fixed machine: it must reach every calibration
/// pose.
fn check_fixed_machine(cfg: &Config, study: &Study, poses: &NominalPoses) -> Result<()> {
    if study.sweep.errors != ErrorDraw::Fixed {
        return Ok(());
    }
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
    })
}

/// Where calibrations are judged: the workspace grid and the ISO 9283
/// positions (empty without `volumetric`).
fn judging_grids(cfg: &Config, study: &Study) -> Result<(MapGrid, MapGrid)> {
    Ok(match study.sweep.volumetric_step_mm {
        Some(step) => {
            let ws = &cfg.workspace;
            let points = workspace_grid(ws, step, cfg.layers);
            let iso = iso9283_positions(ws).to_vec();
            (
                map_grid(cfg, points, "workspace (its volumetric grid)")?,
                map_grid(cfg, iso, "workspace (ISO 9283 positions)")?,
            )
        }
        None => (MapGrid::default(), MapGrid::default()),
    })
}

/// The sensor sets of a study, scale-major: catalogue pairs (their
/// datasheet models), or the grade lists (the grade axis sets a datasheet
/// model's accuracy, docs/method.md §11; the paper's reading without one).
pub(crate) fn assumed_sets(cfg: &Config, study: &Study) -> Vec<SensorModel<N_READINGS>> {
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

/// The sensor set `i` as a config names it: its catalogue pair, or its grades.
fn sensor_set_name(sw: &SweepConfig, i: usize) -> String {
    match &sw.products {
        Some(p) => {
            let (e, s) = p.pair(i);
            format!("encoder \"{}\" with scale \"{}\"", e.name, s.name)
        }
        None => {
            let (ne, _) = (sw.encoder_arcsec.len(), sw.scale_um.len());
            format!(
                "encoder grade {} arcsec with scale grade {} µm",
                sw.encoder_arcsec[i % ne],
                sw.scale_um[i / ne]
            )
        }
    }
}

/// The trailing cells of a grade's trials.csv rows (from `,pose_count` on):
/// what tells apart rows of the same grades, estimator and trial.
fn grade_cells(ctx: &SweepContext, grade: &Grade) -> String {
    let (encoder, scale) = match &ctx.products {
        Some(p) => {
            let (e, s) = p.pair(grade.product);
            (csv_text(&e.name), csv_text(&s.name))
        }
        None => (String::new(), String::new()),
    };
    format!(
        ",{},{encoder},{scale},{},{},{}",
        grade.pose_count,
        grade.truth.amplitude,
        grade.truth.extra_harmonic,
        csv_text(&grade.truth.label())
    )
}

/// A text cell: quoted (quotes doubled) when it holds a comma, a quote or a
/// line break.
fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
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
        // The first-order path would give a number where exact kinematics
        // cannot: every point is checked as the calibration poses are.
        crate::mechanism::tricept::check_pose(&nominal, r, cfg.max_tilt_deg).map_err(|why| {
            Error::config(
                &cfg.source,
                format!(
                    "{key}: the point ({:.1}, {:.1}, {:.1}) mm is not reachable by the nominal machine: {why}; shrink [workspace] (radius, height, top) or relax geometry.max_tilt_deg",
                    r.x, r.y, r.z
                ),
            )
        })?;
        let pose = nominal.inverse(r).map_err(fail)?;
        grid.sensitivity
            .push(position_sensitivity(&pose).map_err(fail)?);
        grid.nominal.push(pose.joints);
        grid.commands.push(pose.legs_mm);
    }
    grid.block();
    Ok(grid)
}

#[cfg(test)]
#[path = "context_tests.rs"]
mod tests;
