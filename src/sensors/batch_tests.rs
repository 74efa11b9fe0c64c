use super::*;
use crate::mechanism::tricept::N_READINGS;
use crate::sensors::structured::MAX_HARMONICS;
use crate::sensors::ARCSEC_PER_RAD;
use nalgebra::{SVector, Vector3};
use rand::{RngExt, SeedableRng};

fn axis(accuracy: f64, harmonics: &[f64], period: f64) -> Axis {
    let mut h = [0.0; MAX_HARMONICS];
    h[..harmonics.len()].copy_from_slice(harmonics);
    Axis {
        accuracy,
        harmonics: h,
        n_harmonics: harmonics.len(),
        period,
        interpolation: 0.0,
        signal_period: 0.0,
        noise: 0.0,
        resolution: 0.0,
        readheads: 1,
        ..Axis::default()
    }
}

/// Encoders and scale of the example catalogue's ±2″ and ±0.5 µm
/// classes (jitter, interpolation and quantisation all present).
fn catalogue_like() -> Structured<N_READINGS> {
    let r = 1.0 / ARCSEC_PER_RAD;
    let mut enc = axis(2.0 * r, &[0.7, 0.3], std::f64::consts::TAU);
    enc.interpolation = 0.36 * r;
    enc.signal_period = 72.0 * r;
    enc.noise = 0.02 * r;
    enc.resolution = 0.0176 * r;
    let mut scale = axis(0.5e-3, &[0.8, 0.15, 0.0, 0.05], 400.0);
    scale.interpolation = 0.04e-3;
    scale.signal_period = 4e-3;
    scale.noise = 0.003e-3;
    scale.resolution = 1e-6;
    Structured {
        axes: [enc, enc, scale],
        from_section: [true; 3],
    }
}

fn joints(n: usize, rng: &mut impl Rng) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|_| {
            Vector3::new(
                rng.random_range(-0.6..0.6),
                rng.random_range(-0.6..0.6),
                rng.random_range(450.0..850.0),
            )
        })
        .collect()
}

/// The reference: each pose read by [`Structured::reading`] from the
/// same stream, homed rows e_j − e_0.
fn reference<const R: usize>(
    st: &Structured<R>,
    samples: u32,
    seed: u64,
    actual: &[SVector<f64, R>],
) -> Vec<f64> {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
    let (ph, jitter) = st.machine(&mut rng, samples, actual.len());
    let e: Vec<SVector<f64, R>> = actual
        .iter()
        .enumerate()
        .map(|(j, a)| st.reading(&ph, a, samples, &jitter, j) - a)
        .collect();
    let mut out = vec![0.0; R * (actual.len() - 1)];
    for j in 1..actual.len() {
        for k in 0..R {
            out[R * (j - 1) + k] = e[j][k] - e[0][k];
        }
    }
    out
}

