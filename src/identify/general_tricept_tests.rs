//! The Tricept as any mechanism ([`crate::mechanism::Homed`]: its 15
//! errors and its three readings' zeros) through the one identify.

use super::{identify, predict, predicted_accuracy, Holds};
use crate::identify::design_of;
use crate::mechanism::tricept::{Geometry, Machine, Tricept, N_PARAMS, N_READINGS};
use crate::mechanism::{Homed, Kinematic, Mechanism};
use nalgebra::{DMatrix, DVector, SVector, Vector3};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

type T = Homed<'static, Tricept, N_PARAMS, N_READINGS>;

fn tricept() -> T {
    let g: &'static Geometry = Box::leak(Box::new(Geometry::paper()));
    Homed::new(g)
}

/// dyA3, which no reading sees to first order at the nominal machine
/// (the Tricept's rank analysis leaves it out; here it is held at 0).
const UNSEEN: usize = 11;

fn truth() -> Vec<f64> {
    let mut e: Vec<f64> = (0..N_PARAMS)
        .map(|i| 0.3 * ((i as f64) * 0.9).cos())
        .collect();
    e[UNSEEN] = 0.0;
    e.extend([0.01, -0.02, 0.05]);
    e
}

fn holds() -> Holds {
    Holds {
        fixed: vec![(UNSEEN, 0.0)],
        ..Holds::default()
    }
}

/// Exact readings identify the machine and the readings' zeros, and
/// the fit's machine gives the Tricept's own forward kinematics.
#[test]
fn exact_readings_identify_the_tricept_and_its_zeros() {
    let m = tricept();
    let targets = crate::mechanism::tricept::poses::paper_targets();
    let e = truth();
    let read = predict(&m, &e, &targets).unwrap();
    // The readings are the Tricept's own forward kinematics, in degrees
    // and mm, each offset by its zero.
    let g = Geometry::paper();
    let machine = Tricept::machine(&g, &SVector::from_column_slice(&e[..N_PARAMS]));
    let nominal = Machine::nominal(&g);
    for (j, t) in targets.iter().enumerate() {
        let (q, guess) = Tricept::command(&nominal, t).unwrap();
        let x = Tricept::readings(&machine, &q, &guess).unwrap();
        assert!((read[3 * j] - (x[0].to_degrees() + e[15])).abs() < 1e-12);
        assert!((read[3 * j + 1] - (x[1].to_degrees() + e[16])).abs() < 1e-12);
        assert!((read[3 * j + 2] - (x[2] + e[17])).abs() < 1e-12);
    }
    let sigma = [5.0 / 3600.0, 5.0 / 3600.0, 2e-3];
    let id = identify(&m, &targets, &read, 20, &sigma, &holds()).unwrap();
    assert_eq!(m.error_names()[UNSEEN], "dyA3");
    // Free, it leaves the design rank-deficient, which identify refuses.
    let free = identify(&m, &targets, &read, 20, &sigma, &Holds::default());
    assert!(free.unwrap_err().contains("rank 17 of 18"));
    let miss = id
        .errors
        .iter()
        .zip(&e)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(miss < 1e-8, "{miss}");
    assert!(id.residual_rms < 1e-10);
    // A nominal machine is where its targets ask; sensitivities are its
    // forward kinematics differentiated (a step in dq1 moves the point).
    let x0 = Tricept::command(&nominal, &targets[3]).unwrap().1;
    assert!((Tricept::position(&nominal, &x0) - targets[3]).amax() < 1e-9);
    let s = m.sensitivity(&targets[3], &Vector3::zeros()).unwrap();
    let h = 1e-3;
    let mut d = [0.0; 18];
    d[12] = h;
    let moved = Tricept::machine(&g, &SVector::from_column_slice(&d[..N_PARAMS]));
    let (q, guess) = Tricept::command(&nominal, &targets[3]).unwrap();
    let x = Tricept::readings(&moved, &q, &guess).unwrap();
    let step = (Tricept::position(&moved, &x) - targets[3]) / h;
    assert!(
        (s.column(12) - step).amax() < 1e-4,
        "{} vs {step}",
        s.column(12)
    );
    assert!(s.columns(15, 3).amax() == 0.0);
}

