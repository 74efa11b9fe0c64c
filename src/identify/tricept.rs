//! The Tricept's identification: the generic operator ([`Solver`]),
//! estimate ([`EstimateOf`], [`Split`]) and Gauss–Newton
//! ([`gauss_newton`]) at its sizes (15 errors, 3 readings a pose), named by
//! its error names, with its nominal poses as the pose set the sweep and
//! `identify` use, and its Hooke axes' angles beside its errors
//! ([`AxesSolver`], [`angle_design`]); the rest of this folder is written
//! for any topology.

use super::design::{design_into, design_of, stack_differences};
use super::estimate::{EstimateOf, Split};
use super::gauss_newton::{gauss_newton, Linearisation};
use super::linear::{Constraints, Solver};
use super::method::IdentifyOptions;
use super::second_class::SecondClassSolver;
use super::weighting::Weighting;
use crate::error::PoseError;
use crate::mechanism::tricept::second_class::{angle_jacobian, Angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::Reading;
use crate::mechanism::tricept::{
    ErrorJacobian, ErrorVector, Geometry, Joints, Machine, NominalPoses, Tricept, N_PARAMS,
    N_READINGS, PARAM_NAMES,
};
use crate::sensors::{homed_readings, observation_into, SensorModel};
use nalgebra::{DMatrix, DVector, Vector3};
use rand::Rng;

/// Simulated readings of `truth` at the poses; `sensors = None` is
/// noise-free: its exact joints there, read by the homed sensors.
pub fn simulate_readings<G: Rng + Clone>(
    poses: &NominalPoses,
    truth: &Machine,
    sensors: Option<&SensorModel<N_READINGS>>,
    rng: &mut G,
) -> Result<Vec<Reading>, PoseError> {
    let mut actual = vec![Vector3::zeros(); poses.len()];
    poses.actual_joints_into(truth, &mut actual)?;
    let read = homed_readings(poses.joints[0].as_vector(), &actual, sensors, rng);
    Ok(read
        .iter()
        .zip(&poses.targets)
        .map(|(r, &target)| Reading {
            target,
            joints: Joints::from_vector(r),
        })
        .collect())
}

/// The Tricept's least-squares operator.
pub type LinearSolver = Solver<N_PARAMS, N_READINGS>;

/// The Tricept's Hooke axes' three angles identified beside its 15 errors.
pub type AxesSolver = SecondClassSolver<N_PARAMS, N_ANGLES, N_READINGS>;

impl AxesSolver {
    /// [`SecondClassSolver::named`] with the angles' names.
    pub fn new(
        base: &LinearSolver,
        h3: &DMatrix<f64>,
        rank_tolerance: f64,
    ) -> Result<Self, String> {
        Self::named(base, h3, rank_tolerance, &ANGLE_NAMES)
    }
}

/// H3: the derivatives of the homed readings in the three angles (degrees)
/// of `machine` (with its axes at `angles`) in the configurations `joints`
/// (the reference first), rows as [`super::design_matrix`]'s.
pub fn angle_design(
    machine: &Machine,
    angles: &Angles,
    joints: &[Joints],
) -> Result<DMatrix<f64>, PoseError> {
    let jac = joints
        .iter()
        .enumerate()
        .map(|(k, j)| angle_jacobian(machine, angles, j).map_err(|e| PoseError::new(k, e)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(match jac.split_first() {
        Some((reference, others)) => stack_differences(reference, others),
        None => DMatrix::zeros(0, N_ANGLES),
    })
}

/// The Tricept's identification result.
pub type Estimate = EstimateOf<N_PARAMS>;

/// The Tricept's estimate split by source.
pub type NoiseSplit = Split<N_PARAMS, N_READINGS>;

impl LinearSolver {
    /// The operator of design `h` under `weighting` (the estimator's, see
    /// [`super::Method::weighting`]), its active set from the weighted H.
    pub fn new(h: &DMatrix<f64>, weighting: &Weighting, rank_tolerance: f64) -> Self {
        Self::named(h, weighting, rank_tolerance, &PARAM_NAMES)
    }

    /// [`LinearSolver::new`] holding `constraints` (fixed errors, a prior).
    pub fn constrained(
        h: &DMatrix<f64>,
        weighting: &Weighting,
        rank_tolerance: f64,
        constraints: &Constraints<N_PARAMS>,
    ) -> Self {
        Self::constrained_named(h, weighting, rank_tolerance, (constraints, &PARAM_NAMES))
    }

    /// OLS: every row of weight 1.
    pub fn unweighted(h: &DMatrix<f64>, rank_tolerance: f64) -> Self {
        Self::new(
            h,
            &Weighting::Rows(DVector::from_element(h.nrows(), 1.0)),
            rank_tolerance,
        )
    }
}

/// H at the nominal configurations of `poses`.
pub fn design_matrix(nominal: &Machine, poses: &NominalPoses) -> Result<DMatrix<f64>, PoseError> {
    let x: Vec<_> = poses.joints.iter().map(Joints::as_vector).collect();
    design_of::<Tricept, N_PARAMS, N_READINGS>(nominal, &x)
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

/// Full identification of the mechanism from an observation vector: see
/// [`gauss_newton`].
pub fn identify(
    geometry: &Geometry,
    poses: &NominalPoses,
    solver: &LinearSolver,
    l: &DVector<f64>,
    options: &IdentifyOptions<N_PARAMS>,
) -> Result<(Estimate, LinearSolver), PoseError> {
    let mut model = Nominal {
        geometry,
        poses,
        x: vec![Vector3::zeros(); poses.len()],
        jac: Vec::with_capacity(poses.len()),
    };
    gauss_newton(&mut model, solver, l, options)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::Termination;

    /// μ of docs/method.md §8, written out here (identify sits below metrics).
    fn mu(truth: &ErrorVector, est: &ErrorVector) -> f64 {
        (truth - est).abs().sum() / 15.0
    }
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
        let poses = NominalPoses::new(&nominal, &crate::mechanism::tricept::poses::paper_targets())
            .unwrap();
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
