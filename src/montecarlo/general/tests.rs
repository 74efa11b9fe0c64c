use super::{draw_errors, Prepared};
use crate::config::hexapod::{Estimator, Sensor, Spec};
use crate::mechanism::hexapod::tests::targets;
use crate::mechanism::hexapod::*;
use crate::sensors::{Axis, ARCSEC_PER_RAD};
use nalgebra::{DVector, Vector3};

/// A study of one encoder of jitter σ `noise_arcsec` and no curve, on
/// `targets`, judged at `workspace`.
fn spec(noise_arcsec: f64, bound_mm: f64, estimators: Vec<Estimator>, trials: u64) -> Spec {
    Spec {
        sensors: vec![Sensor {
            name: "jitter".into(),
            price: Some(1.0),
            axis: Axis {
                noise: noise_arcsec / ARCSEC_PER_RAD,
                period: std::f64::consts::TAU,
                readheads: 1,
                ..Axis::default()
            },
            truth: None,
        }],
        variants: vec![Encoders::Both, Encoders::First],
        pose_counts: vec![30],
        estimators,
        trials,
        seed: 7,
        length_bound_mm: bound_mm,
        zero_bound_deg: bound_mm / 5.0,
        samples: 1,
        workspace: targets(9, 6),
        tool_mm: Vector3::new(10.0, -20.0, 150.0),
        iterations: 10,
        fixed: Vec::new(),
        prior_std_mm: None,
        prior_std_deg: None,
    }
}

/// Each coordinate's sample spread over `t` trials (sums `sum`, squares
/// `sq`) against its predicted variance `cov[(r, r)]`: every ratio within
/// 0.75–1.25 and their mean within 0.93–1.07 (what `label` says).
fn assert_spread_is_predicted(
    sum: &DVector<f64>,
    sq: &DVector<f64>,
    t: f64,
    cov: &nalgebra::DMatrix<f64>,
    label: &str,
) {
    let ratios: Vec<f64> = (0..sum.len())
        .map(|r| {
            let mean = sum[r] / t;
            ((sq[r] - t * mean * mean) / (t - 1.0) / cov[(r, r)]).sqrt()
        })
        .collect();
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let (lo, hi) = ratios
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &r| (a.min(r), b.max(r)));
    eprintln!("{label}: spread/predicted {lo:.3}–{hi:.3}, mean {mean:.3}");
    assert!(lo > 0.75 && hi < 1.25, "{label}: {ratios:?}");
    assert!((0.93..1.07).contains(&mean), "{label}: {mean}");
}

/// The study's judgement of a machine (each workspace pose's
/// sensitivity times what the estimate leaves) against compensation
/// itself: the identified model's inverse kinematics, the true
/// machine's forward kinematics, the tool point's distance from where
/// it was sent; within 2 % at errors of ±0.1 mm.
#[test]
fn the_study_judges_as_exact_compensation_does() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let s = spec(2.0, 0.1, vec![Estimator::Linear], 4);
    let p = Prepared::new(&hex, &poses, &s).unwrap();
    for k in 0..4 {
        let (machines, estimates) = p.estimates(k).unwrap();
        for (ci, c) in p.combinations.iter().enumerate() {
            let vi = usize::from(c.variant != Encoders::Both);
            let (e, est) = (&machines[vi], &estimates[ci]);
            let truth = hex.actual(&std::array::from_fn(|j| e[j]));
            let model = hex.actual(&std::array::from_fn(|j| est[j]));
            let mut worst = (0.0f64, 0.0f64);
            for w in &s.workspace {
                let reached = Hexapod::forward(&truth, &hex.commands_of(&model, w), w).unwrap();
                let d = (reached.t + reached.r * s.tool_mm) - (w.t + w.r * s.tool_mm);
                let o = kinematics::rotation_angle(&(reached.r * w.r.transpose())) * ARCSEC_PER_RAD;
                worst = (worst.0.max(d.norm()), worst.1.max(o));
            }
            let judged = p.judge(&(e - est));
            assert!(worst.0 > 1e-4, "{worst:?}");
            assert!(
                (judged.0 - worst.0).abs() < 0.02 * worst.0
                    && (judged.1 - worst.1).abs() < 0.02 * worst.1,
                "trial {k} {c:?}: judged {judged:?}, exact {worst:?}"
            );
            // Before compensation: the nominal commands.
            let mut before = 0.0f64;
            for w in &s.workspace {
                let reached = Hexapod::forward(&truth, &hex.commands(w), w).unwrap();
                let d = (reached.t + reached.r * s.tool_mm) - (w.t + w.r * s.tool_mm);
                before = before.max(d.norm());
            }
            let jb = p.judge(e).0;
            assert!((jb - before).abs() < 0.02 * before, "{jb} {before}");
        }
    }
}

