use super::{
    convention_rank, held_out, identifiability, identify, predict, predicted_accuracy, Holds,
};
use crate::mechanism::hexapod::convention::basis;
use crate::mechanism::hexapod::design::design;
use crate::mechanism::hexapod::tests::{random_errors, targets};
use crate::mechanism::hexapod::*;
use nalgebra::{DMatrix, DVector};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;

/// The 54 errors of an identification's vector.
fn arr(e: &[f64]) -> Errors {
    e.try_into().unwrap()
}

/// Rank 45 of 54 with both encoders and 39 of 48 with one; the convention
/// leaves a design of full rank in its free directions.
#[test]
fn nine_combinations_are_invisible_and_the_convention_fixes_them() {
    let poses = targets(7, 30);
    for (enc, rank, of) in [
        (Encoders::Both, 45, 54),
        (Encoders::First, 39, 48),
        (Encoders::Second, 39, 48),
    ] {
        let hex = Hexapod {
            encoders: enc,
            ..Hexapod::example()
        };
        let a = identifiability(&hex, &poses, 1e-9).unwrap();
        assert_eq!((a.rank, a.parameters), (rank, of), "{enc:?}");
        assert_eq!(
            convention_rank(&hex, &poses, 1e-9, &Holds::default()).unwrap(),
            (rank, rank)
        );
    }
    // Four poses are enough with both encoders.
    let a = identifiability(&Hexapod::example(), &targets(8, 4), 1e-9).unwrap();
    assert_eq!(a.rank, 45);
}

/// Gauss–Newton from readings of a machine with errors identifies a
/// machine that predicts fresh readings at other poses to rounding (the
/// invisible combinations change no reading), far better than one
/// linearisation, ours (in the convention's directions) or an independent
/// one-step least squares (the pseudo-inverse of the whole design); and
/// from a machine that obeys the convention it recovers every error.
#[test]
fn identification_predicts_fresh_readings() {
    let hex = Hexapod::example();
    let poses = targets(12, 30);
    let fresh = targets(13, 20);
    let truth = random_errors(11, 0.5, 0.05);
    let measured = predict(&hex, &truth, &poses).unwrap();
    let want = predict(&hex, &truth, &fresh).unwrap();
    let gn = identify(&hex, &poses, &measured, 20, &[], &Holds::default()).unwrap();
    assert!(gn.residual_rms < 1e-9, "{}", gn.residual_rms);
    let miss = |e: &[f64]| (predict(&hex, e, &fresh).unwrap() - &want).amax();
    assert!(miss(&gn.errors[..]) < 1e-9, "{}", miss(&gn.errors[..]));
    let one = identify(&hex, &poses, &measured, 1, &[], &Holds::default()).unwrap();
    let h = design(&hex, &[0.0; N_ERRORS], &poses).unwrap();
    let l = &measured - predict(&hex, &[0.0; N_ERRORS], &poses).unwrap();
    let x = h.pseudo_inverse(1e-10).unwrap() * &l;
    let mut min_norm = [0.0; N_ERRORS];
    min_norm.copy_from_slice(x.as_slice());
    for (name, e) in [
        ("one step", one.errors.clone()),
        ("pseudo-inverse", min_norm.to_vec()),
    ] {
        // One linearisation of ±0.5 mm errors misses by second-order terms.
        assert!(
            miss(&e[..]) > 1e-4 && miss(&e[..]) < 0.1,
            "{name}: {}",
            miss(&e[..])
        );
        assert!(miss(&gn.errors[..]) < 1e-5 * miss(&e[..]));
    }
    // A machine that obeys the convention: its errors come back.
    let n = crate::mechanism::hexapod::convention::basis(&hex);
    let y = nalgebra::DVector::from_fn(n.ncols(), |c, _| 0.3 * ((c as f64) * 1.7).sin());
    let mut obeys = [0.0; N_ERRORS];
    obeys.copy_from_slice((&n * y).as_slice());
    let measured = predict(&hex, &obeys, &poses).unwrap();
    let back = identify(&hex, &poses, &measured, 20, &[], &Holds::default()).unwrap();
    for j in 0..N_ERRORS {
        assert!((back.errors[j] - obeys[j]).abs() < 1e-8, "{j}");
    }
}

