//! Tests of the workspace judgement: first-order propagation against exact
//! kinematics, and the blocked, grouped propagation against point by point.

use super::*;
use crate::config::Config;
use crate::mechanism::tricept::{ErrorVector, Machine};
use crate::metrics::stats::quantile_unsorted;
use crate::montecarlo::plan::NoiseGroup;
use crate::montecarlo::streams::trial_errors;
use crate::montecarlo::trial::tests::SweepContext;
use crate::montecarlo::trial::{run_trial, Outcome, Scratch};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};

/// The groups' directions: an encoder axis moves both encoders alike
/// (one direction), a scale axis the scale, a grid both; members carry
/// their σ differences; grades of their own operator stand alone.
#[test]
fn noise_groups_find_the_directions_grades_differ_in() {
    let v = Vector3::new;
    let scales = [v(1.0, 1.0, 5.0), v(2.0, 2.0, 5.0), v(4.0, 4.0, 5.0)];
    let g = NoiseGroup::of(&[0, 0, 0], |i| scales[i]);
    assert_eq!(g.len(), 1);
    assert_eq!(g[0].directions, vec![[1.0, 1.0, 0.0]]);
    assert_eq!(g[0].members, vec![(1, vec![1.0]), (2, vec![3.0])]);
    let grid = [
        v(1.0, 1.0, 5.0),
        v(2.0, 2.0, 5.0),
        v(1.0, 1.0, 7.0),
        v(2.0, 2.0, 7.0),
    ];
    let g = NoiseGroup::of(&[0, 0, 0, 0, 4], |i| if i < 4 { grid[i] } else { grid[0] });
    assert_eq!(g.len(), 2);
    assert_eq!(g[0].directions, vec![[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(g[0].members[2], (3, vec![1.0, 2.0]));
    assert_eq!((g[1].first, g[1].members.len()), (4, 0));
    // The two encoders differing otherwise: a direction each.
    let apart = [v(1.0, 1.0, 5.0), v(2.0, 3.0, 5.0)];
    let g = NoiseGroup::of(&[0, 0], |i| apart[i]);
    assert_eq!(g[0].directions, vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(g[0].members, vec![(1, vec![1.0, 2.0])]);
}

/// A trial's workspace figures are those of |S·e| point by point, from
/// the unblocked sensitivities and each grade's own residual: the grid
/// of blocks holds each point's matrix in its lane, the noise groups
/// combine the right directions with the right coefficients, and max,
/// mean and p95 are of every point, none missing, none padded. On a grid
/// of encoder × scale grades (two directions) with OLS and WLS.
#[test]
fn the_blocked_grid_judges_every_point_as_one_by_one() {
    let cfg = Config::paper().unwrap();
    let mut study = cfg
        .study()
        .encoder_arcsec(&[0.5, 2.0, 8.0])
        .scale_um(&[0.5, 3.0])
        .methods(&[crate::identify::Method::Ols, crate::identify::Method::Wls])
        .trials(1)
        .build()
        .unwrap();
    study.sweep.volumetric_step_mm = Some(70.0);
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    let n = ctx.grid.points.len();
    assert!(
        !n.is_multiple_of(crate::montecarlo::context::BLOCK),
        "a partial last block: {n}"
    );
    let mut s = Scratch::new(&ctx);
    let mut out = vec![Outcome::default(); ctx.grades.len()];
    for k in 0..5 {
        run_trial(&ctx, k, &mut s, &mut out);
        let truth_e = trial_errors(ctx.draw, &ctx.fixed_errors, ctx.bound_mm, ctx.seed, k);
        let before = ctx
            .grid
            .sensitivity
            .iter()
            .map(|sens| first_order_dv(sens, &truth_e))
            .fold(0.0, f64::max);
        for (gi, o) in out.iter().enumerate() {
            assert_eq!(o.dv_before_max, before);
            let e = -s.error(gi);
            let mut dv: Vec<f64> = ctx
                .grid
                .sensitivity
                .iter()
                .map(|sens| first_order_dv(sens, &e))
                .collect();
            let max = dv.iter().cloned().fold(0.0, f64::max);
            let mean = dv.iter().sum::<f64>() / n as f64;
            // A group's other grades are base − Σ c·(S·w): the same
            // algebra, rounded otherwise (a few ulp).
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * b;
            assert!(close(o.dv_after_max, max), "{} {max}", o.dv_after_max);
            assert!(close(o.dv_after_mean, mean), "{} {mean}", o.dv_after_mean);
            let p95 = quantile_unsorted(&mut dv, 0.95);
            assert!(close(o.dv_after_p95, p95), "{} {p95}", o.dv_after_p95);
            let ap = ctx
                .iso
                .sensitivity
                .iter()
                .map(|sens| first_order_dv(sens, &e))
                .fold(0.0, f64::max);
            assert_eq!(o.ap_after_max, ap);
        }
    }
}

/// First-order dV against exact kinematics at every workspace point, for
/// random machines with errors up to ±0.5 mm, before compensation and
/// after an identification that leaves up to ±0.05 mm per error.
#[test]
fn first_order_dv_is_within_a_micrometre_and_a_percent_of_exact() {
    let cfg = Config::paper().unwrap();
    let study = cfg
        .study()
        .encoder_arcsec(&[1.0])
        .trials(1)
        .build()
        .unwrap();
    let mut study = study;
    study.sweep.volumetric_step_mm = Some(50.0);
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    assert_eq!(ctx.grid.points.len(), 5 * 197);
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(12);
    let (mut worst_abs, mut worst_rel) = (0.0f64, 0.0f64);
    for _ in 0..40 {
        let truth_e = ErrorVector::from_fn(|_, _| rng.random_range(-0.5..=0.5));
        let truth = Machine::with_errors(&cfg.geometry, &truth_e);
        for est in [
            ErrorVector::zeros(),
            truth_e + ErrorVector::from_fn(|_, _| rng.random_range(-0.05..=0.05)),
        ] {
            let identified = Machine::with_errors(&cfg.geometry, &est);
            for k in 0..ctx.grid.points.len() {
                let exact = ctx
                    .mech
                    .exact_dv(&truth, Some(&identified), Judging::Grid, k)
                    .unwrap();
                let first = first_order_dv(&ctx.grid.sensitivity[k], &(truth_e - est));
                let err = (first - exact).abs();
                // The stated bound: 1 µm + 1 % of the exact value.
                assert!(
                    err <= 1e-3 + 0.01 * exact,
                    "point {:?}: first-order {first} vs exact {exact}",
                    ctx.grid.points[k]
                );
                worst_abs = worst_abs.max(err);
                worst_rel = worst_rel.max(err / exact.max(1e-9));
            }
        }
    }
    println!("first-order dV: worst difference {worst_abs:.2e} mm, worst relative {worst_rel:.2e}");
}