/// Over 400 machines read with white jitter, each free error's spread
/// is σ²·(AᵀA)⁻¹ of the design A in the convention's directions (normal
/// equations: an independent route from the study's pseudo-inverse),
/// within the sampling error of 400 (each ratio 0.75–1.25, their mean
/// 0.93–1.07).
#[test]
fn the_study_spread_is_its_predicted_covariance() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let trials = 400;
    let sigma_arcsec = 2.0;
    let s = spec(sigma_arcsec, 0.01, vec![Estimator::Linear], trials);
    let p = Prepared::new(&hex, &poses, &s).unwrap();
    for (ci, c) in p.combinations.iter().enumerate() {
        let h = Hexapod {
            encoders: c.variant,
            ..hex.clone()
        };
        let n = convention::basis(&h);
        let a = design::design(&h, &[0.0; N_ERRORS], &poses).unwrap() * &n;
        let sigma_deg = sigma_arcsec / 3600.0;
        let cov = (a.transpose() * &a).try_inverse().unwrap() * sigma_deg * sigma_deg;
        let f = n.ncols();
        let mut sq = DVector::zeros(f);
        let mut sum = DVector::zeros(f);
        for k in 0..trials {
            let (machines, estimates) = p.estimates(k).unwrap();
            let vi = usize::from(c.variant != Encoders::Both);
            let u: DVector<f64> = n.transpose() * (&estimates[ci] - &machines[vi]);
            sum += &u;
            sq += u.component_mul(&u);
        }
        let t = trials as f64;
        assert_eq!(sum.len(), f);
        assert_spread_is_predicted(&sum, &sq, t, &cov, &format!("{:?}", c.variant));
    }
}

/// GLS with white encoders is the linear estimate (Σ = σ²·I weights
/// every reading alike): the same estimate to 1e-12 on every trial.
#[test]
fn gls_of_white_encoders_is_the_linear_estimate() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let s = spec(2.0, 0.1, vec![Estimator::Linear, Estimator::Gls], 3);
    let p = Prepared::new(&hex, &poses, &s).unwrap();
    for k in 0..3 {
        let (_, estimates) = p.estimates(k).unwrap();
        for pair in estimates.chunks(2) {
            assert!((&pair[0] - &pair[1]).amax() < 1e-12, "trial {k}");
        }
    }
}