/// The stated σ holds: over 300 logs of one machine with white reading
/// noise of 1″, each free error's spread is its stated σ to ±12 %, and
/// with the σ left to the residuals the statement is the same to ±10 %.
#[test]
fn the_stated_uncertainty_is_the_spread() {
    use rand_distr::{Distribution, Normal};
    let hex = Hexapod::example();
    let poses = targets(21, 30);
    let truth = random_errors(22, 0.3, 0.03);
    let exact = predict(&hex, &truth, &poses).unwrap();
    let sigma = 1.0 / 3600.0;
    let normal = Normal::new(0.0, sigma).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(23);
    let logs = 300;
    let mut sum = [0.0; N_ERRORS];
    let mut sq = [0.0; N_ERRORS];
    let mut stated = [0.0; N_ERRORS];
    let mut from_residuals = [0.0; N_ERRORS];
    for _ in 0..logs {
        let noisy = exact.map(|x| x + normal.sample(&mut rng));
        let id = identify(&hex, &poses, &noisy, 5, &[sigma], &Holds::default()).unwrap();
        let own = identify(&hex, &poses, &noisy, 5, &[], &Holds::default()).unwrap();
        let (sd, sd_own) = (id.std(), own.std());
        for j in 0..N_ERRORS {
            sum[j] += id.errors[j];
            sq[j] += id.errors[j] * id.errors[j];
            stated[j] += sd[j] / logs as f64;
            from_residuals[j] += sd_own[j] / logs as f64;
        }
    }
    let n = logs as f64;
    let mut seen = 0;
    let mut range = (f64::INFINITY, 0.0f64);
    for j in (0..N_ERRORS).filter(|&j| stated[j] > 0.0) {
        seen += 1;
        let spread = ((sq[j] - sum[j] * sum[j] / n) / (n - 1.0)).sqrt();
        let r = spread / stated[j];
        range = (range.0.min(r), range.1.max(r));
        assert!(
            (0.88..=1.12).contains(&r),
            "error {j}: spread {spread} stated {}",
            stated[j]
        );
        assert!(
            (from_residuals[j] / stated[j] - 1.0).abs() < 0.1,
            "error {j}"
        );
    }
    eprintln!("spread / stated σ: {:.3}–{:.3}", range.0, range.1);
    assert_eq!(seen, 45);
}

