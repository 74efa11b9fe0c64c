//! A `Kinematic` topology through the study kernel, against the Tricept's
//! own `Studied`: the Tricept is a `Kinematic` topology too, so the same
//! study through [`KinematicStudy`] (forward kinematics from the nominal
//! readings, Gauss–Newton over its pose set, sensitivities by central
//! differences) must reach the calibrations `TriceptStudy` reaches (its
//! first-order start, lock-step forward kinematics, analytic
//! sensitivities) to the tolerances of those routes.

use super::*;
use crate::config::{Config, ConfigStudy, ErrorDraw};
use crate::mechanism::tricept::{Tricept, N_PARAMS, N_READINGS};
use crate::mechanism::Kinematic;
use crate::montecarlo::context::{GradeAxes, GradeTable, Parts, SweepContext};
use crate::montecarlo::trial::{run_trial, Outcome, Scratch};
use crate::montecarlo::tricept::TriceptContext;

type Generic<'a> =
    SweepContext<KinematicStudy<'a, Tricept, N_PARAMS, N_READINGS>, N_PARAMS, N_READINGS, 0>;

/// The grade table of `study` at `tricept`'s sensor sets and subsets,
/// with design `h`, for `mech`.
fn grade_table<'a>(
    study: &ConfigStudy,
    tricept: &TriceptContext,
    h: &nalgebra::DMatrix<f64>,
    mech: &KinematicStudy<'a, Tricept, N_PARAMS, N_READINGS>,
) -> GradeTable<N_PARAMS, N_READINGS> {
    GradeTable::new(
        &GradeAxes {
            methods: &study.sweep.methods,
            truths: &study.sweep.truth,
            assumed: &tricept.assumed,
            h,
            nominal: mech.nominal(),
            subsets: &tricept.subsets,
            options: &study.identification,
            names: mech.names(),
        },
        |i| format!("set {i}"),
    )
    .unwrap()
}

/// The study of `tricept`'s config and study through [`KinematicStudy`]:
/// the same poses, subsets, grades, sensor sets and settings.
fn through_kinematic<'a>(
    cfg: &'a Config,
    study: &ConfigStudy,
    tricept: &TriceptContext,
) -> Generic<'a> {
    let (mech, grids) = KinematicStudy::<Tricept, N_PARAMS, N_READINGS>::new(
        &cfg.geometry,
        &study.poses,
        &tricept.subsets,
        (&tricept.grid.points, &tricept.iso.points),
    )
    .unwrap();
    // Its own design, from the topology's error Jacobian at its poses.
    let nominal = Tricept::machine(&cfg.geometry, &nalgebra::SVector::zeros());
    let h = crate::identify::design_of::<Tricept, N_PARAMS, N_READINGS>(&nominal, mech.nominal())
        .unwrap();
    assert!((&h - &tricept.h).amax() < 1e-9, "the two routes' designs");
    let sw = &study.sweep;
    let table = grade_table(study, tricept, &h, &mech);
    SweepContext::assemble(Parts {
        mech,
        h,
        h_second: None,
        subsets: tricept.subsets.clone(),
        table,
        assumed: tricept.assumed.clone(),
        sensors: tricept.sensors.clone(),
        products: tricept.products.clone(),
        options: study.identification,
        gls_per_machine: sw.gls_per_machine,
        draw: sw.errors,
        fixed_errors: cfg.errors,
        bound_mm: sw.error_bound_mm,
        seed: sw.seed,
        perfect: sw.perfect_sensors,
        grids,
        orientation: Default::default(),
        exact: sw.volumetric_exact,
    })
    .unwrap()
}

/// Trials 0 … n−1 of both contexts, outcome by outcome: μ to `mu_tol`
/// mm, the workspace's dV (before and after) to `dv_tol` mm, each a
/// number where the study judges the workspace.
fn agree(a: &TriceptContext, b: &Generic<'_>, n: u64, mu_tol: f64, dv_tol: f64) {
    let (mut sa, mut sb) = (Scratch::new(a), Scratch::new(b));
    let g = a.grades().len();
    assert_eq!(g, b.grades().len());
    let (mut oa, mut ob) = (vec![Outcome::default(); g], vec![Outcome::default(); g]);
    for k in 0..n {
        run_trial(a, k, &mut sa, &mut oa);
        run_trial(b, k, &mut sb, &mut ob);
        for (gi, (x, y)) in oa.iter().zip(&ob).enumerate() {
            let at = format!("trial {k} grade {gi}");
            assert_eq!(x.mu0, y.mu0, "{at}: the same machine");
            assert_eq!((x.failure, x.rank), (y.failure, y.rank), "{at}");
            assert!(
                x.mu.is_finite() && (x.mu - y.mu).abs() < mu_tol,
                "{at}: μ {} vs {}",
                x.mu,
                y.mu
            );
            for (u, v) in [
                (x.dv_before_max, y.dv_before_max),
                (x.dv_after_max, y.dv_after_max),
                (x.dv_after_mean, y.dv_after_mean),
                (x.ap_after_max, y.ap_after_max),
            ] {
                match a.volumetric() {
                    true => assert!(
                        u.is_finite() && (u - v).abs() < dv_tol,
                        "{at}: dV {u} vs {v}"
                    ),
                    false => assert!(u.is_nan() && v.is_nan(), "{at}: dV {u} vs {v}"),
                }
            }
        }
    }
}

