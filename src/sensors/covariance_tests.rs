//! Tests of the sensors' covariance ([`super`]): the kernel and its
//! homed form against draws, unknown curve shapes, and the envelope of an
//! assumed or stated coherence.

mod kernel {
    use super::super::*;
    use crate::mechanism::tricept::Joints;
    use crate::sensors::structured::{Phases, MAX_HARMONICS};
    use rand::{RngExt, SeedableRng};

    fn axis() -> Axis {
        let mut harmonics = [0.0; MAX_HARMONICS];
        harmonics[0] = 0.8;
        harmonics[1] = 0.2;
        Axis {
            accuracy: 2e-5,
            harmonics,
            n_harmonics: 2,
            period: std::f64::consts::TAU,
            interpolation: 3e-7,
            signal_period: 1e-3,
            noise: 1e-6,
            resolution: 2e-7,
            readheads: 1,
            ..Axis::default()
        }
    }

    /// The formula against the sample covariance of the model's own curves:
    /// many machines (random phases), the homed curve errors at three
    /// joint values, by a route that never writes the cosine sum.
    #[test]
    fn the_curve_covariance_is_the_curves_sample_covariance() {
        let mut a = axis();
        a.interpolation = 0.0;
        a.noise = 0.0;
        a.resolution = 0.0;
        let c = SensorCovariance::of_axis(&a, 3);
        let v = [0.1, -0.4, 0.45];
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let n = 200_000;
        let mut acc = [[0.0; 2]; 2];
        for _ in 0..n {
            let ph = Phases {
                harmonic: std::array::from_fn(|_| rng.random_range(0.0..std::f64::consts::TAU)),
                interpolation: 0.0,
                ..Phases::default()
            };
            let d = [
                a.systematic(&ph, v[1]) - a.systematic(&ph, v[0]),
                a.systematic(&ph, v[2]) - a.systematic(&ph, v[0]),
            ];
            for i in 0..2 {
                for j in 0..2 {
                    acc[i][j] += d[i] * d[j] / n as f64;
                }
            }
        }
        for i in 0..2 {
            for j in 0..2 {
                let want = c.homed(v[0], v[1 + i], v[1 + j], i == j)
                    - c.white * (1.0 + (i == j) as u8 as f64);
                // Sample covariance of 2·10⁵ draws: a few per mille.
                assert!(
                    (acc[i][j] - want).abs() < 0.02 * acc[0][0].abs().max(acc[1][1].abs()),
                    "({i},{j}): sample {} formula {want}",
                    acc[i][j]
                );
            }
        }
    }

    /// The white term: interpolation²/2 + (noise² + r²/12)/samples, floored
    /// at (10⁻³·a)²/samples; the paper's reading σ².
    #[test]
    fn the_white_term_and_its_floor() {
        let a = axis();
        let c = SensorCovariance::of_axis(&a, 4);
        let want = 3e-7f64.powi(2) / 2.0 + (1e-12 + 4e-14 / 12.0) / 4.0;
        assert!((c.white - want).abs() < 1e-12 * want, "{} {want}", c.white);
        let mut bare = a;
        bare.interpolation = 0.0;
        bare.noise = 0.0;
        bare.resolution = 0.0;
        let f = SensorCovariance::of_axis(&bare, 4);
        assert_eq!(f.white, (1e-3 * 2e-5f64).powi(2) / 4.0);
        assert!(f.is_positive());
        bare.accuracy = 0.0;
        assert!(!SensorCovariance::of_axis(&bare, 4).is_positive());
        assert_eq!(SensorCovariance::white(3.0).white, 9.0);
        // An interpolation amplitude without a signal period is no error
        // (the model reads none, Axis::shape_at).
        let mut no_period = a;
        no_period.signal_period = 0.0;
        let want = (1e-12 + 4e-14 / 12.0) / 4.0;
        let got = SensorCovariance::of_axis(&no_period, 4).white;
        assert!((got - want).abs() < 1e-12 * want, "{got} {want}");
    }