/// Errors fixed at measured values are held, and the rest are what the
/// unconstrained fit finds (an independent route: a leg offset and an
/// encoder zero are the same in every frame, so the noise-free fit
/// recovers them and fixing them at their values changes nothing); a
/// wrong fixed value leaves readings no estimate explains. With noise, the
/// others' spread is their stated σ, at most the unconstrained σ.
#[test]
fn fixed_errors_are_held_and_the_rest_spread_as_stated() {
    use rand_distr::{Distribution, Normal};
    let hex = Hexapod::example();
    let poses = targets(31, 30);
    let truth = random_errors(32, 0.3, 0.03);
    let exact = predict(&hex, &truth, &poses).unwrap();
    let (dl3, dphi2) = (error_index(2, 6), error_index(1, 7));
    let holds = |d: f64| Holds {
        fixed: vec![(dl3, truth[dl3] + d), (dphi2, truth[dphi2])],
        ..Holds::default()
    };
    let free = identify(&hex, &poses, &exact, 20, &[], &Holds::default()).unwrap();
    let held = identify(&hex, &poses, &exact, 20, &[], &holds(0.0)).unwrap();
    assert!((free.errors[dl3] - truth[dl3]).abs() < 1e-9);
    assert_eq!(held.fixed, vec![dl3, dphi2]);
    assert_eq!(held.std()[dl3], 0.0);
    assert_eq!(held.std()[dphi2], 0.0);
    for j in 0..N_ERRORS {
        assert!((held.errors[j] - free.errors[j]).abs() < 1e-9, "error {j}");
    }
    assert!(held.residual_rms < 1e-10);
    let wrong = identify(&hex, &poses, &exact, 20, &[], &holds(0.05)).unwrap();
    assert_eq!(wrong.errors[dl3], truth[dl3] + 0.05);
    assert!(
        wrong.residual_rms > 1e-4,
        "a wrong fixed value is explained away: {}",
        wrong.residual_rms
    );

    let sigma = 1.0 / 3600.0;
    let normal = Normal::new(0.0, sigma).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(33);
    let logs = 200;
    let (mut sum, mut sq) = ([0.0; N_ERRORS], [0.0; N_ERRORS]);
    let noisy = |rng: &mut Xoshiro256PlusPlus| exact.map(|x| x + normal.sample(rng));
    let first = noisy(&mut rng);
    let stated = identify(&hex, &poses, &first, 5, &[sigma], &holds(0.0))
        .unwrap()
        .std();
    let unconstrained = identify(&hex, &poses, &first, 5, &[sigma], &Holds::default())
        .unwrap()
        .std();
    for _ in 0..logs {
        let id = identify(&hex, &poses, &noisy(&mut rng), 5, &[sigma], &holds(0.0)).unwrap();
        for j in 0..N_ERRORS {
            sum[j] += id.errors[j];
            sq[j] += id.errors[j] * id.errors[j];
        }
    }
    let n = logs as f64;
    let mut seen = 0;
    for j in (0..N_ERRORS).filter(|&j| stated[j] > 0.0) {
        seen += 1;
        let spread = ((sq[j] - sum[j] * sum[j] / n) / (n - 1.0)).sqrt();
        let r = spread / stated[j];
        assert!((0.85..=1.15).contains(&r), "error {j}: spread/stated {r}");
        assert!(stated[j] <= unconstrained[j] * (1.0 + 1e-9), "error {j}");
    }
    assert_eq!(seen, 43);
    assert!((sum[dl3] / n - truth[dl3]).abs() < 1e-15);
}

