//! Iterated identification (Gauss–Newton): re-linearise the observation
//! model at the machine of the current estimate and solve for the step with
//! the same weights and the active set of the nominal analysis. Every stop
//! has a name ([`Termination`]). One algorithm for every topology
//! ([`gauss_newton`] over a [`Linearisation`]): the mechanism's nominal
//! poses ([`identify`]) and any [`Kinematic`] topology's [`PoseSet`]
//! ([`identify_poses`]).

use super::design::design_into;
use super::estimate::{Estimate, EstimateOf, Termination};
use super::linear::{LinearSolver, Solver};
use super::method::IdentifyOptions;
use crate::error::PoseError;
use crate::mechanism::tricept::{
    ErrorJacobian, ErrorVector, Geometry, Machine, NominalPoses, Tricept, N_PARAMS, N_READINGS,
};
use crate::mechanism::{Kinematic, PoseSet};
use crate::sensors::observation_into;
use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector3};

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

/// The mechanism's nominal poses (the sweep's and `identify`'s pose set).
struct Nominal<'a> {
    geometry: &'a Geometry,
    poses: &'a NominalPoses,
    x: Vec<Vector3<f64>>,
    jac: Vec<ErrorJacobian>,
}

impl Linearisation<N_PARAMS, N_READINGS> for Nominal<'_> {
    fn observe(&mut self, values: &ErrorVector, g: &mut [f64]) -> Result<(), PoseError> {
        let machine = Machine::with_errors(self.geometry, values);
        self.poses.actual_joints_into(&machine, &mut self.x)?;
        observation_into(&self.poses.joints, &self.x, g);
        Ok(())
    }

    fn design(&mut self, values: &ErrorVector) -> Result<DMatrix<f64>, PoseError> {
        let machine = Machine::with_errors(self.geometry, values);
        design_into::<Tricept, N_PARAMS, N_READINGS>(&machine, &self.x, &mut self.jac)
    }
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

/// Full identification of the mechanism from an observation vector: see
/// [`gauss_newton`].
pub fn identify(
    geometry: &Geometry,
    poses: &NominalPoses,
    solver: &LinearSolver,
    l: &DVector<f64>,
    options: &IdentifyOptions,
) -> Result<(Estimate, LinearSolver), PoseError> {
    let mut model = Nominal {
        geometry,
        poses,
        x: vec![Vector3::zeros(); poses.len()],
        jac: Vec::with_capacity(poses.len()),
    };
    gauss_newton(&mut model, solver, l, options)
}

/// Full identification of a [`Kinematic`] topology from the observation `l`
/// of its pose set `poses` (rows as [`PoseSet::observation_into`] writes
/// them): see [`gauss_newton`].
pub fn identify_poses<T: Kinematic<P, R>, const P: usize, const R: usize>(
    layout: &T::Layout,
    poses: &PoseSet<T, P, R>,
    solver: &Solver<P, R>,
    l: &DVector<f64>,
    options: &IdentifyOptions,
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
    options: &IdentifyOptions,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::{design_matrix, Weighting};

    /// μ of docs/method.md §8, written out here (identify sits below metrics).
    fn mu(truth: &ErrorVector, est: &ErrorVector) -> f64 {
        (truth - est).abs().sum() / 15.0
    }
    use crate::mechanism::tricept::poses::{pattern, Workspace};
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
