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
}

/// Does GLS weight this sensor set's interpolation error by its kernel
/// (some datasheet axis has an interpolation error and an assumed
/// coherence)?
pub(super) fn weighs_interpolation<const R: usize>(s: &SensorModel<R>) -> bool {
    s.structured.is_some_and(|st| {
        st.axes
            .iter()
            .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0 && a.weight_coherence > 0.0)
    })
}

/// The trailing cells of a grade's trials.csv rows (from `,pose_count` on):
/// what tells apart rows of the same grades, estimator and trial.
pub(super) fn grade_cells<const R: usize>(products: Option<&Products<R>>, grade: &Grade) -> String {
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