/// The prior's posterior holds: machines drawn from the prior N(0, σp²)
/// in the convention's free directions and read with noise at poses too
/// few to determine them well are identified with each error's spread
/// about the truth equal to its posterior σ (±15 %), centred (within 4
/// standard errors), and narrower than the prior; without the prior the
/// same logs spread wider.
#[test]
fn the_prior_posterior_is_the_spread_about_the_truth() {
    use rand_distr::{Distribution, Normal};
    let hex = Hexapod::example();
    let poses = targets(41, 5);
    let (sp_mm, sp_deg) = (0.2, 0.02);
    let holds = Holds {
        prior_std_mm: Some(sp_mm),
        prior_std_deg: Some(sp_deg),
        ..Holds::default()
    };
    let n = basis(&hex);
    let sigma = 20.0 / 3600.0;
    let noise = Normal::new(0.0, sigma).unwrap();
    let unit = Normal::new(0.0, 1.0).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(42);
    let trials = 300;
    let (mut sum, mut sq, mut stated) = ([0.0; N_ERRORS], [0.0; N_ERRORS], [0.0; N_ERRORS]);
    let mut sq_free = [0.0; N_ERRORS];
    for _ in 0..trials {
        let y = DVector::from_fn(n.ncols(), |c, _| {
            let j = (0..N_ERRORS).find(|&j| n[(j, c)] != 0.0).unwrap();
            unit.sample(&mut rng) * if is_angle(j) { sp_deg } else { sp_mm }
        });
        let e = &n * y;
        let truth: Errors = std::array::from_fn(|j| e[j]);
        let read = predict(&hex, &truth, &poses)
            .unwrap()
            .map(|x| x + noise.sample(&mut rng));
        let id = identify(&hex, &poses, &read, 10, &[sigma], &holds).unwrap();
        let plain = identify(&hex, &poses, &read, 10, &[sigma], &Holds::default()).unwrap();
        let sd = id.std();
        for j in 0..N_ERRORS {
            let d = id.errors[j] - truth[j];
            sum[j] += d;
            sq[j] += d * d;
            stated[j] += sd[j] * sd[j] / trials as f64;
            sq_free[j] += (plain.errors[j] - truth[j]).powi(2);
        }
    }
    let t = trials as f64;
    let mut seen = 0;
    let mut range = (f64::INFINITY, 0.0f64);
    for j in (0..N_ERRORS).filter(|&j| stated[j] > 0.0) {
        seen += 1;
        let rms = (sq[j] / t).sqrt();
        let post = stated[j].sqrt();
        let r = rms / post;
        range = (range.0.min(r), range.1.max(r));
        assert!(
            (0.85..=1.15).contains(&r),
            "error {j}: rms {rms} posterior σ {post}"
        );
        assert!(
            (sum[j] / t).abs() < 4.0 * rms / t.sqrt(),
            "error {j}: biased"
        );
        let sp = if is_angle(j) { sp_deg } else { sp_mm };
        assert!(post < sp, "error {j}: posterior {post} ≥ prior {sp}");
    }
    let wider = (0..N_ERRORS).filter(|&j| sq_free[j] > sq[j]).count();
    eprintln!(
        "rms / posterior σ: {:.3}–{:.3}; {wider} errors spread wider without the prior",
        range.0, range.1
    );
    assert_eq!(seen, 45);
    assert!(wider >= 40, "{wider}");
}

/// identify's predicted accuracy holds on the machine it describes: 200
/// logs (a new machine each, errors ±0.3 mm and ±0.03°, 2″ of noise) are
/// identified, and the compensated machine's largest position and
/// orientation errors over a workspace of 40 poses, by exact kinematics
/// (the identified machine's inverse kinematics, the true machine's
/// forward, both in the convention's frames), are within the predicted
/// 95th percentile in 95 % of them (89–99 %) and below the predicted
/// median in half (38–62 %).
#[test]
fn the_predicted_accuracy_covers_the_compensated_machine() {
    use crate::mechanism::hexapod::kinematics::rotation_angle;
    use rand_distr::{Distribution, Normal};
    let hex = Hexapod::example();
    let poses = targets(51, 30);
    let workspace = targets(52, 40);
    let tool = nalgebra::Vector3::new(0.0, 0.0, 100.0);
    let sigma = 2.0 / 3600.0;
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(53);
    let trials = 200;
    let (mut p95, mut p50) = ([0; 2], [0; 2]);
    for k in 0..trials {
        let truth = random_errors(1000 + k, 0.3, 0.03);
        let exact = predict(&hex, &truth, &poses).unwrap();
        let frames = identify(&hex, &poses, &exact, 30, &[], &Holds::default()).unwrap();
        let noisy = exact.map(|x| x + noise.sample(&mut rng));
        let id = identify(&hex, &poses, &noisy, 10, &[sigma], &Holds::default()).unwrap();
        let stated = predicted_accuracy(&hex, &id.covariance, &workspace, &tool).unwrap();
        let (real, model) = (
            hex.actual(&arr(&frames.errors)),
            hex.actual(&arr(&id.errors)),
        );
        let (mut pos, mut rot) = (0.0f64, 0.0f64);
        for target in &workspace {
            let q = hex.commands_of(&model, target);
            let reached = Hexapod::forward(&real, &q, target).unwrap();
            let miss = (reached.t + reached.r * tool) - (target.t + target.r * tool);
            pos = pos.max(miss.norm());
            let turn = rotation_angle(&(reached.r * target.r.transpose()));
            rot = rot.max(turn * crate::mechanism::ARCSEC_PER_RAD);
        }
        for (i, (actual, stat)) in [(pos, stated.worst[0].1), (rot, stated.worst[1].1)]
            .into_iter()
            .enumerate()
        {
            p95[i] += (actual <= stat[1]) as usize;
            p50[i] += (actual <= stat[0]) as usize;
        }
    }
    eprintln!("within the predicted p95: {p95:?} of {trials}; below the median: {p50:?}");
    for i in 0..2 {
        assert!(
            (178..=198).contains(&p95[i]),
            "{i}: {} of {trials} within p95",
            p95[i]
        );
        assert!(
            (76..=124).contains(&p50[i]),
            "{i}: {} of {trials} below the median",
            p50[i]
        );
    }
}

