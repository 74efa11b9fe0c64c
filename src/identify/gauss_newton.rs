//! Iterated identification (Gauss–Newton): re-linearise the observation
//! model at the machine of the current estimate and solve for the step with
//! the same weights and the active set of the nominal analysis. Every stop
//! has a name ([`Termination`]). One algorithm for every topology
//! ([`gauss_newton`] over a [`Linearisation`]): any [`Kinematic`]
//! topology's [`PoseSet`] ([`identify_poses`]), and the Tricept's nominal
//! poses ([`super::tricept::identify`]).

use super::design::design_into;
use super::estimate::{EstimateOf, Termination};
use super::linear::Solver;
use super::method::IdentifyOptions;
use crate::error::PoseError;
use crate::mechanism::{Kinematic, PoseSet};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// What Gauss–Newton asks of a pose set: the observation the machine with
/// errors `values` gives by exact kinematics, and the design matrix of that
/// machine in the configurations it reached.
pub trait Linearisation<const P: usize, const R: usize> {
    /// g(values): the rows of l that machine gives, written into `g`; its
    /// configurations are kept for [`Linearisation::design`].
    fn observe(&mut self, values: &SVector<f64, P>, g: &mut [f64]) -> Result<(), PoseError>;

    /// H of the machine with `values` in the configurations of the last
    /// [`Linearisation::observe`] (of the same values).
    fn design(&mut self, values: &SVector<f64, P>) -> Result<DMatrix<f64>, PoseError>;
}

/// A [`Kinematic`] topology's pose set.
struct Poses<'a, T: Kinematic<P, R>, const P: usize, const R: usize> {
    layout: &'a T::Layout,
    poses: &'a PoseSet<T, P, R>,
    x: Vec<SVector<f64, R>>,
    jac: Vec<SMatrix<f64, R, P>>,
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> Linearisation<P, R>
    for Poses<'_, T, P, R>
{
    fn observe(&mut self, values: &SVector<f64, P>, g: &mut [f64]) -> Result<(), PoseError> {
        let machine = T::machine(self.layout, values);
        self.poses.actual_into(&machine, &mut self.x)?;
        self.poses.observation_into(&self.x, g);
        Ok(())
    }

    fn design(&mut self, values: &SVector<f64, P>) -> Result<DMatrix<f64>, PoseError> {
        design_into::<T, P, R>(&T::machine(self.layout, values), &self.x, &mut self.jac)
    }
}

/// l − g(values): the observation minus what the model with `values`
/// predicts (exact kinematics).
fn residual<const P: usize, const R: usize>(
    model: &mut impl Linearisation<P, R>,
    values: &SVector<f64, P>,
    l: &DVector<f64>,
) -> Result<DVector<f64>, PoseError> {
    let mut g = DVector::zeros(l.len());
    model.observe(values, g.as_mut_slice())?;
    Ok(l - g)
}

/// Full identification of a [`Kinematic`] topology from the observation `l`
/// of its pose set `poses` (rows as [`PoseSet::observation_into`] writes
/// them): see [`gauss_newton`].
pub fn identify_poses<T: Kinematic<P, R>, const P: usize, const R: usize>(
    layout: &T::Layout,
    poses: &PoseSet<T, P, R>,
    solver: &Solver<P, R>,
    l: &DVector<f64>,
    options: &IdentifyOptions<P>,
) -> Result<(EstimateOf<P>, Solver<P, R>), PoseError> {
    let mut model = Poses {
        layout,
        poses,
        x: vec![SVector::zeros(); poses.len()],
        jac: Vec::with_capacity(poses.len()),
    };
    gauss_newton(&mut model, solver, l, options)
}

/// Full identification from an observation vector: one linearisation at the
/// nominal poses with the prebuilt `solver` (its H, weights and active set),
/// then (if `iterations > 1`) Gauss–Newton steps re-linearised at the machine
/// of the current estimate. FK failures of an intermediate estimate are
/// returned with the pose index. Returns the estimate and the operator of the
/// last linearisation.
pub fn gauss_newton<const P: usize, const R: usize>(
    model: &mut impl Linearisation<P, R>,
    solver: &Solver<P, R>,
    l: &DVector<f64>,
    options: &IdentifyOptions<P>,
) -> Result<(EstimateOf<P>, Solver<P, R>), PoseError> {
    let mut est = solver.estimate(l);
    if options.iterations <= 1 {
        return Ok((est, solver.clone()));
    }
    let mut values = est.values;
    let mut termination = Termination::MaxIterations;
    let mut used = 1;
    let mut previous_step = f64::INFINITY;
    let mut last = solver.clone();
    while used < options.iterations {
        let r = residual(model, &values, l)?;
        let h = model.design(&values)?;
        let step_solver = Solver::with_analysis(
            &h,
            solver.weighting(),
            solver.analysis.clone(),
            solver.constraints(),
        );
        let mut step = SVector::zeros();
        step_solver.step(r.as_slice(), &values, &mut step);
        values += step;
        used += 1;
        last = step_solver;
        let size = step.amax();
        if size < options.tolerance_mm {
            termination = Termination::StepBelowTolerance;
            break;
        }
        // Forward kinematics is exact to ~1e-11 mm, so steps cannot fall
        // below a floor of ~1e-10 mm: a step no smaller than the previous one
        // and within 100 × tolerance has stagnated at round-off.
        if size >= previous_step && size < 100.0 * options.tolerance_mm {
            termination = Termination::StagnatedAtRoundoff;
            break;
        }
        previous_step = size;
    }
    // Uncertainty from the last linearisation and the final exact residual.
    let r = residual(model, &values, l)?;
    let (std_mm, residual_rms) = last.posterior(&r);
    est.values = values;
    est.source = last.sources(&std_mm);
    est.std_mm = std_mm;
    est.residual_rms = residual_rms;
    est.iterations = used;
    est.termination = termination;
    Ok((est, last))
}
