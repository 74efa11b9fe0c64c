//! The generic white-noise kernel against the mechanism's own kernel: the
//! same machines, the same noise, the same estimates.

use super::*;
use crate::config::{Config, ErrorDraw};
use crate::identify::Method;
use crate::mechanism::tricept::{ErrorVector, Tricept, N_PARAMS, N_READINGS};
use crate::montecarlo::{run_trial, KernelPath, Outcome as KernelOutcome, Scratch, SweepContext};
use std::ops::Range;

/// The mechanism's context for white-noise OLS with random machines and
/// the generic study of the same machines, sensors and poses.
fn both(iterations: usize) -> (Config, SweepContext) {
    let cfg = Config::paper().unwrap();
    let study = cfg
        .study()
        .errors(ErrorDraw::Random)
        .encoder_arcsec(&[3.0])
        .scale_um(&[2.0])
        .methods(&[Method::Ols])
        .iterations(iterations)
        .seed(41)
        .trials(1)
        .build()
        .unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    (cfg, ctx)
}

fn generic_of(ctx: &SweepContext) -> Study<'_, Tricept, N_PARAMS, N_READINGS> {
    Study {
        layout: &ctx.geometry,
        targets: &ctx.poses.targets,
        bound_mm: ctx.bound_mm,
        sigma: ctx.sensors[0].reading_sigma(),
        trials: 0,
        seed: ctx.seed,
        options: ctx.options,
    }
}

/// ‖op‖∞ of `solver`: the most an estimate moves per unit change of every
/// row of l (by applying it to each unit vector).
fn op_norm(solver: &Solver<N_PARAMS, N_READINGS>) -> f64 {
    let mut sums = ErrorVector::zeros();
    let mut e = vec![0.0; solver.rows()];
    for r in 0..solver.rows() {
        e[r] = 1.0;
        let mut col = ErrorVector::zeros();
        solver.apply(&e, &mut col);
        sums += col.abs();
        e[r] = 0.0;
    }
    sums.amax()
}

/// Trial k of the mechanism's kernel and of the generic one: the largest
/// difference of their estimates (mm) as a fraction of what forward
/// kinematics' own spread allows (two solutions from different starts agree
/// to FK_AGREEMENT per reading, so an estimate to ‖op‖∞·2·FK_AGREEMENT), and
/// of their μ relative to μ.
fn differences(ctx: &SweepContext, ks: Range<u64>) -> (f64, f64) {
    let study = generic_of(ctx);
    let nominal = crate::mechanism::tricept::Machine::nominal(&ctx.geometry);
    let poses = PoseSet::<Tricept, N_PARAMS, N_READINGS>::new(&nominal, study.targets).unwrap();
    let h = crate::identify::design_of::<Tricept, N_PARAMS, N_READINGS>(&nominal, &poses.nominal)
        .unwrap();
    let solver = Solver::<N_PARAMS, N_READINGS>::ols_named(
        &h,
        ctx.options.rank_tolerance,
        crate::mechanism::tricept::PARAM_NAMES.as_slice(),
    );
    let allowed = op_norm(&solver) * 2.0 * super::super::trial::tests::FK_AGREEMENT;
    let mut s = Scratch::new(ctx);
    let mut gs = Buffers::new(&poses);
    let mut out = vec![KernelOutcome::default(); ctx.grades.len()];
    let (mut est_diff, mut mu_diff) = (0.0f64, 0.0f64);
    for k in ks {
        run_trial(ctx, k, &mut s, &mut out);
        let g = trial(&study, &poses, &solver, k, &mut gs);
        let kernel_est: ErrorVector = out[0].error + g.truth;
        assert!(g.mu.is_finite() && out[0].mu.is_finite());
        est_diff = est_diff.max((kernel_est - g.estimate).amax());
        mu_diff = mu_diff.max((out[0].mu - g.mu).abs() / out[0].mu);
        assert_eq!(g.mu0, out[0].mu0, "the same machine from stream 0");
    }
    (est_diff / allowed, mu_diff)
}

/// The generic kernel against the mechanism's own on `path`, trials `ks`:
/// the same operator applied to the same noise and to readings of the same
/// machine that forward kinematics solved from other starts (the kernel's
/// from a first-order guess).
fn assert_equal_to_the_kernel(iterations: usize, path: fn(&KernelPath) -> bool, ks: Range<u64>) {
    let (_, ctx) = both(iterations);
    assert!(path(&ctx.plan.path), "{:?}", ctx.plan.path);
    let (est, mu) = differences(&ctx, ks);
    assert!(est < 1.0, "estimates differ by {est} of what FK allows");
    assert!(mu < 1e-8, "μ differs by {mu:e} of itself");
}

#[test]
fn the_mechanism_through_the_generic_kernel_gives_its_own_kernels_estimates() {
    assert_equal_to_the_kernel(1, |p| matches!(p, KernelPath::WhiteNoise { .. }), 0..40);
}

#[test]
fn the_mechanism_through_the_generic_gauss_newton_gives_its_own_kernels_estimates() {
    assert_equal_to_the_kernel(4, |p| matches!(p, KernelPath::GaussNewton { .. }), 0..8);
}

#[test]
fn a_generic_study_summarises_its_trials() {
    let (_, ctx) = both(1);
    let mut study = generic_of(&ctx);
    study.trials = 80;
    let out = run(&study).unwrap();
    assert_eq!(out.trials.len(), 80);
    assert_eq!(out.failed, 0);
    // The paper's poses leave one combination unidentified, as the kernel's.
    assert_eq!(out.rank, ctx.solvers[0].analysis.rank);
    assert_eq!(out.identifiable, ctx.solvers[0].identifiable());
    let mut mus: Vec<f64> = out.trials.iter().map(|t| t.mu).collect();
    let mean = mus.iter().sum::<f64>() / 80.0;
    assert!((out.mu_mean - mean).abs() < 1e-15);
    assert!(out.mu_mean_ci95.0 < mean && mean < out.mu_mean_ci95.1);
    mus.sort_by(f64::total_cmp);
    // Type 7 at p = 0.95 of 80 values: x[75] + 0.05·(x[76] − x[75]);
    // the upper 95 % limit of 80 values is an order statistic above it.
    let p95 = mus[75] + 0.05 * (mus[76] - mus[75]);
    assert!((out.mu_p95 - p95).abs() < 1e-15);
    let limit = out.mu_p95_upper95.unwrap();
    assert!(mus.contains(&limit) && limit >= out.mu_p95);
    // The machines are stream 0's: the first trial's μ0 is trial_errors's.
    let e = crate::montecarlo::trial_errors(
        ErrorDraw::Random,
        &ErrorVector::zeros(),
        ctx.bound_mm,
        ctx.seed,
        0,
    );
    assert_eq!(out.trials[0].truth, e);
}

#[test]
fn a_gauss_newton_stopped_by_its_limit_is_said() {
    // Two linearisations cannot reach 1e-15 mm: every trial says so, and
    // its estimate is still the iterated one (better than one linearisation).
    let (_, ctx) = both(2);
    let mut study = generic_of(&ctx);
    study.trials = 6;
    study.options.tolerance_mm = 1e-15;
    let two = run(&study).unwrap();
    assert!(two.trials.iter().all(|t| t.not_converged));
    study.options.iterations = 1;
    let one = run(&study).unwrap();
    assert!(one.trials.iter().all(|t| !t.not_converged));
    study.options.iterations = 30;
    study.options.tolerance_mm = 1e-6;
    let many = run(&study).unwrap();
    assert!(many.trials.iter().all(|t| !t.not_converged));
}