/// A prior (`identification.prior_std_mm`, `prior_std_deg`) is every
/// estimator's as identify holds it: on every trial the linear estimate
/// (the study's gain, the prior's rows weighted by the encoder's σ), GLS
/// (whitened, the prior's rows 1/σp) and one linearisation of identify
/// itself (its own prior rows, the readings' σ the encoder's) agree to
/// 1e-9 mm; a prior of 10⁶ mm and degrees leaves the estimates as without
/// one; a prior of 0.01 mm and 0.005° moves them.
#[test]
fn a_prior_is_every_estimators_as_identify_holds_it() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let all = vec![Estimator::Linear, Estimator::Gls, Estimator::GaussNewton];
    let mut none = spec(2.0, 0.1, all, 3);
    none.iterations = 1;
    let with = |mm: f64, deg: f64| Spec {
        prior_std_mm: Some(mm),
        prior_std_deg: Some(deg),
        ..none.clone()
    };
    let (tight, loose) = (with(0.01, 0.005), with(1e6, 1e6));
    let p = Prepared::new(&hex, &poses, &tight).unwrap();
    let q = Prepared::new(&hex, &poses, &none).unwrap();
    let r = Prepared::new(&hex, &poses, &loose).unwrap();
    let mut moved = 0.0f64;
    for k in 0..3 {
        let (_, a) = p.estimates(k).unwrap();
        let (_, b) = q.estimates(k).unwrap();
        let (_, c) = r.estimates(k).unwrap();
        // Combinations: per variant, the three estimators in turn.
        for (v, three) in a.chunks(3).enumerate() {
            for e in &three[1..] {
                let d = (&three[0] - e).amax();
                assert!(d < 1e-9, "trial {k} variant {v}: {d:e}");
            }
        }
        for ((x, y), z) in a.iter().zip(&b).zip(&c) {
            assert!((y - z).amax() < 1e-9, "trial {k}: a prior of 10⁶ moved it");
            moved = moved.max((x - y).amax());
        }
    }
    // The tight prior pulls the estimates toward nominal by tenths of
    // their ±0.1 mm.
    eprintln!("a prior of 0.01 mm and 0.005° moved an estimate by up to {moved:.4}");
    assert!(moved > 0.01, "{moved}");
}

/// An encoder with a curve of unknown shape (±3″ in up to 6 harmonics,
/// 0.2″ of jitter): over 600 machines GLS's spread in each free
/// direction is (AᵀΣ⁻¹A)⁻¹ of the datasheet's covariance Σ (Σ⁻¹ by a
/// dense inverse, not the study's whitening), each ratio 0.75–1.25 and
/// their mean 0.92–1.08; and its total variance is less than the linear
/// estimator's.
#[test]
fn gls_spreads_as_the_datasheet_covariance_predicts() {
    use crate::sensors::structured::Shape;
    use crate::sensors::SensorCovariance;
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let trials = 600;
    let mut s = spec(0.2, 0.01, vec![Estimator::Linear, Estimator::Gls], trials);
    s.variants = vec![Encoders::Both];
    s.sensors[0].axis.accuracy = 3.0 / ARCSEC_PER_RAD;
    s.sensors[0].axis.shape = Shape::Unknown;
    s.sensors[0].axis.n_harmonics = 6;
    let p = Prepared::new(&hex, &poses, &s).unwrap();
    let n = convention::basis(&hex);
    let a = design::design(&hex, &[0.0; N_ERRORS], &poses).unwrap() * &n;
    // The readings' covariance, degrees², entry by entry.
    let c = SensorCovariance::of_axis(&s.sensors[0].axis, 1);
    let m0 = hex.actual(&[0.0; N_ERRORS]);
    let nominal: Vec<f64> = poses.iter().flat_map(|t| hex.read_at(&m0, t)).collect();
    let per = hex.readings_per_pose();
    let deg2 = (180.0 / std::f64::consts::PI).powi(2);
    let sigma = nalgebra::DMatrix::from_fn(nominal.len(), nominal.len(), |i, j| {
        if i % per != j % per {
            return 0.0;
        }
        let (u, v) = (nominal[i].to_radians(), nominal[j].to_radians());
        (c.curve(u, v) + if i == j { c.white } else { 0.0 }) * deg2
    });
    let info = a.transpose() * sigma.try_inverse().unwrap() * &a;
    let cov = info.try_inverse().unwrap();
    let f = n.ncols();
    let (mut sum, mut sq) = (vec![DVector::zeros(f); 2], vec![DVector::zeros(f); 2]);
    for k in 0..trials {
        let (machines, estimates) = p.estimates(k).unwrap();
        for e in 0..2 {
            let u: DVector<f64> = n.transpose() * (&estimates[e] - &machines[0]);
            sum[e] += &u;
            sq[e] += u.component_mul(&u);
        }
    }
    let t = trials as f64;
    let var = |e: usize, j: usize| {
        let mean = sum[e][j] / t;
        (sq[e][j] - t * mean * mean) / (t - 1.0)
    };
    let ratios: Vec<f64> = (0..f).map(|j| (var(1, j) / cov[(j, j)]).sqrt()).collect();
    let mean = ratios.iter().sum::<f64>() / f as f64;
    let (lo, hi) = ratios
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &r| (a.min(r), b.max(r)));
    eprintln!("gls spread/predicted {lo:.3}–{hi:.3}, mean {mean:.3}");
    assert!(lo > 0.75 && hi < 1.25, "{ratios:?}");
    assert!((0.92..1.08).contains(&mean), "{mean}");
    let total = |e: usize| (0..f).map(|j| var(e, j)).sum::<f64>();
    eprintln!(
        "total variance: linear {:.3e}, gls {:.3e}",
        total(0),
        total(1)
    );
    assert!(total(1) < total(0));
}