/// Four slots, a scale first and last and two encoders between (no
/// slot where the Tricept has its own): the kernel reads each slot with its
/// own axis, row R(j−1)+k, as the reference does; a slot left out keeps
/// its rows.
#[test]
fn the_kernel_reads_any_slot_layout_as_the_reference() {
    let three = catalogue_like();
    let (enc, scale) = (three.axes[0], three.axes[2]);
    let mut other = enc;
    other.harmonics[0] *= 0.5;
    let mut far = scale;
    far.harmonics[0] *= 3.0;
    far.period *= 0.5;
    let st = Structured::<4> {
        axes: [scale, enc, other, far],
        from_section: [true; 4],
    };
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(21);
    let mut d = MachineDraws::<4>::default();
    let mut worst = [0.0f64; 4];
    for trial in 0..40u64 {
        let samples = 1 + (trial % 3) as u32;
        let actual: Vec<SVector<f64, 4>> = (0..9)
            .map(|_| {
                SVector::<f64, 4>::new(
                    rng.random_range(450.0..850.0),
                    rng.random_range(-0.6..0.6),
                    rng.random_range(-0.6..0.6),
                    rng.random_range(100.0..300.0),
                )
            })
            .collect();
        // Every other trial anchored at nominal readings near the true ones.
        if trial % 2 == 0 {
            let shift = SVector::<f64, 4>::new(2e-4, 2e-3, -3e-3, -1e-4);
            let nominal: Vec<_> = actual.iter().map(|a| a + shift).collect();
            d.anchor_at(&nominal);
        } else {
            d.anchor_at(&[]);
        }
        d.draw(
            &st,
            samples,
            &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(trial),
            &actual,
        );
        let mut got = vec![7.0; 4 * 8];
        d.homed_errors(&st, samples, [true, true, false, true], &mut got);
        let want = reference(&st, samples, trial, &actual);
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            match r % 4 {
                2 => assert_eq!(*g, 7.0, "slot 2 was not asked for"),
                k => worst[k] = worst[k].max((g - w).abs()),
            }
        }
        // Every slot read has errors (±2″ encoders, ±0.5 µm scales).
        for k in [0, 1, 3] {
            assert!(want.iter().skip(k).step_by(4).any(|e| e.abs() > 1e-8));
        }
    }
    assert!(worst[1] < 1e-15, "{worst:?}");
    assert!(worst[0] < 1e-12 && worst[3] < 1e-12, "{worst:?}");
}

#[test]
fn the_kernel_reads_what_the_reference_reads() {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(9);
    let mut d = MachineDraws::default();
    let mut worst = [0.0f64; 3];
    for trial in 0..200u64 {
        let mut st = catalogue_like();
        // Vary what is present: no jitter, no quantisation, both.
        match trial % 4 {
            1 => st.axes.iter_mut().for_each(|a| a.resolution = 0.0),
            2 => st.axes.iter_mut().for_each(|a| a.noise = 0.0),
            3 => st.axes[1].interpolation = 0.0,
            _ => {}
        }
        let samples = 1 + (trial % 3) as u32;
        let actual = joints(12, &mut rng);
        // Every other trial anchored at nominal joints near the true
        // ones (the scale's within 0.2 µm), the last pose far off
        // (1 rad and 150 mm: there the series would be wrong by far more
        // than the tolerance, so it must be the full sine).
        if trial % 2 == 0 {
            let mut nominal: Vec<Vector3<f64>> = actual
                .iter()
                .map(|a| a + Vector3::new(2e-3, -3e-3, 2e-4))
                .collect();
            nominal[11] += Vector3::new(1.0, 0.0, 150.0);
            d.anchor_at(&nominal);
        } else {
            d.anchor_at(&[]);
        }
        d.draw(
            &st,
            samples,
            &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(trial),
            &actual,
        );
        let mut got = vec![0.0; 33];
        d.homed_errors(&st, samples, [true; 3], &mut got);
        let want = reference(&st, samples, trial, &actual);
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            worst[r % 3] = worst[r % 3].max((g - w).abs());
        }
    }
    // Encoders to 1e-15 rad; the scale to 1e-12 mm (a reading of
    // 650 mm rounds at 1e-13 mm before the truth is taken off).
    assert!(worst[0] < 1e-15 && worst[1] < 1e-15, "{worst:?}");
    assert!(worst[2] < 1e-12, "{worst:?}");
}

