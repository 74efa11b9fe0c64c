//! A white-noise study of any [`Kinematic`] topology: the reference kernel
//! a second topology runs through before it has a kernel of its own.
//!
//! Trial k draws its machine from stream (seed, k, 0) — each error uniform
//! in ±`bound_mm`, as [`super::trial_errors`] draws the mechanism's — reads
//! it by exact forward kinematics at the nominal commands, adds homed
//! Gaussian noise of σ per reading from stream (seed, k, 1) in the order
//! the mechanism's white-noise kernel draws it
//! ([`crate::sensors::noise::homed_unit_normals`]), and identifies the
//! errors with [`Solver`] (OLS) and, when `iterations > 1`, the same
//! Gauss–Newton as `identify` ([`identify_poses`]). For the mechanism
//! itself it gives the white-noise kernel's estimates (tested trial by
//! trial); it has none of that kernel's sharing across grades, datasheet
//! sensors or workspace maps. Trials are gathered in trial order: the
//! thread count cannot change a result.

use super::streams::{stream, uniform_errors};
use crate::error::PoseError;
use crate::identify::{identify_poses, IdentifyOptions, Solver};
use crate::mechanism::{Kinematic, PoseSet};
use crate::metrics::stats::{mean_ci95, quantile_sorted, quantile_upper95};
use crate::metrics::{mu, mu0};
use crate::sensors::noise::homed_unit_normals;
use nalgebra::{DVector, SVector, Vector3};
use rayon::prelude::*;

/// A white-noise study of topology `T` (P errors, R readings a pose).
#[derive(Debug, Clone)]
pub struct Study<'a, T: Kinematic<P, R>, const P: usize, const R: usize> {
    pub layout: &'a T::Layout,
    /// Pose targets, the reference first (the sensors are homed there).
    pub targets: &'a [Vector3<f64>],
    /// Each error of a trial's machine is uniform in ±bound, mm.
    pub bound_mm: f64,
    /// σ of each reading, in the model's units (rad, mm).
    pub sigma: SVector<f64, R>,
    pub trials: u64,
    pub seed: u64,
    /// Iterations, tolerance and rank tolerance (the method is OLS).
    pub options: IdentifyOptions,
}

/// One trial's machine and its calibration.
#[derive(Debug, Clone, Copy)]
pub struct Trial<const P: usize> {
    pub truth: SVector<f64, P>,
    /// The estimate (NaN when forward kinematics failed at a pose).
    pub estimate: SVector<f64, P>,
    /// μ of the estimate (NaN when forward kinematics failed).
    pub mu: f64,
    /// μ with no calibration.
    pub mu0: f64,
    /// Gauss–Newton stopped on its limit or at a pose it could not solve
    /// (the one-linearisation estimate is kept then).
    pub not_converged: bool,
}

/// A study's trials and what they say.
#[derive(Debug, Clone)]
pub struct Sweep<const P: usize> {
    /// Rank of the design and the errors it identifies.
    pub rank: usize,
    pub identifiable: [bool; P],
    /// The linear model's standard deviation of each estimate for `sigma`
    /// (mm; 0 for an unidentifiable error).
    pub predicted_std: SVector<f64, P>,
    pub trials: Vec<Trial<P>>,
    /// Machines whose forward kinematics failed (left out of μ's figures).
    pub failed: usize,
    /// Mean μ and its Student-t 95 % interval (mm; NaN with no machine).
    pub mu_mean: f64,
    pub mu_mean_ci95: (f64, f64),
    /// p95 of μ and its one-sided upper 95 % limit (from 59 machines), mm.
    pub mu_p95: f64,
    pub mu_p95_upper95: Option<f64>,
}

