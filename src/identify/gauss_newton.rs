//! Iterated identification (Gauss–Newton): re-linearise the observation
//! model at the machine of the current estimate and solve for the step with
//! the same weights and the active set of the nominal analysis. Every stop
//! has a name ([`Termination`]).

use super::design::stack_differences;
use super::linear::{Estimate, LinearSolver, Termination};
use super::method::IdentifyOptions;
use crate::error::PoseError;
use crate::model::jacobian::error_jacobian;
use crate::model::{ErrorVector, Geometry, Joints, Machine, NominalPoses};
use crate::sensors::observation_into;
use nalgebra::{DVector, Vector3};

/// l − g(values): the observation minus what the model with `values` predicts
/// (exact kinematics), with the joints of that machine left in `x`.
fn residual(
    geometry: &Geometry,
    poses: &NominalPoses,
    values: &ErrorVector,
    l: &DVector<f64>,
    x: &mut [Vector3<f64>],
) -> Result<DVector<f64>, PoseError> {
    let machine = Machine::with_errors(geometry, values);
    poses.actual_joints_into(&machine, x)?;
    let mut g = DVector::zeros(l.len());
    observation_into(&poses.joints, x, g.as_mut_slice());
    Ok(l - g)
}

/// Full identification from an observation vector: one linearisation at the
/// nominal poses with the prebuilt `solver` (its H, weights and active set),
/// then (if `iterations > 1`) Gauss–Newton steps re-linearised at the machine
/// of the current estimate. FK failures of an intermediate estimate are
/// returned with the pose index. Returns the estimate and the operator of the
/// last linearisation.
pub fn identify(
    geometry: &Geometry,
    poses: &NominalPoses,
    solver: &LinearSolver,
    l: &DVector<f64>,
    options: &IdentifyOptions,
) -> Result<(Estimate, LinearSolver), PoseError> {
    let mut est = solver.estimate(l);
    if options.iterations <= 1 {
        return Ok((est, solver.clone()));
    }
    let n = poses.len();
    let mut values = est.values;
    let mut termination = Termination::MaxIterations;
    let mut used = 1;
    let mut previous_step = f64::INFINITY;
    let mut last = solver.clone();
    let mut jac = Vec::with_capacity(n);
    let mut x = vec![Vector3::zeros(); n];
    while used < options.iterations {
        let r = residual(geometry, poses, &values, l, &mut x)?;
        let machine = Machine::with_errors(geometry, &values);
        jac.clear();
        for (k, xk) in x.iter().enumerate() {
            let j = Joints::from_vector(xk);
            jac.push(error_jacobian(&machine, &j).map_err(|e| PoseError::new(k, e))?);
        }
        let h = stack_differences(&jac[0], &jac[1..]);
        let step_solver =
            LinearSolver::with_analysis(&h, solver.weights(), solver.analysis.clone());
        let mut step = ErrorVector::zeros();
        step_solver.apply(r.as_slice(), &mut step);
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
    let r = residual(geometry, poses, &values, l, &mut x)?;
    let (std_mm, residual_rms) = last.posterior(&r);
    est.values = values;
    est.std_mm = std_mm;
    est.residual_rms = residual_rms;
    est.iterations = used;
    est.termination = termination;
    Ok((est, last))
}