/// One machine's draws read by sets that differ in resolution, jitter,
/// interpolation or accuracy, one after another and back: each set's
/// errors are the reference's (the per-axis units are formed again when
/// what they depend on changes, and only then).
#[test]
fn sets_alike_in_draws_but_not_in_units_read_as_the_reference() {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(5);
    let actual = joints(10, &mut rng);
    let a = catalogue_like();
    let mut sets = vec![a];
    for change in 0..4 {
        let mut b = a;
        for ax in &mut b.axes {
            match change {
                0 => ax.resolution *= 2.5,
                1 => ax.noise *= 3.0,
                2 => ax.interpolation *= 0.5,
                _ => ax.accuracy *= 4.0,
            }
        }
        assert!(draws_alike(&a, &b));
        sets.extend([b, a]);
    }
    let mut d = MachineDraws::default();
    let stream = || rand::rngs::Xoshiro256PlusPlus::seed_from_u64(31);
    for st in &sets {
        d.prepare(0, st, 3, &actual, stream);
        let mut got = vec![0.0; 27];
        d.homed_errors(st, 3, [true; 3], &mut got);
        let want = reference(st, 3, 31, &actual);
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            let tol = if r % 3 == 2 { 1e-12 } else { 1e-15 };
            assert!((g - w).abs() < tol, "row {r}: {g:e} vs {w:e}");
        }
    }
    // Only the axes asked for are written.
    let mut rows = vec![7.0; 27];
    d.homed_errors(&a, 3, [false, true, false], &mut rows);
    assert!(rows.iter().skip(1).step_by(3).all(|&x| x != 7.0));
    assert!(rows
        .iter()
        .enumerate()
        .all(|(r, &x)| (r % 3 == 1) != (x == 7.0)));
}

/// Anchored draws for sets whose curve periods alternate (a catalogue's
/// scales of different lengths): each period's anchors are computed once
/// and found again, and every reading is the reference's.
#[test]
fn anchors_of_alternating_periods_read_as_the_reference() {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(8);
    let actual = joints(7, &mut rng);
    let nominal: Vec<Vector3<f64>> = actual
        .iter()
        .map(|a| a + Vector3::new(1e-3, 2e-3, 1e-4))
        .collect();
    let mut d = MachineDraws::default();
    d.anchor_at(&nominal);
    let a = catalogue_like();
    let mut b = a;
    b.axes[2].period = 300.0;
    for (round, st) in [a, b, a, b].iter().enumerate() {
        let seed = 40 + round as u64;
        d.draw(
            st,
            2,
            &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed),
            &actual,
        );
        let mut got = vec![0.0; 18];
        d.homed_errors(st, 2, [true; 3], &mut got);
        let want = reference(st, 2, seed, &actual);
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            let tol = if r % 3 == 2 { 1e-12 } else { 1e-15 };
            assert!((g - w).abs() < tol, "round {round} row {r}: {g:e} vs {w:e}");
        }
    }
    assert_eq!(d.anchors[2].len(), 2);
    assert_eq!(d.anchors[0].len(), 1);
}

#[test]
fn unquantised_errors_are_the_sum_of_their_parts() {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(21);
    let mut st = catalogue_like();
    st.axes.iter_mut().for_each(|a| a.resolution = 0.0);
    st.axes[1].noise = 0.0;
    let actual = joints(9, &mut rng);
    let mut d = MachineDraws::default();
    d.draw(&st, 3, &mut rng, &actual);
    let m = 24;
    let (mut h, mut s, mut z) = (vec![1.0; m], vec![1.0; m], vec![1.0; m]);
    d.linear_parts([&mut h, &mut s, &mut z]);
    for grade in [0.5, 2.0, 7.0] {
        let g = st.at_grades(grade / ARCSEC_PER_RAD, grade * 1e-3);
        let mut e = vec![0.0; m];
        d.homed_errors(&g, 3, [true; 3], &mut e);
        for r in 0..m {
            let [a, i, n] = g.axes[r % 3].linear_amplitudes(3);
            let want = a * h[r] + i * s[r] + n * z[r];
            assert!((e[r] - want).abs() < 1e-18 + 1e-14 * want.abs(), "{r}");
        }
    }
    // The θ4 encoder has no jitter: its z rows are zero.
    assert!(z.iter().skip(1).step_by(3).all(|&x| x == 0.0));
}

