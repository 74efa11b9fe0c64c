//! The checks' held-out variances against the dense route.

use super::*;
use crate::mechanism::tricept::Joints;
use crate::sensors::{observation_covariance, SensorCovariance};
use nalgebra::DMatrix;

/// The held-out variances through the factored Σ against the dense
/// route: A·Σ·Aᵀ with A the prediction error's map of every row and Σ
/// built entry by entry.
#[test]
fn held_out_variances_are_the_dense_sandwich() {
    // Datasheet encoders of unknown shape with eccentricity, a scale:
    // the curves correlate every pair of poses.
    let enc = crate::sensors::Axis {
        accuracy: 1e-5,
        shape: crate::sensors::structured::Shape::Unknown,
        n_harmonics: 4,
        eccentricity: 2e-6,
        period: std::f64::consts::TAU,
        interpolation: 2e-7,
        signal_period: 1e-3,
        readheads: 1,
        ..crate::sensors::Axis::default()
    };
    let scale = crate::sensors::Axis {
        accuracy: 3e-3,
        period: 400.0,
        interpolation: 1e-4,
        signal_period: 0.02,
        eccentricity: 0.0,
        ..enc
    };
    let cov = [
        SensorCovariance::of_axis(&enc, 3),
        SensorCovariance::of_axis(&enc, 3),
        SensorCovariance::of_axis(&scale, 3),
    ];
    assert!(!cov[0].terms().is_empty());
    let joints: Vec<Joints> = (0..12)
        .map(|k| Joints {
            psi_rad: 0.2 * (k as f64).sin(),
            theta_rad: 0.15 * (1.7 * k as f64).cos(),
            q4_mm: 700.0 + 30.0 * (0.9 * k as f64).sin(),
        })
        .collect();
    let f = ObservationCovariance::new(&cov, &joints);
    let dense = observation_covariance(&cov, &joints);
    let m = f.rows();
    let rh: Vec<usize> = (0..m).filter(|r| (r / 3) % 4 == 1).collect();
    let rk: Vec<usize> = (0..m).filter(|r| (r / 3) % 4 != 1).collect();
    let hh = DMatrix::from_fn(rh.len(), 15, |i, c| ((i * 5 + c * 11) as f64 * 0.13).cos());
    let op = DMatrix::from_fn(15, rk.len(), |a, c| ((a * 3 + c * 7) as f64 * 0.29).sin());
    let got = prediction_variances(&f, &hh, &op, &rh, &rk);
    let mut a = DMatrix::zeros(rh.len(), m);
    let g = -(&hh * &op);
    for (c, &r) in rk.iter().enumerate() {
        a.set_column(r, &g.column(c));
    }
    for (i, &r) in rh.iter().enumerate() {
        a[(i, r)] += 1.0;
    }
    let want = &a * &dense * a.transpose();
    for (i, v) in got.iter().enumerate() {
        assert!(
            (v - want[(i, i)]).abs() < 1e-9 * want[(i, i)].abs(),
            "{i}: {v} vs {}",
            want[(i, i)]
        );
    }
}