/// Each machine's lengths within ±length_bound and encoder zeros within
/// ±zero_bound, each reaching near its bound over 2,000 machines; a
/// pose count too small to determine the free errors is refused.
#[test]
fn machines_are_drawn_within_their_bounds_and_too_few_poses_refused() {
    let s = spec(1.0, 0.1, vec![Estimator::Linear], 1);
    // Each error's largest |x| over its bound.
    let mut most = [0.0f64; N_ERRORS];
    for k in 0..2000 {
        let e = draw_errors(&Hexapod::example(), &s, k);
        for (j, x) in e.iter().enumerate() {
            let bound = if is_angle(j) {
                s.zero_bound_deg
            } else {
                s.length_bound_mm
            };
            assert!(x.abs() <= bound, "{j}: {x}");
            most[j] = most[j].max(x.abs() / bound);
        }
    }
    assert!(most.iter().all(|&m| m > 0.99), "{most:?}");
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let few = Spec {
        pose_counts: vec![3],
        ..s
    };
    let err = Prepared::new(&hex, &poses, &few).err().unwrap();
    assert!(err.contains("do not determine"), "{err}");
}

/// The thread count changes nothing, bit for bit; noise-free encoders
/// leave Gauss–Newton nothing but rounding, and the one linearisation
/// its second-order terms (under 5 % of the machine's error).
#[test]
fn the_study_is_deterministic_and_exact_without_noise() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let s = spec(0.0, 0.1, vec![Estimator::Linear, Estimator::GaussNewton], 6);
    let p = Prepared::new(&hex, &poses, &s).unwrap();
    let one = p.run(1).unwrap();
    assert_eq!(one, p.run(3).unwrap());
    // The trials' stacked judgement in the free directions is the
    // per-pose one over the 54 errors.
    for (k, trial) in one.iter().enumerate() {
        let (machines, estimates) = p.estimates(k as u64).unwrap();
        for ((c, j), est) in p.combinations.iter().zip(trial).zip(&estimates) {
            let vi = usize::from(c.variant != Encoders::Both);
            let (after, before) = (p.judge(&(&machines[vi] - est)), p.judge(&machines[vi]));
            for (a, b) in [
                (after.0, j.position_after),
                (after.1, j.orientation_after),
                (before.0, j.position_before),
                (before.1, j.orientation_before),
            ] {
                assert!((a - b).abs() <= 1e-9 * a.abs().max(1e-9), "{c:?}: {a} {b}");
            }
        }
    }
    for trial in &one {
        for (c, j) in p.combinations.iter().zip(trial) {
            match c.estimator {
                Estimator::GaussNewton => assert!(j.position_after < 1e-7, "{c:?} {j:?}"),
                Estimator::Linear | Estimator::Gls => {
                    assert!(j.position_after < 0.05 * j.position_before, "{c:?} {j:?}")
                }
            }
        }
    }
}