/// Run `study` on the current rayon pool. Errors: a target the nominal
/// machine cannot reach (named by its pose index).
pub fn run<T, const P: usize, const R: usize>(
    study: &Study<'_, T, P, R>,
) -> Result<Sweep<P>, PoseError>
where
    T: Kinematic<P, R>,
    T::Layout: Sync,
    T::Machine: Sync,
{
    let nominal = T::machine(study.layout, &SVector::zeros());
    let poses = PoseSet::<T, P, R>::new(&nominal, study.targets)?;
    let h = crate::identify::design_of::<T, P, R>(&nominal, &poses.nominal)?;
    let solver = Solver::<P, R>::ols_named(&h, study.options.rank_tolerance, T::ERROR_NAMES);
    let trials: Vec<Trial<P>> = (0..study.trials)
        .into_par_iter()
        .map_init(
            || Buffers::new(&poses),
            |s, k| trial(study, &poses, &solver, k, s),
        )
        .collect();
    let mut mus: Vec<f64> = trials
        .iter()
        .map(|t| t.mu)
        .filter(|m| !m.is_nan())
        .collect();
    mus.sort_by(f64::total_cmp);
    let (mu_mean, mu_mean_half) = mean_ci95(&mus);
    Ok(Sweep {
        rank: solver.analysis.rank,
        identifiable: solver.identifiable(),
        predicted_std: solver.predicted_std(&study.sigma),
        failed: trials.len() - mus.len(),
        trials,
        mu_mean,
        mu_mean_ci95: (mu_mean - mu_mean_half, mu_mean + mu_mean_half),
        mu_p95: quantile_sorted(&mus, 0.95),
        mu_p95_upper95: quantile_upper95(&mus, 0.95),
    })
}

/// A thread's buffers for [`trial`] (one linearisation allocates nothing).
#[derive(Debug, Clone)]
pub struct Buffers<const R: usize> {
    x: Vec<SVector<f64, R>>,
    l: Vec<f64>,
    dz: Vec<f64>,
}

impl<const R: usize> Buffers<R> {
    pub fn new<T: Kinematic<P, R>, const P: usize>(poses: &PoseSet<T, P, R>) -> Self {
        Buffers {
            x: vec![SVector::zeros(); poses.len()],
            l: vec![0.0; poses.rows()],
            dz: vec![0.0; poses.rows()],
        }
    }
}

/// Trial k: a pure function of (study, k); `s` only lends buffers.
pub fn trial<T: Kinematic<P, R>, const P: usize, const R: usize>(
    study: &Study<'_, T, P, R>,
    poses: &PoseSet<T, P, R>,
    solver: &Solver<P, R>,
    k: u64,
    s: &mut Buffers<R>,
) -> Trial<P> {
    let truth = uniform_errors::<P>(study.bound_mm, study.seed, k);
    let failed = Trial {
        truth,
        estimate: SVector::from_element(f64::NAN),
        mu: f64::NAN,
        mu0: mu0(&truth),
        not_converged: false,
    };
    let machine = T::machine(study.layout, &truth);
    if poses.actual_into(&machine, &mut s.x).is_err() {
        return failed;
    }
    poses.observation_into(&s.x, &mut s.l);
    homed_unit_normals::<R, _>(&mut stream(study.seed, k, 1), &mut s.dz);
    for (r, (li, d)) in s.l.iter_mut().zip(&s.dz).enumerate() {
        *li += study.sigma[r % R] * d;
    }
    let one_linearisation = |estimate: &mut SVector<f64, P>| solver.apply(&s.l, estimate);
    let mut estimate = SVector::zeros();
    let mut not_converged = false;
    if study.options.iterations <= 1 {
        one_linearisation(&mut estimate);
    } else {
        let lv = DVector::from_column_slice(&s.l);
        match identify_poses(study.layout, poses, solver, &lv, &study.options) {
            Ok((e, _)) => {
                estimate = e.values;
                not_converged = !e.termination.converged();
            }
            Err(_) => {
                one_linearisation(&mut estimate);
                not_converged = true;
            }
        }
    }
    Trial {
        mu: mu(&truth, &estimate),
        estimate,
        not_converged,
        ..failed
    }
}

#[cfg(test)]
#[path = "generic_tests.rs"]
mod tests;