    /// The stated covariance keeps each reading's variance whatever the
    /// curve's width in signal periods (ω²σ_c² from 10⁻⁶ to 10⁴, where
    /// e^x overflows): the kernel's terms plus the white part sum to
    /// i²/2 + the jitter's; every number finite and the kernel's share ρ
    /// falling to nothing.
    #[test]
    fn the_stated_kernel_keeps_each_readings_variance() {
        for period in [1e-1, 1e-3, 1e-5, 1e-7] {
            let a = Axis {
                shape: crate::sensors::structured::Shape::Unknown,
                n_harmonics: 6,
                interpolation: 3e-7,
                signal_period: period,
                ..axis()
            };
            let plain = SensorCovariance::of_axis(&a, 4);
            let stated = SensorCovariance::stated_of_axis(&a, 4);
            let var = |c: &SensorCovariance| c.terms().iter().map(|t| t.0).sum::<f64>() + c.white;
            assert!(stated.white.is_finite() && stated.terms().iter().all(|t| t.0.is_finite()));
            assert!(
                (var(&stated) - var(&plain)).abs() < 1e-9 * var(&plain),
                "P = {period}: {} vs {}",
                var(&stated),
                var(&plain)
            );
            // 1 + 2·6 more terms than the curve's 6.
            assert_eq!(stated.terms().len(), plain.terms().len() + 13);
        }
        // A curve many periods wide: the kernel is white.
        let wide = Axis {
            interpolation: 3e-7,
            signal_period: 1e-9,
            ..axis()
        };
        let s = SensorCovariance::stated_of_axis(&wide, 4);
        assert!(s.terms()[2].0 < 1e-300, "{:?}", s.terms()[2]);
    }

    /// Σ of white-noise sensors is σ²·(I + 11ᵀ) within each sensor (the
    /// reference reading is shared), zero across sensors.
    #[test]
    fn white_noise_shares_the_reference_reading() {
        let cov = [
            SensorCovariance::white(1.0),
            SensorCovariance::white(2.0),
            SensorCovariance::white(3.0),
        ];
        let joints: Vec<Joints> = (0..4)
            .map(|k| Joints {
                psi_rad: 0.1 * k as f64,
                theta_rad: -0.05 * k as f64,
                q4_mm: 700.0 + k as f64,
            })
            .collect();
        let s = observation_covariance(&cov, &joints);
        assert_eq!(s.shape(), (9, 9));
        for r in 0..9 {
            for c in 0..9 {
                let want = if r % 3 != c % 3 {
                    0.0
                } else {
                    let v = ((r % 3) + 1) as f64;
                    v * v * if r == c { 2.0 } else { 1.0 }
                };
                assert_eq!(s[(r, c)], want, "({r},{c})");
            }
        }
    }
}

mod shape_unknown {
    use super::super::*;
    use crate::sensors::structured::Shape;
    use rand::SeedableRng;

    /// An unknown shape of order K (Dirichlet fractions and phases drawn
    /// per machine by the model itself), with eccentricity or two heads:
    /// the sample covariance of its homed curve errors at three joint
    /// values is a²/(K(K+1))·Σ cos + E²/6·cos (odd orders and E gone for
    /// two heads), and its interpolation's variance i²/2 (i²/4 for two).
    #[test]
    fn the_unknown_shape_covariance_is_the_sample_covariance_of_its_draws() {
        for (k, ecc, heads) in [(6, 0.0, 1u8), (3, 0.8, 1), (5, 0.8, 2), (1, 0.0, 1)] {
            let a = Axis {
                accuracy: 2.0,
                shape: Shape::Unknown,
                n_harmonics: k,
                eccentricity: ecc,
                readheads: heads,
                period: std::f64::consts::TAU,
                interpolation: 0.3,
                signal_period: 0.01,
                ..Axis::default()
            };
            let c = SensorCovariance::of_axis(&a, 1);
            let v = [0.1, -0.4, 0.45];
            let mut rng = rand::rngs::StdRng::seed_from_u64(11);
            let n = 200_000;
            let mut acc = [[0.0; 2]; 2];
            let mut interp = 0.0;
            for _ in 0..n {
                let ph = a.phases(&mut rng);
                let curve = |x: f64| a.curve_scale() * a.shape_at(&ph, x).0;
                let d = [curve(v[1]) - curve(v[0]), curve(v[2]) - curve(v[0])];
                for i in 0..2 {
                    for j in 0..2 {
                        acc[i][j] += d[i] * d[j] / n as f64;
                    }
                }
                interp += (a.interpolation * a.shape_at(&ph, 0.123).1).powi(2) / n as f64;
            }
            // The formula written out independently of curve_terms.
            let kk = k as f64;
            let cf = |x: f64, y: f64| -> f64 {
                let mut s = 0.0;
                for o in 1..=k {
                    if heads == 2 && o % 2 == 1 {
                        continue;
                    }
                    s += 4.0 / (kk * (kk + 1.0)) * (o as f64 * (x - y)).cos();
                }
                if heads == 1 {
                    s += ecc * ecc / 6.0 * (x - y).cos();
                }
                s
            };
            for i in 0..2 {
                for j in 0..2 {
                    let (x, y) = (v[1 + i], v[1 + j]);
                    let want = cf(x, y) - cf(x, v[0]) - cf(v[0], y) + cf(v[0], v[0]);
                    let from_model =
                        c.homed(v[0], x, y, i == j) - c.white * (1.0 + (i == j) as u8 as f64);
                    assert!(
                        (from_model - want).abs() < 1e-12,
                        "K={k}: model {from_model} formula {want}"
                    );
                    let scale = acc[0][0].abs().max(acc[1][1].abs());
                    assert!(
                        (acc[i][j] - want).abs() < 0.02 * scale,
                        "K={k} e={ecc} heads={heads} ({i},{j}): sample {} formula {want}",
                        acc[i][j]
                    );
                }
            }
            let want_i = 0.09 / 2.0 / heads as f64;
            assert!((interp / want_i - 1.0).abs() < 0.02, "{interp} vs {want_i}");
            assert!((c.white - want_i.max(4e-6)).abs() < 1e-15);
            // The Dirichlet fractions sum to 1: the curve never exceeds ±a.
            let ph = a.phases(&mut rng);
            let sum: f64 = ph.fractions[..k].iter().sum();
            assert!((sum - 1.0).abs() < 1e-12);
        }
    }
}