/// The paper's study with the workspace judged to first order (white
/// noise, OLS and WLS at two encoder grades), then by exact kinematics.
#[test]
fn the_tricept_through_any_kinematic_topologys_study_calibrates_alike() {
    let cfg = Config::paper().unwrap();
    for exact in [false, true] {
        let mut study = cfg
            .study()
            .errors(ErrorDraw::Random)
            .encoder_arcsec(&[1.0, 8.0])
            .methods(&[crate::identify::Method::Ols, crate::identify::Method::Wls])
            .trials(4)
            .build()
            .unwrap();
        study.sweep.volumetric_step_mm = Some(100.0);
        study.sweep.volumetric_exact = exact;
        let tricept = TriceptContext::new(&cfg, &study).unwrap();
        assert!(tricept.volumetric());
        let generic = through_kinematic(&cfg, &study, &tricept);
        // Forward kinematics closes to 1e-11 from either start, so the
        // estimates differ by parts in 1e10 (μ by at most 2.7e-10 mm in
        // these trials) and dV after compensation with them by at most
        // 2.5e-9 mm, the central differences' sensitivities included.
        agree(&tricept, &generic, 4, 1e-9, 1e-8);
    }
}

/// Gauss–Newton: each grade identified from its noisy readings by
/// iterating over its own pose set, through either.
#[test]
fn gauss_newton_through_any_kinematic_topology_reaches_the_tricepts_estimates() {
    let cfg = Config::paper().unwrap();
    let study = cfg
        .study()
        .errors(ErrorDraw::Random)
        .encoder_arcsec(&[2.0])
        .iterations(10)
        .trials(3)
        .build()
        .unwrap();
    let tricept = TriceptContext::new(&cfg, &study).unwrap();
    let generic = through_kinematic(&cfg, &study, &tricept);
    agree(&tricept, &generic, 3, 1e-9, 1e-9);
}

/// A study's parts are checked before the kernel builds on them: second-
/// class unknowns a mechanism has none of, and a pose subset the parts
/// disagree on, are refused in a sentence.
#[test]
fn parts_that_disagree_are_refused() {
    let cfg = Config::paper().unwrap();
    let mut study = cfg.study().trials(1).build().unwrap();
    let tricept = TriceptContext::new(&cfg, &study).unwrap();
    study.identification.second_class = true;
    let refused = |study: &ConfigStudy, subsets: Vec<crate::montecarlo::context::PoseSubset>| {
        let (mech, grids) = KinematicStudy::<Tricept, N_PARAMS, N_READINGS>::new(
            &cfg.geometry,
            &study.poses,
            &tricept.subsets,
            (&[], &[]),
        )
        .unwrap();
        let table = grade_table(study, &tricept, &tricept.h, &mech);
        match SweepContext::assemble(Parts {
            mech,
            h: tricept.h.clone(),
            h_second: None,
            subsets,
            table,
            assumed: tricept.assumed.clone(),
            sensors: tricept.sensors.clone(),
            products: None,
            options: study.identification,
            gls_per_machine: None,
            draw: ErrorDraw::Random,
            fixed_errors: cfg.errors,
            bound_mm: 0.5,
            seed: 1,
            perfect: [false; N_READINGS],
            grids,
            orientation: Default::default(),
            exact: false,
        }) {
            Ok(_) => String::new(),
            Err(why) => why,
        }
    };
    let why = refused(&study, tricept.subsets.clone());
    assert!(why.contains("no second-class unknowns"), "{why}");
    study.identification.second_class = false;
    assert_eq!(refused(&study, tricept.subsets.clone()), "");
    let n = study.poses.len();
    let short = vec![crate::montecarlo::context::PoseSubset::new(n, n, 2)];
    let why = refused(&study, short);
    assert!(
        why.starts_with("a study's parts disagree: pose subset 0"),
        "{why}"
    );
}
