//! What a sweep's trials share, built once per study: the grades (sensor
//! set × estimator × pose count), one prebuilt operator per grade, the
//! mechanism as the kernel sees it ([`Studied`]: its calibration poses, a
//! trial's machine and its exact readings), and the workspace grid where
//! accuracy is judged. Written for any mechanism of P errors, R readings a
//! pose and A second-class unknowns; the Tricept's study is built in
//! `tricept.rs`.

pub use super::plan::{AxisSharing, KernelPath, NoiseGroup, TrialPlan};
pub use super::studied::{Judging, Studied};
pub use super::subsets::{spread_poses, PoseSubset};
use crate::config::{ErrorDraw, Products, Truth};
use crate::identify::second_class::SecondClassSolver;
use crate::identify::Constraints;
use crate::identify::{IdentifyOptions, Method, Solver};
use crate::sensors::SensorModel;
use nalgebra::{DMatrix, SMatrix, SVector, Vector3};
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

/// Points where a calibration's accuracy is judged, with the first-order
/// position sensitivity S = ∂r/∂ε at the nominal commands (a 3 × P matrix
/// per point, computed once per study).
#[derive(Debug, Clone, Default)]
pub struct MapGrid<const P: usize> {
    pub points: Vec<Vector3<f64>>,
    pub sensitivity: Vec<SMatrix<f64, 3, P>>,
    /// The same sensitivities by blocks of [`BLOCK`] points, one array of
    /// lanes per matrix entry: `blocks[b][a][c][i]` = S[a][c] of point
    /// BLOCK·b + i (zero past the last point). A block's S·e for many e is
    /// then straight vector arithmetic across its points.
    pub blocks: Vec<Block<P>>,
}

/// One block of [`MapGrid::blocks`].
pub type Block<const P: usize> = [[[f64; BLOCK]; P]; 3];

/// Points per block of [`MapGrid::blocks`].
pub const BLOCK: usize = 8;

impl<const P: usize> MapGrid<P> {
    /// The grid of `points` with their sensitivities.
    pub fn new(points: Vec<Vector3<f64>>, sensitivity: Vec<SMatrix<f64, 3, P>>) -> Self {
        let blocks = sensitivity
            .chunks(BLOCK)
            .map(|chunk| {
                let mut b = [[[0.0; BLOCK]; P]; 3];
                for (i, s) in chunk.iter().enumerate() {
                    for (a, row) in b.iter_mut().enumerate() {
                        for (c, lanes) in row.iter_mut().enumerate() {
                            lanes[i] = s[(a, c)];
                        }
                    }
                }
                b
            })
            .collect();
        MapGrid {
            points,
            sensitivity,
            blocks,
        }
    }
}

