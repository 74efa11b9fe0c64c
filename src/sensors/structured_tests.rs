use super::*;
use rand::SeedableRng;

fn axis() -> Axis {
    let mut harmonics = [0.0; MAX_HARMONICS];
    harmonics[0] = 0.8;
    harmonics[1] = 0.2;
    Axis {
        accuracy: 2.0,
        harmonics,
        n_harmonics: 2,
        period: std::f64::consts::TAU,
        interpolation: 0.3,
        signal_period: 0.01,
        noise: 0.0,
        resolution: 0.0,
        readheads: 1,
        ..Axis::default()
    }
}

#[test]
fn the_curve_stays_within_its_bound_and_phases_are_uniform() {
    let a = axis();
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let mut bins = [0usize; 8];
    let n = 4000;
    for _ in 0..n {
        let ph = a.phases(&mut rng);
        for k in 0..200 {
            let v = -0.6 + 1.2 * k as f64 / 200.0;
            // |e| ≤ a·Σh + i.
            assert!(a.systematic(&ph, v).abs() <= 2.0 * 1.0 + 0.3 + 1e-12);
        }
        bins[(ph.harmonic[0] / std::f64::consts::TAU * 8.0) as usize] += 1;
    }
    // Each eighth of [0, 2π) holds 1/8 of the phases (±5 σ of a binomial).
    let sd = (n as f64 * 0.125 * 0.875).sqrt();
    for b in bins {
        assert!((b as f64 - n as f64 / 8.0).abs() < 5.0 * sd, "{bins:?}");
    }
}

#[test]
fn the_curve_is_what_the_formula_says() {
    let a = axis();
    let ph = Phases {
        harmonic: std::array::from_fn(|k| [0.5, 1.0].get(k).copied().unwrap_or(0.0)),
        interpolation: 0.25,
        ..Phases::default()
    };
    let v = 0.3;
    let want = 2.0 * (0.8 * (v + 0.5f64).sin() + 0.2 * (2.0 * v + 1.0f64).sin())
        + 0.3 * (std::f64::consts::TAU * v / 0.01 + 0.25).sin();
    assert!((a.systematic(&ph, v) - want).abs() < 1e-12);
    // RMS over random phases: a·√(Σh²/2) and i/√2.
    let want_sigma = (4.0 * (0.64 + 0.04) / 2.0 + 0.09 / 2.0f64).sqrt();
    assert!((a.sigma(3) - want_sigma).abs() < 1e-12);
}

/// A machine's jitter is `StandardNormal`'s draws from its generator
/// after the phases, axis by axis, then sample by sample, then pose by
/// pose: a quantised axis takes a draw per sample, an unquantised one
/// one for the mean, one without jitter none.
#[test]
fn the_jitter_table_is_standard_normals_axis_then_sample_then_pose() {
    let mut st = Structured {
        axes: [axis(); 3],
        from_section: [true; 3],
    };
    st.axes[0].noise = 0.1;
    st.axes[0].resolution = 0.01;
    st.axes[1].noise = 0.1;
    let (samples, poses) = (3, 5);
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(8);
    let mut straight = rng.clone();
    let (ph, table) = st.machine(&mut rng, samples, poses);
    assert_eq!(ph, st.phases(&mut straight));
    for (k, draws) in [(0, 3), (1, 1)] {
        assert_eq!(table.axis(k).len(), draws * poses);
        for s in 0..draws {
            for j in 0..poses {
                let want: f64 = straight.sample(rand_distr::StandardNormal);
                assert_eq!(table.draw(k, s, j).to_bits(), want.to_bits());
            }
        }
    }
    assert!(table.axis(2).is_empty());
    // The generator is left where the last draw leaves it.
    assert_eq!(rng.next_u64(), straight.next_u64());
}

#[test]
fn samples_average_the_jitter_not_the_curve_and_quantise() {
    let mut a = axis();
    a.noise = 0.5;
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(2);
    let ph = a.phases(&mut rng);
    let v = 0.2;
    let e = a.systematic(&ph, v);
    let n = 20000;
    let (mut sum, mut sq) = (0.0, 0.0);
    for _ in 0..n {
        let z: [f64; 4] = std::array::from_fn(|_| rng.sample(rand_distr::StandardNormal));
        let r = a.reading(&ph, v, 4, |s| z[s]) - v - e;
        sum += r;
        sq += r * r;
    }
    let (mean, var) = (sum / n as f64, sq / n as f64 - (sum / n as f64).powi(2));
    // The curve is repeatable: the readings centre on v + e(v); the
    // jitter of a mean of 4 samples has σ = 0.5/2.
    assert!(mean.abs() < 5.0 * 0.25 / (n as f64).sqrt(), "{mean}");
    assert!((var.sqrt() / 0.25 - 1.0).abs() < 0.03, "{}", var.sqrt());
    // Quantised samples: one sample is a multiple of the resolution.
    a.noise = 0.0;
    a.resolution = 0.125;
    let r = a.reading(&ph, v, 1, |_| unreachable!("no jitter"));
    assert!(((r / 0.125) - (r / 0.125).round()).abs() < 1e-9);
    assert!((r - (v + e)).abs() <= 0.0625 + 1e-12);
}