/// The held-out check's statistic is what it says: over 20 logs of
/// machines read with the noise their σ states, the RMS of the
/// standardised predictions of poses left out is 1 (±0.04: leaving the
/// fit's own uncertainty out of the prediction's spread makes it about
/// 1.08); with readings 3× noisier than stated it is about 3.
#[test]
fn held_out_predictions_spread_as_the_encoders_allow() {
    use rand_distr::{Distribution, Normal};
    let hex = Hexapod::example();
    let poses = targets(61, 30);
    let sigma = 1.0 / 3600.0;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(62);
    let mut rms = |noise: f64| -> f64 {
        let normal = Normal::new(0.0, noise).unwrap();
        let logs = 20;
        let mut sq = 0.0;
        for k in 0..logs {
            let truth = random_errors(2000 + k, 0.3, 0.03);
            let read = predict(&hex, &truth, &poses)
                .unwrap()
                .map(|x| x + normal.sample(&mut rng));
            let h = held_out(&hex, &poses, &read, 5, &[sigma], &Holds::default(), &[]).unwrap();
            assert_eq!((h.folds, h.folds_skipped, h.readings), (5, 0, 360));
            sq += h.rms_z * h.rms_z / logs as f64;
        }
        sq.sqrt()
    };
    let honest = rms(sigma);
    let noisy = rms(3.0 * sigma);
    eprintln!("held-out RMS z: {honest:.4} honest, {noisy:.3} with 3× the noise");
    assert!((honest - 1.0).abs() < 0.04, "{honest}");
    assert!((noisy / 3.0 - 1.0).abs() < 0.06, "{noisy}");
    assert!(held_out(
        &hex,
        &poses[..9],
        &predict(&hex, &[0.0; N_ERRORS], &poses[..9]).unwrap(),
        5,
        &[sigma],
        &Holds::default(),
        &[]
    )
    .is_none());
}

/// A column of round-off beside columns of large norm (heavy weights, many
/// poses) is not scaled up into a fitted direction: the fit refuses it.
#[test]
fn a_column_of_round_off_is_refused_whatever_the_units() {
    let mut h = DMatrix::from_fn(30, 3, |i, j| {
        ((i * 7 + j * 3) % 11) as f64 * 1e4 + (j as f64)
    });
    // Round-off: 1e-13 of the largest column's norm (~3e5), well above
    // 1e-9 in absolute terms, so only a relative guard catches it.
    let largest = h.column(0).norm().max(h.column(1).norm());
    let unit = DVector::from_fn(30, |i, _| (i % 5) as f64 - 2.0).normalize();
    h.set_column(2, &(unit * 1e-13 * largest));
    let r = DVector::from_fn(30, |i, _| i as f64);
    let err = super::least_squares(&h, &r).unwrap_err();
    assert!(err.contains("rank 2 of 3"), "{err}");
    // The same column at a length's size is fitted.
    for i in 0..30 {
        h[(i, 2)] = (i % 5) as f64 - 2.0;
    }
    assert!(super::least_squares(&h, &r).is_ok());
}