/// Everything a trial needs, built once and shared read-only: the
/// mechanism `M` as the kernel sees it and what every mechanism's study
/// has. Its fields are the study kernel's own (this folder's); outside it
/// a study is read through [`SweepContext::grades`],
/// [`SweepContext::grade_cells`], [`SweepContext::plan`],
/// [`SweepContext::solvers`], `rows` and `volumetric`.
pub struct SweepContext<M, const P: usize, const R: usize, const A: usize> {
    /// The mechanism: its calibration poses, machines and kinematics.
    pub(super) mech: M,
    pub(super) grades: Vec<Grade>,
    /// The sensor sets that read, truth-amplitude-major over
    /// [`SweepContext::assumed`].
    pub(super) sensors: Vec<SensorModel<R>>,
    /// The datasheet sensor sets the estimators assume.
    pub(super) assumed: Vec<SensorModel<R>>,
    /// Each grade's trailing trials.csv cells (see
    /// [`grade_cells`]), formed once.
    pub(super) grade_cells: Vec<String>,
    /// One prebuilt operator per grade (OLS shared across sensor grades);
    /// a pose subset's operator maps that subset's rows of l.
    pub(super) solvers: Vec<Solver<P, R>>,
    /// The pose subsets of `[sweep] pose_counts`, in that order.
    pub(super) subsets: Vec<PoseSubset>,
    /// Each subset's nominal readings, the reference first.
    pub(super) subset_nominal: Vec<Vec<SVector<f64, R>>>,
    /// Catalogue products, when the study compares them.
    pub(super) products: Option<Products<R>>,
    /// The kernel's path and what its grades and sensor sets share.
    pub(super) plan: TrialPlan<R>,
    pub(super) h: DMatrix<f64>,
    pub(super) options: IdentifyOptions<P>,
    pub(super) draw: ErrorDraw,
    pub(super) fixed_errors: SVector<f64, P>,
    pub(super) bound_mm: f64,
    pub(super) seed: u64,
    /// The sensors whose reading errors are zeroed (the deciding metric's
    /// error budget, see [`super::budget`]).
    pub(super) perfect: [bool; R],
    /// The workspace grid (empty when volumetric is off) and the ISO 9283
    /// positions P1–P5.
    pub(super) grid: MapGrid<P>,
    pub(super) iso: MapGrid<P>,
    /// The workspace's orientation sensitivities (empty: not judged).
    pub(super) orientation: MapGrid<P>,
    /// dV by exact kinematics instead of first-order propagation.
    pub(super) exact: bool,
    /// With `[identification] second_class = true`: each grade's operator
    /// of the A second-class unknowns (empty otherwise).
    pub(super) second_class_solvers: Vec<SecondClassSolver<P, A, R>>,
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

impl<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize> SweepContext<M, P, R, A> {
    /// Errors a calibration estimates: the records' error sums' length.
    pub fn errors(&self) -> usize {
        P
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
    pub fn plan(&self) -> &TrialPlan<R> {
        &self.plan
    }

    /// One prebuilt operator per grade.
    pub fn solvers(&self) -> &[Solver<P, R>] {
        &self.solvers
    }

    /// The calibration poses' count, the reference included.
    pub fn poses(&self) -> usize {
        self.mech.nominal().len()
    }

    /// Rows of l: R per pose after the reference.
    pub fn rows(&self) -> usize {
        self.h.nrows()
    }

    /// Is dV computed per calibration?
    pub fn volumetric(&self) -> bool {
        !self.grid.points.is_empty()
    }

    /// Is the orientation error over the workspace judged per calibration
    /// (targets are poses)?
    pub fn oriented(&self) -> bool {
        !self.orientation.points.is_empty()
    }
}

/// The grades of a study and one operator each (OLS shared across sensor
/// sets; a set's other truths share its datasheet operator), and which
/// grade's split each grade reads.
pub struct GradeTable<const P: usize, const R: usize> {
    pub grades: Vec<Grade>,
    pub solvers: Vec<Solver<P, R>>,
    pub split_of: Vec<usize>,
}

/// What a study's grades are made of: its estimators and truths, the
/// datasheet sensor sets the estimators assume, the design `h` at every
/// calibration pose with their nominal readings, the pose subsets, how
/// it identifies (its held errors and rank tolerance) and its errors'
/// names.
pub struct GradeAxes<'a, const P: usize, const R: usize> {
    pub methods: &'a [Method],
    pub truths: &'a [Truth],
    pub assumed: &'a [SensorModel<R>],
    pub h: &'a DMatrix<f64>,
    pub nominal: &'a [SVector<f64, R>],
    pub subsets: &'a [PoseSubset],
    pub options: &'a IdentifyOptions<P>,
    pub names: &'a [&'a str],
}

