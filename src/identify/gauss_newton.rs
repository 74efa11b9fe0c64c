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
            LinearSolver::with_analysis(&h, solver.weighting(), solver.analysis.clone());
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::{design_matrix, Weighting};

    /// μ of SPEC §8, written out here (identify sits below metrics).
    fn mu(truth: &ErrorVector, est: &ErrorVector) -> f64 {
        (truth - est).abs().sum() / 15.0
    }
    use crate::model::poses::{pattern, Workspace};
    use crate::sensors::observation_vector;
    use nalgebra::DVector;

    /// Noise-free observation of a full-rank layout with Table 2-sized errors.
    fn case() -> (
        Geometry,
        NominalPoses,
        LinearSolver,
        DVector<f64>,
        ErrorVector,
    ) {
        let g = Geometry::from_circles(100.0, 288.7, [-60.0, 60.0, 180.0], [-30.0, 90.0, 210.0]);
        let nominal = Machine::nominal(&g);
        let poses =
            NominalPoses::new(&nominal, &pattern(&Workspace::paper(), 3, &[0.5, 1.0], 8)).unwrap();
        let truth = ErrorVector::from_fn(|i, _| 0.4 * ((i as f64) * 1.7).sin());
        let mut x = vec![Vector3::zeros(); poses.len()];
        poses
            .actual_joints_into(&Machine::with_errors(&g, &truth), &mut x)
            .unwrap();
        let l = observation_vector(&poses.joints, &x);
        let h = design_matrix(&nominal, &poses).unwrap();
        let solver = LinearSolver::new(
            &h,
            &Weighting::Rows(DVector::from_element(h.nrows(), 1.0)),
            1e-9,
        );
        (g, poses, solver, l, truth)
    }

    #[test]
    fn each_stop_has_its_name_and_count() {
        let (g, poses, solver, l, truth) = case();
        let opts = |iterations| IdentifyOptions {
            iterations,
            tolerance_mm: 1e-10,
            ..IdentifyOptions::default()
        };
        let (one, _) = identify(&g, &poses, &solver, &l, &opts(1)).unwrap();
        assert_eq!(one.termination, Termination::SingleLinearisation);
        assert_eq!(one.iterations, 1);
        // Two linearisations cannot reach 1e-10 mm: stopped by the limit.
        let (two, _) = identify(&g, &poses, &solver, &l, &opts(2)).unwrap();
        assert_eq!(two.termination, Termination::MaxIterations);
        assert!(!two.termination.converged());
        assert_eq!(two.iterations, 2);
        assert!(mu(&truth, &two.values) < mu(&truth, &one.values));
        // Enough: converges, reports how many it used, recovers the truth.
        let (full, _) = identify(&g, &poses, &solver, &l, &opts(30)).unwrap();
        assert!(full.termination.converged(), "{:?}", full.termination);
        assert!(
            full.iterations > 2 && full.iterations < 30,
            "{}",
            full.iterations
        );
        assert!(
            mu(&truth, &full.values) < 1e-9,
            "{}",
            mu(&truth, &full.values)
        );
        // Exact data: the residual and the uncertainty vanish.
        assert!(full.residual_rms < 1e-9 && full.std_mm.amax() < 1e-6);
        // One step more is one linearisation more (the count is exact).
        let (three, _) = identify(&g, &poses, &solver, &l, &opts(3)).unwrap();
        assert_eq!(three.iterations, 3);
    }

    #[test]
    fn a_loose_tolerance_stops_on_the_step() {
        let (g, poses, solver, l, _) = case();
        let opts = IdentifyOptions {
            iterations: 30,
            tolerance_mm: 1e-3,
            ..IdentifyOptions::default()
        };
        let (e, _) = identify(&g, &poses, &solver, &l, &opts).unwrap();
        assert_eq!(e.termination, Termination::StepBelowTolerance);
        assert!(e.iterations <= 4, "{}", e.iterations);
        assert!(Termination::StagnatedAtRoundoff.converged());
        assert!(Termination::MaxIterations.describe().contains("NOT"));
    }

    #[test]
    fn steps_stuck_at_round_off_count_as_converged() {
        // FK is exact to ~1e-11 mm: a tolerance of 1e-11 mm is reached or
        // the steps stop shrinking there; either way it converges long
        // before the limit (on this machine: stagnation after 7 steps).
        let (g, poses, solver, l, truth) = case();
        let opts = IdentifyOptions {
            iterations: 60,
            tolerance_mm: 1e-11,
            ..IdentifyOptions::default()
        };
        let (e, _) = identify(&g, &poses, &solver, &l, &opts).unwrap();
        assert!(e.termination.converged(), "{:?}", e.termination);
        assert!(e.iterations < 30, "{}", e.iterations);
        assert!(mu(&truth, &e.values) < 1e-9);
    }
}