#[test]
fn grades_that_draw_alike_share_the_draws() {
    let a = catalogue_like();
    let mut b = a.at_grades(5.0 / ARCSEC_PER_RAD, 2e-3);
    assert!(draws_alike(&a, &b));
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let actual = joints(6, &mut rng);
    let mut d = MachineDraws::default();
    let stream = || rand::rngs::Xoshiro256PlusPlus::seed_from_u64(77);
    d.prepare(0, &a, 3, &actual, stream);
    // Kept for b, of a's class: b's errors are the reference's from the
    // same stream.
    let mut calls = 0;
    d.prepare(0, &b, 3, &actual, || {
        calls += 1;
        stream()
    });
    assert_eq!(calls, 0);
    let mut got = vec![0.0; 15];
    d.homed_errors(&b, 3, [true; 3], &mut got);
    let want = reference(&b, 3, 77, &actual);
    let diff = got
        .iter()
        .zip(&want)
        .map(|(g, w)| (g - w).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-12, "{diff:e}");
    // Another shape, or other samples, draws afresh.
    b.axes[0].harmonics[0] = 0.5;
    assert!(!draws_alike(&a, &b));
    d.prepare(1, &b, 3, &actual, || {
        calls += 1;
        stream()
    });
    d.prepare(2, &b, 2, &actual, || {
        calls += 1;
        stream()
    });
    assert_eq!(calls, 2);
    let mut c = a;
    c.axes[2].noise = 0.0;
    assert!(!draws_alike(&a, &c));
}

/// Unknown shapes (Dirichlet fractions per machine), eccentricity and two
/// readheads: the kernel, which folds the eccentricity into the first
/// harmonic's phasor and drops the odd orders of a pair, reads what the
/// reference reads by evaluating each head's ring curve straight from the
/// formula.
#[test]
fn unknown_shapes_eccentricity_and_two_heads_read_as_the_reference() {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(21);
    let mut d = MachineDraws::default();
    let mut worst = [0.0f64; 3];
    let r = 1.0 / ARCSEC_PER_RAD;
    for trial in 0..240u64 {
        let mut st = catalogue_like();
        let k = 1 + (trial % 9) as usize * 3 % 32;
        for a in st.axes.iter_mut() {
            a.shape = crate::sensors::structured::Shape::Unknown;
            a.n_harmonics = k.min(32);
        }
        match trial % 4 {
            0 => st.axes[0].eccentricity = 1.5 * r,
            1 => st.axes[1].readheads = 2,
            2 => {
                st.axes[0].readheads = 2;
                st.axes[1].eccentricity = 0.7 * r;
                st.axes.iter_mut().for_each(|a| a.resolution = 0.0);
            }
            _ => {
                // A listed shape with eccentricity and no harmonic at all.
                st.axes[0].shape = crate::sensors::structured::Shape::Listed;
                st.axes[0].n_harmonics = 0;
                st.axes[0].eccentricity = 3.0 * r;
            }
        }
        let samples = 1 + (trial % 3) as u32;
        let actual = joints(12, &mut rng);
        if trial % 2 == 0 {
            let nominal: Vec<Vector3<f64>> = actual
                .iter()
                .map(|a| a + Vector3::new(2e-3, -3e-3, 2e-4))
                .collect();
            d.anchor_at(&nominal);
        } else {
            d.anchor_at(&[]);
        }
        d.draw(
            &st,
            samples,
            &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(trial),
            &actual,
        );
        let mut got = vec![0.0; 33];
        d.homed_errors(&st, samples, [true; 3], &mut got);
        let want = reference(&st, samples, trial, &actual);
        for (r, (g, w)) in got.iter().zip(&want).enumerate() {
            worst[r % 3] = worst[r % 3].max((g - w).abs());
        }
    }
    assert!(worst[0] < 1e-14 && worst[1] < 1e-14, "{worst:?}");
    assert!(worst[2] < 1e-12, "{worst:?}");
}