mod envelope {
    use super::super::*;
    use crate::mechanism::tricept::Joints;
    use crate::sensors::factored::ObservationCovariance;
    use crate::sensors::structured::Shape;

    /// The assumed-coherence kernel built from its Fourier terms is
    /// (i²/2)·exp(−Δ²/(2ℓ²))·cos(ωΔ) between any two readings within the
    /// span (dense Σ of the factored form, entry by entry against the
    /// formula, homed differences included), for a coherence from a 40th
    /// of the span to more than the span.
    #[test]
    fn the_envelope_kernel_is_the_formula() {
        for (ell, period) in [(0.05, 7e-4), (0.01, 7e-4), (0.5, 1e-3), (2.0, 3e-3)] {
            let a = Axis {
                accuracy: 1e-9,
                shape: Shape::Unknown,
                n_harmonics: 1,
                period: std::f64::consts::TAU,
                interpolation: 7e-6,
                signal_period: period,
                noise: 1e-12,
                readheads: 1,
                weight_coherence: ell,
                ..Axis::default()
            };
            let c = SensorCovariance::of_axis(&a, 1);
            let (vi, omega, _) = c.envelope.unwrap();
            let vals: Vec<f64> = (0..40)
                .map(|k| -0.5 + 0.025 * k as f64 + 1e-4 * (k * k) as f64)
                .collect();
            let joints: Vec<Joints> = vals
                .iter()
                .map(|&v| Joints {
                    psi_rad: v,
                    theta_rad: 0.0,
                    q4_mm: 700.0,
                })
                .collect();
            let cov = [
                c,
                SensorCovariance::white(1.0),
                SensorCovariance::white(1.0),
            ];
            let dense = ObservationCovariance::new(&cov, &joints).dense();
            let k = |x: f64, y: f64| {
                let d = x - y;
                vi * (-d * d / (2.0 * ell * ell)).exp() * (omega * d).cos()
            };
            let v0 = vals[0];
            let mut worst = 0.0f64;
            for i in 1..vals.len() {
                for j in 1..vals.len() {
                    let want = k(vals[i], vals[j]) - k(vals[i], v0) - k(v0, vals[j]) + k(v0, v0)
                        // the white parts (jitter, and the shared reference's)
                        + cov[0].white * (1.0 + (i == j) as u8 as f64);
                    let got = dense[(3 * (i - 1), 3 * (j - 1))];
                    worst = worst.max((got - want).abs());
                    // `between`, entry by entry, homed: the same Σ as the
                    // factored form's Fourier series.
                    let b = |x: f64, y: f64, same: bool| c.between(x, y, same);
                    let homed =
                        b(vals[i], vals[j], i == j) - b(vals[i], v0, false) - b(v0, vals[j], false)
                            + b(v0, v0, true);
                    worst = worst.max((got - homed).abs());
                }
            }
            assert!(worst < 1e-6 * vi, "ℓ = {ell}: {worst} of {vi}");
        }
    }
}