impl<const P: usize, const R: usize> GradeTable<P, R> {
    /// Every pose subset × estimator × truth × sensor set, subset-major;
    /// `set_name(i)` names sensor set i in a refusal. A study weights at
    /// the nominal readings, where a machine's errors have moved the
    /// interpolation carrier's phase: its kernel there is worse than white
    /// (the Tricept's catalogue study: 0.1787 → 0.2282 mm), so the study
    /// weights the interpolation error as white.
    pub fn new(
        a: &GradeAxes<'_, P, R>,
        set_name: impl Fn(usize) -> String,
    ) -> Result<Self, String> {
        let tol = a.options.rank_tolerance;
        let held = a.options.constraints;
        let (mut grades, mut solvers, mut split_of) = (Vec::new(), Vec::new(), Vec::new());
        for (pi, sub) in a.subsets.iter().enumerate() {
            let h_sub = rows_of(a.h, &sub.rows);
            let nominal: Vec<SVector<f64, R>> = sub.poses.iter().map(|&p| a.nominal[p]).collect();
            // OLS's operator (and the subset's rank): no prior, which needs GLS.
            let free = Constraints {
                prior_std_mm: None,
                ..held
            };
            let ols: Solver<P, R> = Method::Ols
                .solver((&a.assumed[0], &nominal), &h_sub, tol, (&free, a.names))
                .map_err(|why| format!("sweep.methods: {why}"))?;
            if ols.analysis.rank == 0 {
                return Err(format!("poses: no error can be identified from {} of these poses (the design matrix has rank 0: every pose reads like the reference)", sub.poses.len()));
            }
            let mut first_ols = None;
            for &method in a.methods {
                // The grade of the datasheet itself per set: the other truth
                // amplitudes share its operator.
                let mut own = vec![usize::MAX; a.assumed.len()];
                for (ti, &truth) in a.truths.iter().enumerate() {
                    for (si, s) in a.assumed.iter().enumerate() {
                        grades.push(Grade {
                            encoder_arcsec: s.encoder_arcsec,
                            scale_um: s.scale_um,
                            method,
                            sensor_index: ti * a.assumed.len() + si,
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
                        let solver = method
                            .solver(
                                (&s.white_interpolation(), &nominal),
                                &h_sub,
                                tol,
                                (&held, a.names),
                            )
                            .map_err(|why| format!("sweep.methods: {why} ({})", set_name(si)))?;
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
}

/// The rows `rows` of `m`.
fn rows_of(m: &DMatrix<f64>, rows: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), m.ncols(), |r, c| m[(rows[r], c)])
}

/// A study of mechanism `mech` before the kernel's own tables: its design
/// at every calibration pose (`h`; with second-class unknowns identified,
/// theirs, `h_second`, A columns), its pose subsets and grades, its
/// sensor sets (the datasheet's, `assumed`, and those that read), and the
/// study's settings.
pub struct Parts<M, const P: usize, const R: usize> {
    pub mech: M,
    pub h: DMatrix<f64>,
    pub h_second: Option<DMatrix<f64>>,
    pub subsets: Vec<PoseSubset>,
    pub table: GradeTable<P, R>,
    pub assumed: Vec<SensorModel<R>>,
    pub sensors: Vec<SensorModel<R>>,
    pub products: Option<Products<R>>,
    pub options: IdentifyOptions<P>,
    /// `[sweep] gls_per_machine`: None weights GLS per machine where its
    /// sensors' interpolation error has a coherence to weight by.
    pub gls_per_machine: Option<bool>,
    pub draw: ErrorDraw,
    pub fixed_errors: SVector<f64, P>,
    pub bound_mm: f64,
    pub seed: u64,
    pub perfect: [bool; R],
    /// The workspace grid and the ISO 9283 positions (empty: not judged).
    pub grids: (MapGrid<P>, MapGrid<P>),
    /// The workspace's orientation sensitivities (∂ rotation vector/∂
    /// error, rad, one 3 × P matrix a target), always first order; empty
    /// where the mechanism's targets are points.
    pub orientation: MapGrid<P>,
    pub exact: bool,
}

impl<M, const P: usize, const R: usize> Parts<M, P, R> {
    /// What the study asks of itself, before the kernel's tables: GLS
    /// weighted per machine is one linearisation (no Gauss–Newton, no
    /// second-class unknowns); second-class unknowns need their design
    /// and a mechanism that has some; and the parts agree in size (R rows
    /// a pose after the reference, P columns; each subset's rows its
    /// poses'; each grade's sets, operator and subset there).
    fn check<const A: usize>(&self) -> Result<(), String>
    where
        M: Studied<P, R, A>,
    {
        let o = &self.options;
        if self.gls_per_machine == Some(true) && (o.second_class || o.iterations > 1) {
            return Err(format!("sweep.gls_per_machine does not combine with [identification] second_class = true or iterations > 1 yet: the operator per machine is one linearisation of the {P} errors; remove one of the two"));
        }
        if o.second_class && (A == 0 || self.h_second.is_none()) {
            return Err(format!(
                "identification.second_class: the {} has no second-class unknowns to identify",
                if A == 0 { "mechanism" } else { "study" }
            ));
        }
        let poses = self.mech.nominal().len();
        let rows = R * poses.saturating_sub(1);
        let bad = |what: String| Err(format!("a study's parts disagree: {what}"));
        if self.h.nrows() != rows || self.h.ncols() != P {
            return bad(format!(
                "the design is {} × {}, {poses} poses of {R} readings and {P} errors need {rows} × {P}",
                self.h.nrows(),
                self.h.ncols()
            ));
        }
        if let Some(h3) = &self.h_second {
            if h3.nrows() != rows || h3.ncols() != A {
                return bad(format!(
                    "the second-class design is {} × {}, not {rows} × {A}",
                    h3.nrows(),
                    h3.ncols()
                ));
            }
        }
        for (i, s) in self.subsets.iter().enumerate() {
            let n = s.poses.len();
            if s.poses.iter().any(|&p| p >= poses)
                || s.rows.len() != R * n.saturating_sub(1)
                || s.rows.iter().any(|&r| r >= rows)
            {
                return bad(format!(
                    "pose subset {i} is not {n} of the {poses} poses, {R} rows each"
                ));
            }
        }
        let t = &self.table;
        if t.solvers.len() != t.grades.len() || t.split_of.len() != t.grades.len() {
            return bad("each grade needs one operator and one split".into());
        }
        if let Some(gi) = t.grades.iter().position(|g| {
            g.sensor_index >= self.sensors.len()
                || g.product >= self.assumed.len()
                || g.subset >= self.subsets.len()
        }) {
            return bad(format!(
                "grade {gi} names a sensor set or pose subset the study lacks"
            ));
        }
        Ok(())
    }
}

impl<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize> SweepContext<M, P, R, A> {
    /// The study of `parts`: which grades are weighted per machine and
    /// which record their linearisation, the kernel's plan, each subset's
    /// rows and nominal readings, the grades' trailing cells, and each
    /// grade's operator of the second-class unknowns when they are
    /// identified. Err: a sentence, the key it names first.
    pub fn assemble(parts: Parts<M, P, R>) -> Result<Self, String> {
        parts.check()?;
        let Parts { table, options, .. } = &parts;
        let per_machine: Vec<bool> = table
            .grades
            .iter()
            .map(|g| {
                parts.gls_per_machine != Some(false)
                    && g.method == Method::Gls
                    && !options.second_class
                    && options.iterations <= 1
                    && weighs_interpolation(&parts.assumed[g.product])
            })
            .collect();
        let recorded: Vec<usize> = (0..table.grades.len())
            .filter(|&gi| per_machine[gi] && table.grades[gi].truth.is_datasheet())
            .collect();
        let sensor_of: Vec<usize> = table.grades.iter().map(|g| g.sensor_index).collect();
        let plan = TrialPlan::new(
            &sensor_of,
            &parts.sensors,
            table.split_of.clone(),
            options.iterations > 1 || options.second_class || per_machine.iter().any(|&p| p),
        );
        let subset_h = parts
            .subsets
            .iter()
            .map(|s| rows_of(&parts.h, &s.rows))
            .collect();
        let nominal = parts.mech.nominal();
        let subset_nominal = parts
            .subsets
            .iter()
            .map(|s| s.poses.iter().map(|&p| nominal[p]).collect())
            .collect();
        let grade_cells = table
            .grades
            .iter()
            .map(|g| grade_cells(parts.products.as_ref(), g))
            .collect();
        let second_class_solvers = match (&parts.h_second, options.second_class) {
            (Some(h3), true) => table
                .grades
                .iter()
                .zip(&table.solvers)
                .map(|(g, solver)| {
                    let rows = rows_of(h3, &parts.subsets[g.subset].rows);
                    SecondClassSolver::named(
                        solver,
                        &rows,
                        options.rank_tolerance,
                        parts.mech.unknown_names(),
                    )
                    .map_err(|why| format!("identification.second_class: {why}"))
                })
                .collect::<Result<Vec<_>, String>>()?,
            _ => Vec::new(),
        };
        let Parts {
            mech,
            h,
            subsets,
            table,
            assumed,
            sensors,
            products,
            options,
            draw,
            fixed_errors,
            bound_mm,
            seed,
            perfect,
            grids: (grid, iso),
            orientation,
            exact,
            ..
        } = parts;
        Ok(SweepContext {
            mech,
            grades: table.grades,
            sensors,
            assumed,
            grade_cells,
            solvers: table.solvers,
            subsets,
            subset_nominal,
            products,
            plan,
            h,
            options,
            draw,
            fixed_errors,
            bound_mm,
            seed,
            perfect,
            grid,
            iso,
            orientation,
            exact,
            second_class_solvers,
            per_machine,
            recorded,
            subset_h,
        })
    }
}

/// Does GLS weight this sensor set's interpolation error by its kernel
/// (some datasheet axis has an interpolation error and an assumed
/// coherence)?
fn weighs_interpolation<const R: usize>(s: &SensorModel<R>) -> bool {
    s.structured.is_some_and(|st| {
        st.axes
            .iter()
            .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0 && a.weight_coherence > 0.0)
    })
}

/// The trailing cells of a grade's trials.csv rows (from `,pose_count` on):
/// what tells apart rows of the same grades, estimator and trial.
fn grade_cells<const R: usize>(products: Option<&Products<R>>, grade: &Grade) -> String {
    let (encoder, scale) = match products {
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

#[cfg(test)]
#[path = "context_tests.rs"]
mod tests;