/// `identification.fix` in the study: every machine has the fixed values
/// and every estimator (linear, GLS, Gauss–Newton) holds them exactly;
/// over 400 machines the other free errors spread as σ²·(A_RᵀA_R)⁻¹ of
/// the design without the fixed columns (normal equations, each ratio
/// 0.75–1.25, their mean 0.93–1.07) about the truth (each mean within 4
/// standard errors), never wider than unfixed; the errors the variant
/// lacks (ψ's zero with φ only) are ignored.
#[test]
fn fixed_errors_are_every_machines_and_held_by_every_estimator() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let trials = 400;
    let sigma_arcsec = 2.0;
    let (dl3, dphi2, dpsi4) = (error_index(2, 6), error_index(1, 7), error_index(3, 8));
    let fixed = vec![(dl3, 0.05), (dphi2, 0.01), (dpsi4, -0.02)];
    let mut s = spec(
        sigma_arcsec,
        0.01,
        vec![Estimator::Linear, Estimator::Gls, Estimator::GaussNewton],
        trials,
    );
    s.fixed = fixed.clone();
    let p = Prepared::new(&hex, &poses, &s).unwrap();
    for k in 0..3 {
        let (machines, estimates) = p.estimates(k).unwrap();
        for (ci, c) in p.combinations.iter().enumerate() {
            let vi = usize::from(c.variant != Encoders::Both);
            for &(j, v) in &fixed {
                let has = j != dpsi4 || c.variant == Encoders::Both;
                let want = if has { v } else { 0.0 };
                assert!((machines[vi][j] - want).abs() < 1e-15, "{c:?} machine {j}");
                assert!(
                    (estimates[ci][j] - want).abs() < 1e-12,
                    "{c:?} estimate {j}"
                );
            }
        }
    }
    for (ci, c) in p.combinations.iter().enumerate() {
        if c.estimator != Estimator::Linear {
            continue;
        }
        let h = Hexapod {
            encoders: c.variant,
            ..hex.clone()
        };
        let n = convention::basis(&h);
        let a = design::design(&h, &[0.0; N_ERRORS], &poses).unwrap() * &n;
        let keep: Vec<usize> = (0..n.ncols())
            .filter(|&col| !fixed.iter().any(|&(j, _)| n[(j, col)] != 0.0))
            .collect();
        let ar = a.select_columns(&keep);
        let s2 = (sigma_arcsec / 3600.0).powi(2);
        let cov = (ar.transpose() * &ar).try_inverse().unwrap() * s2;
        let unfixed = (a.transpose() * &a).try_inverse().unwrap() * s2;
        let (mut sum, mut sq) = (DVector::zeros(keep.len()), DVector::zeros(keep.len()));
        for k in 0..trials {
            let (machines, estimates) = p.estimates(k).unwrap();
            let vi = usize::from(c.variant != Encoders::Both);
            let u: DVector<f64> = n.transpose() * (&estimates[ci] - &machines[vi]);
            let u = u.select_rows(&keep);
            sum += &u;
            sq += u.component_mul(&u);
        }
        let t = trials as f64;
        assert_spread_is_predicted(&sum, &sq, t, &cov, &format!("{:?} fixed", c.variant));
        for (r, &col) in keep.iter().enumerate() {
            assert!(cov[(r, r)] <= unfixed[(col, col)] * (1.0 + 1e-9), "{col}");
            // Centred: the fixed errors' part of the readings is taken out.
            let se = (cov[(r, r)] / t).sqrt();
            assert!(
                (sum[r] / t).abs() < 4.0 * se,
                "{col}: mean {} se {se}",
                sum[r] / t
            );
        }
    }
}