/// With σ of 5″ on the encoders and 2 µm on the scale, the Tricept's 15
/// errors' covariance from the one identify (its readings' zeros free,
/// rows weighted by σ₀/σₖ) is that of generalised least squares on the
/// homed differences the Tricept's own identification reads (eq. 10:
/// every difference shares the reference pose's noise, Σ = (I + 11ᵀ) ⊗
/// diag σ²), built from the Tricept's fixed-size design; and estimates
/// from noisy readings spread as it states.
#[test]
fn the_tricepts_covariance_is_gls_on_its_homed_differences() {
    let m = tricept();
    let targets = crate::mechanism::tricept::poses::paper_targets();
    let sigma_model = [
        5.0 / crate::mechanism::ARCSEC_PER_RAD,
        5.0 / crate::mechanism::ARCSEC_PER_RAD,
        2e-3,
    ];
    let sigma = [5.0 / 3600.0, 5.0 / 3600.0, 2e-3];
    let e = truth();
    let exact = predict(&m, &e, &targets).unwrap();
    let id = identify(&m, &targets, &exact, 10, &sigma, &holds()).unwrap();
    // The independent route, at the identified machine.
    let g = Geometry::paper();
    let machine = Tricept::machine(&g, &SVector::from_column_slice(&e[..N_PARAMS]));
    let nominal = Machine::nominal(&g);
    let x: Vec<_> = targets
        .iter()
        .map(|t| {
            let (q, guess) = Tricept::command(&nominal, t).unwrap();
            Tricept::readings(&machine, &q, &guess).unwrap()
        })
        .collect();
    let seen: Vec<usize> = (0..N_PARAMS).filter(|&j| j != UNSEEN).collect();
    let h = design_of::<Tricept, N_PARAMS, N_READINGS>(&machine, &x)
        .unwrap()
        .select_columns(&seen);
    let n = targets.len() - 1;
    let sigma_of = |i: usize| sigma_model[i % 3];
    let cov_l = DMatrix::from_fn(3 * n, 3 * n, |a, b| {
        if a % 3 != b % 3 {
            0.0
        } else if a == b {
            2.0 * sigma_of(a).powi(2)
        } else {
            sigma_of(a).powi(2)
        }
    });
    let gls = (h.transpose() * cov_l.try_inverse().unwrap() * &h)
        .try_inverse()
        .unwrap();
    assert_eq!(id.covariance.row(UNSEEN).amax(), 0.0);
    for (ga, &a) in seen.iter().enumerate() {
        for (gb, &b) in seen.iter().enumerate() {
            let (got, want) = (id.covariance[(a, b)], gls[(ga, gb)]);
            let scale = (gls[(ga, ga)] * gls[(gb, gb)]).sqrt();
            assert!(
                (got - want).abs() < 1e-6 * scale,
                "({a}, {b}): {got:e} vs {want:e}"
            );
        }
    }
    // Estimates from noisy readings spread as stated (400 machines:
    // each variance within ±25 %, far outside a wrong weighting's).
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let trials = 400;
    let mut sq = [0.0; N_PARAMS];
    for _ in 0..trials {
        let noisy = DVector::from_fn(exact.len(), |i, _| {
            exact[i] + Normal::new(0.0, sigma[i % 3]).unwrap().sample(&mut rng)
        });
        let fit = identify(&m, &targets, &noisy, 3, &sigma, &holds()).unwrap();
        for j in 0..N_PARAMS {
            sq[j] += (fit.errors[j] - e[j]).powi(2) / trials as f64;
        }
    }
    for (g, &j) in seen.iter().enumerate() {
        let ratio = sq[j] / gls[(g, g)];
        assert!(
            (0.75..1.33).contains(&ratio),
            "{}: {ratio}",
            m.error_names()[j]
        );
    }
    // Poses left out are predicted as well as each reading's own σ
    // allows (the encoders' 5″ and the scale's 2 µm, weighted apart).
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
    let noisy = DVector::from_fn(exact.len(), |i, _| {
        exact[i] + Normal::new(0.0, sigma[i % 3]).unwrap().sample(&mut rng)
    });
    let h = super::held_out(&m, &targets, &noisy, 5, &sigma, &holds(), &[]).unwrap();
    assert!((0.8..1.2).contains(&h.rms_z), "held-out RMS z {}", h.rms_z);
    // Unstated, one σ cannot serve angles and a length: refused.
    let err = identify(&m, &targets, &noisy, 5, &[], &holds()).unwrap_err();
    assert!(err.contains("different units"), "{err}");
    // The predicted accuracy judges position alone, in mm.
    let a = predicted_accuracy(&m, &id.covariance, &targets, &Vector3::zeros()).unwrap();
    assert_eq!(a.worst.len(), 1);
    assert_eq!(a.worst[0].0.unit, "mm");
    assert!(a.of("position").unwrap()[1] > a.of("position").unwrap()[0]);
}
