//! What the study kernel asks of a mechanism with P errors, R readings a
//! pose and A second-class unknowns identified beside the errors: the
//! nominal readings of its calibration poses, a trial's true machine and
//! its exact readings there, Gauss–Newton on a pose subset, and the exact
//! position error over the judging grids. Everything else a study does
//! (grades, operators, sensors, noise, the first-order workspace judgement,
//! statements and summaries) is written once, in this folder, for any
//! mechanism that implements it, but for the error budget, whose columns
//! are the Tricept's three sensors (a mechanism of other readings states
//! none); the Tricept's implementation is `tricept.rs`, any `Kinematic`
//! topology's `kinematic.rs`.

use crate::config::Study;
use crate::error::PoseError;
use crate::identify::{IdentifyOptions, Solver};
use nalgebra::{DVector, SVector};

/// Where a calibration is judged by exact kinematics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Judging {
    /// The workspace grid (`[sweep] volumetric_step_mm`).
    Grid,
    /// The ISO 9283 positions P1–P5.
    Iso,
}

/// A mechanism as the study kernel sees it, built once per study and
/// shared read-only by every trial.
pub trait Studied<const P: usize, const R: usize, const A: usize>: Sync + Sized {
    /// A trial's true machine: its P errors with whatever else it carries.
    type Machine;
    /// One worker's buffers for forward kinematics, reused across trials.
    type Buffers: Send;

    /// The errors' names, in order (P of them).
    fn names(&self) -> &[&str];

    /// The second-class unknowns' names, in order (A of them).
    fn unknown_names(&self) -> &'static [&'static str];

    /// The calibration poses' nominal readings, the reference first (model
    /// units: rad and mm).
    fn nominal(&self) -> &[SVector<f64, R>];

    /// A worker's buffers.
    fn buffers(&self) -> Self::Buffers;

    /// Trial k's errors where the mechanism draws its machines itself
    /// (from stream (seed, k, 0)); None, the default: the study's own
    /// draw, each error uniform in its bound.
    fn draw(&self, _seed: u64, _k: u64) -> Option<SVector<f64, P>> {
        None
    }

    /// Trial k's true machine, with errors `e` (what else it carries, such
    /// as second-class errors, drawn from trial k's own streams).
    fn machine(&self, e: &SVector<f64, P>, k: u64) -> Self::Machine;

    /// The exact readings `machine` (errors `e`) gives at every
    /// calibration pose, into `out`; the first pose that has none, else.
    fn actual(
        &self,
        machine: &Self::Machine,
        e: &SVector<f64, P>,
        buf: &mut Self::Buffers,
        out: &mut [SVector<f64, R>],
    ) -> Result<(), PoseError>;

    /// Gauss–Newton on pose subset `subset` (in `[sweep] pose_counts`
    /// order) from its operator `solver` and observation `l`: the estimate
    /// and whether it converged; None where it fails.
    fn iterate(
        &self,
        subset: usize,
        solver: &Solver<P, R>,
        l: &DVector<f64>,
        options: &IdentifyOptions<P>,
    ) -> Option<(SVector<f64, P>, bool)>;

    /// The machine a calibration commands with: identified errors `est`,
    /// and the A second-class unknowns `angles` (zero when not identified).
    fn identified(&self, est: &SVector<f64, P>, angles: &SVector<f64, A>) -> Self::Machine;

    /// The position error (mm), by exact kinematics, of `truth` at point
    /// `i` of `at` commanded by the machine `by` (None: the nominal
    /// machine's commands); None where kinematics fails.
    fn exact_dv(
        &self,
        truth: &Self::Machine,
        by: Option<&Self::Machine>,
        at: Judging,
        i: usize,
    ) -> Option<f64>;

    /// What a study's verdict rests on of the mechanism, one sentence
    /// each: the errors its machines draw and what else they carry.
    fn assumptions(&self, study: &Study<P, R>) -> Vec<String>;
}

#[cfg(test)]
#[path = "studied_tests.rs"]
mod tests;
