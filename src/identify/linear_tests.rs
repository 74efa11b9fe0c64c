//! Tests of the linear solver (`identify/linear.rs`).

use super::*;
use crate::identify::tricept::{design_matrix, LinearSolver};
use crate::identify::Weighting;
use crate::mechanism::tricept::ErrorVector;
use crate::mechanism::tricept::{Geometry, Machine, NominalPoses};
use crate::mechanism::tricept::{N_PARAMS, N_READINGS, SLOTS};
use crate::sensors::{noisy_observation, GradeReading, SensorModel};
use rand::SeedableRng;

fn paper_design() -> DMatrix<f64> {
    let nominal = Machine::nominal(&Geometry::paper());
    let poses =
        NominalPoses::new(&nominal, &crate::mechanism::tricept::poses::paper_targets()).unwrap();
    design_matrix(&nominal, &poses).unwrap()
}

#[test]
fn predicted_std_matches_the_monte_carlo_spread() {
    let h = paper_design();
    let sensor = SensorModel {
        slots: SLOTS,
        encoder_arcsec: 4.0,
        scale_um: 0.5,
        samples: 1,
        reading: GradeReading::Sigma,
        structured: None,
    };
    let wls = sensor_weights(&h, &sensor);
    for weights in [DVector::from_element(h.nrows(), 1.0), wls] {
        let solver = LinearSolver::new(&h, &Weighting::Rows(weights.clone()), 1e-9);
        let predicted = solver.predicted_std(&sensor.reading_sigma());
        let l0 = vec![0.0; h.nrows()];
        let mut l = vec![0.0; h.nrows()];
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(3);
        let n = 20_000;
        let (mut sum, mut sq) = (ErrorVector::zeros(), ErrorVector::zeros());
        let mut est = ErrorVector::zeros();
        for _ in 0..n {
            noisy_observation(&sensor, &mut rng, &l0, &mut l);
            solver.apply(&l, &mut est);
            sum += est;
            sq += est.component_mul(&est);
        }
        for p in 0..N_PARAMS {
            if !solver.identifiable()[p] {
                assert_eq!(predicted[p], 0.0);
                continue;
            }
            let mean = sum[p] / n as f64;
            let sd = (sq[p] / n as f64 - mean * mean).sqrt();
            // Standard error of a standard deviation from 20000 draws: 0.5 %.
            assert!(
                (sd / predicted[p] - 1.0).abs() < 0.03,
                "parameter {p}: Monte-Carlo {sd:e} vs predicted {:e}",
                predicted[p]
            );
        }
    }
}

/// Every choice of sensors, on the AVX2 copy (where the processor has
/// it) and on the baseline: the sums a loop over the rows forms, in row
/// order, bit for bit; zero for a sensor not asked for. And op·l whole,
/// and white noise's split of op·l0 and op·dz.
#[test]
fn each_sensors_part_and_the_whole_are_rows_summed_in_order_on_every_copy() {
    let h = paper_design();
    let weights = DVector::from_fn(h.nrows(), |r, _| 1.0 + (r % 7) as f64 / 3.0);
    let solver = LinearSolver::new(&h, &Weighting::Rows(weights.clone()), 1e-9);
    let e: Vec<f64> = (0..h.nrows())
        .map(|r| ((r * 37 % 101) as f64 - 50.0) * 1.3e-6)
        .collect();
    let mut by_row = [ErrorVector::zeros(); 3];
    // From the row-major operator, not the padded columns the kernel reads.
    for (r, &x) in e.iter().enumerate() {
        for (a, &c) in solver.active.iter().enumerate() {
            by_row[r % 3][c] += solver.op[a * solver.rows + r] * x;
        }
    }
    assert!(by_row.iter().all(|b| b.amax() > 0.0));
    for bits in 1..8u8 {
        let need = std::array::from_fn(|k| bits >> k & 1 == 1);
        let mut wide = [ErrorVector::zeros(); 3];
        solver.apply_sensors(&e, need, &mut wide);
        let mut narrow = [ErrorVector::zeros(); 3];
        crate::cpu::baseline(|| solver.apply_sensors(&e, need, &mut narrow));
        for k in 0..3 {
            let want = if need[k] {
                by_row[k]
            } else {
                ErrorVector::zeros()
            };
            for c in 0..N_PARAMS {
                assert_eq!(wide[k][c].to_bits(), want[c].to_bits(), "{need:?} {k} {c}");
                assert_eq!(
                    narrow[k][c].to_bits(),
                    want[c].to_bits(),
                    "{need:?} {k} {c}"
                );
            }
        }
    }
    // The whole estimate (op·l, every row in order) on both copies.
    let mut all = ErrorVector::zeros();
    for (r, &x) in e.iter().enumerate() {
        for (a, &c) in solver.active.iter().enumerate() {
            all[c] += solver.op[a * solver.rows + r] * x;
        }
    }
    let (mut wide, mut narrow) = (ErrorVector::zeros(), ErrorVector::zeros());
    solver.apply(&e, &mut wide);
    crate::cpu::baseline(|| solver.apply(&e, &mut narrow));
    for c in 0..N_PARAMS {
        assert_eq!(wide[c].to_bits(), all[c].to_bits(), "apply {c}");
        assert_eq!(narrow[c].to_bits(), all[c].to_bits(), "apply {c}");
    }
    // White noise's split (op·l0 and op·dz by sensor in one pass), on
    // both copies: the same sums.
    let l0: Vec<f64> = e.iter().rev().copied().collect();
    let mut exact = ErrorVector::zeros();
    crate::cpu::baseline(|| solver.apply(&l0, &mut exact));
    for split in [
        solver.apply_split(&l0, &e),
        crate::cpu::baseline(|| solver.apply_split(&l0, &e)),
    ] {
        for c in 0..N_PARAMS {
            assert_eq!(split.exact[c].to_bits(), exact[c].to_bits(), "exact {c}");
            for k in 0..3 {
                assert_eq!(
                    split.noise[k][c].to_bits(),
                    by_row[k][c].to_bits(),
                    "noise {k} {c}"
                );
            }
        }
    }
}

fn sensor_weights(h: &DMatrix<f64>, s: &SensorModel<N_READINGS>) -> DVector<f64> {
    match crate::identify::Method::Wls
        .weighting(
            s,
            &vec![crate::mechanism::tricept::Joints::default(); h.nrows() / 3 + 1],
        )
        .unwrap()
    {
        Weighting::Rows(w) => w,
        Weighting::Whiten(_) => unreachable!(),
    }
}

#[test]
fn exact_observation_is_recovered_and_has_no_residual() {
    let h = paper_design();
    let solver = LinearSolver::new(
        &h,
        &Weighting::Rows(DVector::from_element(h.nrows(), 1.0)),
        1e-9,
    );
    let mut truth = ErrorVector::from_fn(|i, _| 0.01 * (i as f64 - 7.0));
    truth[11] = 0.0; // dyA3 cannot be seen in this layout
    let l = &h * truth;
    let est = solver.estimate(&l);
    assert!((est.values - truth).amax() < 1e-9);
    assert!(est.residual_rms < 1e-12 && est.std_mm.amax() < 1e-9);
    assert_eq!(est.dof, h.nrows() - 14);
    assert_eq!(est.termination, Termination::SingleLinearisation);
}

#[test]
fn operator_and_covariance_match_the_normal_equations() {
    // Independent route on a full-rank weighted design: the estimate of
    // an exact observation is the truth, and cov = (HᵀW²H)⁻¹.
    let g = Geometry::from_circles(100.0, 288.7, [-60.0, 60.0, 180.0], [-30.0, 90.0, 210.0]);
    let nominal = Machine::nominal(&g);
    let poses =
        NominalPoses::new(&nominal, &crate::mechanism::tricept::poses::paper_targets()).unwrap();
    let h = design_matrix(&nominal, &poses).unwrap();
    let w = DVector::from_fn(h.nrows(), |r, _| [3.0e4, 5.0e4, 2.0][r % 3]);
    let solver = LinearSolver::new(&h, &Weighting::Rows(w.clone()), 1e-9);
    assert_eq!(solver.identifiable(), [true; N_PARAMS]);
    let truth = ErrorVector::from_fn(|i, _| 0.03 * (i as f64 - 6.5));
    let l = &h * truth;
    let mut est = ErrorVector::zeros();
    solver.apply(l.as_slice(), &mut est);
    assert!((est - truth).amax() < 1e-9, "{:e}", (est - truth).amax());
    let hw = DMatrix::from_fn(h.nrows(), h.ncols(), |r, c| h[(r, c)] * w[r]);
    let normal = (hw.transpose() * &hw).try_inverse().unwrap();
    for a in 0..N_PARAMS {
        for b in 0..N_PARAMS {
            let rel =
                (solver.cov[(a, b)] - normal[(a, b)]).abs() / normal[(a, a)].abs().max(1e-300);
            assert!(
                rel < 1e-6,
                "cov[{a},{b}] {} vs {}",
                solver.cov[(a, b)],
                normal[(a, b)]
            );
        }
    }
}

#[test]
fn a_design_that_sees_nothing_identifies_nothing_without_panicking() {
    let h = DMatrix::zeros(12, N_PARAMS);
    let solver = LinearSolver::new(&h, &Weighting::Rows(DVector::from_element(12, 1.0)), 1e-9);
    assert_eq!(solver.analysis.rank, 0);
    assert_eq!(solver.identifiable(), [false; N_PARAMS]);
    let mut est = ErrorVector::from_element(1.0);
    solver.apply(&[0.5; 12], &mut est);
    assert_eq!(est, ErrorVector::zeros());
    assert_eq!(solver.dof(), 12);
    assert_eq!(solver.rows(), 12);
}

#[test]
fn posterior_scales_with_the_residual() {
    let h = paper_design();
    let solver = LinearSolver::new(
        &h,
        &Weighting::Rows(DVector::from_element(h.nrows(), 1.0)),
        1e-9,
    );
    let r = DVector::from_fn(h.nrows(), |i, _| if i % 2 == 0 { 1e-3 } else { -1e-3 });
    // Weighted rows enter as (w·r)²: rows of weight 2 count four times.
    let w2 = LinearSolver::new(
        &h,
        &Weighting::Rows(DVector::from_element(h.nrows(), 2.0)),
        1e-9,
    );
    let (_, rms_w2) = w2.posterior(&r);
    assert!((rms_w2 - 2e-3).abs() < 1e-15, "{rms_w2}");
    let (std1, rms1) = solver.posterior(&r);
    let (std2, rms2) = solver.posterior(&(&r * 2.0));
    assert!((rms1 - 1e-3).abs() < 1e-15);
    assert!((rms2 / rms1 - 2.0).abs() < 1e-12);
    for p in 0..N_PARAMS {
        if solver.identifiable()[p] {
            assert!((std2[p] / std1[p] - 2.0).abs() < 1e-12);
            // s² = rss/(m − p) times the covariance diagonal.
            let s2 = 1e-6 * h.nrows() as f64 / solver.dof() as f64;
            let a = solver.active.iter().position(|&c| c == p).unwrap();
            assert!((std1[p] - (s2 * solver.cov[(a, a)]).sqrt()).abs() < 1e-15);
        }
    }
}

/// The full-rank layout's design and the covariance of datasheet sensors
/// (two harmonics, jitter) at its poses.
fn gls_case() -> (
    DMatrix<f64>,
    DMatrix<f64>,
    NominalPoses,
    SensorModel<N_READINGS>,
) {
    let g = Geometry::from_circles(100.0, 288.7, [-60.0, 60.0, 180.0], [-30.0, 90.0, 210.0]);
    let nominal = Machine::nominal(&g);
    let poses =
        NominalPoses::new(&nominal, &crate::mechanism::tricept::poses::paper_targets()).unwrap();
    let h = design_matrix(&nominal, &poses).unwrap();
    use crate::sensors::structured::fixtures::{encoder, paper_span_mm, scale, sensors};
    let e = encoder(5.0, &[0.8, 0.2], 0.1);
    let sensors = sensors(
        [e, e, scale(2.0, &[0.6, 0.3], paper_span_mm(), 0.05)],
        [true; 3],
        3,
    );
    let sigma = crate::sensors::observation_covariance(&sensors.covariances(), &poses.joints);
    (h, sigma, poses, sensors)
}

/// GLS by an independent route: (HᵀΣ⁻¹H)⁻¹HᵀΣ⁻¹ from the normal equations
/// with Σ⁻¹ formed outright, against the operator built from the Cholesky
/// whitening and an SVD; and its covariance against the sandwich op·Σ·opᵀ
/// (equal for the BLUE) and against the normal equations' inverse.
#[test]
fn gls_is_the_normal_equations_with_the_inverse_covariance() {
    let (h, sigma, poses, sensors) = gls_case();
    let w = crate::identify::Method::Gls
        .weighting(&sensors, &poses.joints)
        .unwrap();
    assert!(matches!(w, Weighting::Whiten(_)));
    let solver = LinearSolver::new(&h, &w, 1e-9);
    assert_eq!(solver.identifiable(), [true; N_PARAMS]);
    let si = sigma.clone().try_inverse().unwrap();
    let info = h.transpose() * &si * &h;
    let inv = info.clone().try_inverse().unwrap();
    let op = &inv * h.transpose() * &si;
    // Column scales differ by 10⁵ (rad and mm rows): compare each
    // parameter's row relative to its largest entry.
    for a in 0..N_PARAMS {
        let big = (0..h.nrows()).map(|r| op[(a, r)].abs()).fold(0.0, f64::max);
        for r in 0..h.nrows() {
            let got = solver.op[a * h.nrows() + r];
            assert!(
                (got - op[(a, r)]).abs() < 1e-6 * big,
                "op[{a},{r}] {got} vs {}",
                op[(a, r)]
            );
        }
    }
    let cov = solver.covariance_std();
    let sandwich = solver.predicted_std_under(&crate::sensors::ObservationCovariance::new(
        &sensors.covariances(),
        &poses.joints,
    ));
    for a in 0..N_PARAMS {
        let want = inv[(a, a)].sqrt();
        assert!(
            (cov[a] - want).abs() < 1e-6 * want,
            "{a}: {} vs {want}",
            cov[a]
        );
        assert!(
            (sandwich[a] - want).abs() < 1e-6 * want,
            "{a}: {} vs {want}",
            sandwich[a]
        );
    }
    // GLS's a-posteriori uncertainty is that covariance, whatever the
    // residual (docs/method.md §13), and its RMS is of the whitened residual.
    let resid = DVector::from_fn(h.nrows(), |r, _| 1e-6 * ((r * 7 % 5) as f64 - 2.0));
    let (std_mm, rms) = solver.posterior(&resid);
    assert_eq!(std_mm, cov);
    let white = w.apply_vector(&resid);
    assert!((rms - (white.norm_squared() / h.nrows() as f64).sqrt()).abs() < 1e-12 * rms);
    // The BLUE's variance is below WLS's (the sandwich under the same Σ)
    // for every parameter.
    let wls = LinearSolver::new(
        &h,
        &crate::identify::Method::Wls
            .weighting(&sensors, &poses.joints)
            .unwrap(),
        1e-9,
    );
    let wls_std = wls.predicted_std_under(&crate::sensors::ObservationCovariance::new(
        &sensors.covariances(),
        &poses.joints,
    ));
    for a in 0..N_PARAMS {
        assert!(
            cov[a] <= wls_std[a] * (1.0 + 1e-9),
            "{a}: {} > {}",
            cov[a],
            wls_std[a]
        );
    }
}

/// With white-noise sensors the sandwich under σ²(I + 11ᵀ) is the closed
/// form of [`LinearSolver::predicted_std`]; GLS differs from WLS only by the
/// shared reference reading, so its variance is no larger.
#[test]
fn white_noise_sandwich_is_the_closed_form() {
    let (h, _, poses, _) = gls_case();
    let sensor = SensorModel {
        slots: SLOTS,
        encoder_arcsec: 2.0,
        scale_um: 1.0,
        samples: 3,
        reading: GradeReading::Sigma,
        structured: None,
    };
    let sigma = crate::sensors::ObservationCovariance::new(&sensor.covariances(), &poses.joints);
    for m in crate::identify::Method::ALL {
        let s = LinearSolver::new(&h, &m.weighting(&sensor, &poses.joints).unwrap(), 1e-9);
        let closed = s.predicted_std(&sensor.reading_sigma());
        let sandwich = s.predicted_std_under(&sigma);
        for a in 0..N_PARAMS {
            assert!(
                (closed[a] - sandwich[a]).abs() < 1e-9 * closed[a],
                "{m:?} {a}"
            );
        }
    }
    let gls = crate::identify::Method::Gls
        .weighting(&sensor, &poses.joints)
        .unwrap();
    let wls = crate::identify::Method::Wls
        .weighting(&sensor, &poses.joints)
        .unwrap();
    let g = LinearSolver::new(&h, &gls, 1e-9).covariance_std();
    let w = LinearSolver::new(&h, &wls, 1e-9).predicted_std_under(&sigma);
    for a in 0..N_PARAMS {
        assert!(g[a] <= w[a] * (1.0 + 1e-9));
    }
}

/// `fix` and `prior_std_mm` against independent routes with Σ⁻¹ formed
/// outright: fixed errors held and the rest the GLS of the reduced columns
/// on l − H_F·v_F; a prior the MAP (HᵀΣ⁻¹H + I/σp²)⁻¹HᵀΣ⁻¹l with that
/// inverse as its covariance, on the full-rank layout and on the paper's
/// (dyA3 seen by no reading: held at 0 with σ = σp, source "prior"); a
/// Gauss–Newton step from the MAP is zero.
#[test]
fn fixed_errors_and_a_prior_are_the_constrained_least_squares() {
    let (h_full, sigma_full, poses_full, sensors) = gls_case();
    let paper = {
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let poses = NominalPoses::new(&nominal, &crate::mechanism::tricept::poses::paper_targets())
            .unwrap();
        let h = design_matrix(&nominal, &poses).unwrap();
        let sigma = crate::sensors::observation_covariance(&sensors.covariances(), &poses.joints);
        (h, sigma, poses)
    };
    for (h, sigma, poses) in [(h_full, sigma_full, poses_full), paper] {
        let w = crate::identify::Method::Gls
            .weighting(&sensors, &poses.joints)
            .unwrap();
        let si = sigma.clone().try_inverse().unwrap();
        let l = DVector::from_fn(h.nrows(), |r, _| 1e-3 * ((r as f64) * 0.71).sin());
        // Fixed: dxB1 (3) and dq2 (13) held.
        let mut c = Constraints::default();
        c.fixed[3] = Some(0.02);
        c.fixed[13] = Some(-0.01);
        let s = LinearSolver::constrained(&h, &w, 1e-9, &c);
        let est = s.estimate(&l);
        let base = LinearSolver::new(&h, &w, 1e-9);
        let free: Vec<usize> = (0..N_PARAMS)
            .filter(|&k| c.fixed[k].is_none() && base.identifiable()[k])
            .collect();
        let v = DVector::from_fn(N_PARAMS, |k, _| c.fixed[k].unwrap_or(0.0));
        let hf = h.select_columns(&free);
        let info = hf.transpose() * &si * &hf;
        let want = info.clone().try_inverse().unwrap() * hf.transpose() * &si * (&l - &h * &v);
        for (i, &k) in free.iter().enumerate() {
            let tol = 1e-7 * want.amax();
            assert!(
                (est.values[k] - want[i]).abs() < tol,
                "fix {k}: {} vs {}",
                est.values[k],
                want[i]
            );
            let sd = info.clone().try_inverse().unwrap()[(i, i)].sqrt();
            assert!((est.std_mm[k] / sd - 1.0).abs() < 1e-6, "σ {k}");
            assert_eq!(est.source[k], "readings");
        }
        assert_eq!((est.values[3], est.values[13]), (0.02, -0.01));
        assert!(est.std_mm[3].is_nan() && est.source[13] == "fixed" && est.identifiable[3]);
        // A Gauss–Newton step's operator keeps the fixed errors out and
        // carries no offset (the estimate it moves from holds them): from
        // l it moves the free errors by the reduced GLS of l alone, and
        // the fixed ones not at all.
        let step = LinearSolver::with_analysis(&h, &w, base.analysis.clone(), &c);
        let mut d = nalgebra::SVector::<f64, N_PARAMS>::zeros();
        step.apply(l.as_slice(), &mut d);
        let moved = info.clone().try_inverse().unwrap() * hf.transpose() * &si * &l;
        for (i, &k) in free.iter().enumerate() {
            let tol = 1e-7 * moved.amax();
            assert!(
                (d[k] - moved[i]).abs() < tol,
                "step {k}: {} vs {}",
                d[k],
                moved[i]
            );
        }
        assert_eq!((d[3], d[13]), (0.0, 0.0));
        // Prior σp = 0.05 mm: every error estimated.
        let sp = 0.05;
        let c = Constraints {
            prior_std_mm: Some(sp),
            ..Constraints::default()
        };
        let s = LinearSolver::constrained(&h, &w, 1e-9, &c);
        let est = s.estimate(&l);
        let info = h.transpose() * &si * &h + DMatrix::identity(N_PARAMS, N_PARAMS) / (sp * sp);
        let inv = info.clone().try_inverse().unwrap();
        // The MAP by a second route that avoids squaring the condition
        // number: the augmented least squares [L⁻¹H; I/σp]·ε = [L⁻¹l; 0]
        // (L the dense Cholesky factor of Σ) by SVD.
        let chol = sigma.clone().cholesky().unwrap().unpack();
        let lh = chol.solve_lower_triangular(&h).unwrap();
        let ll = chol.solve_lower_triangular(&l).unwrap();
        let m = h.nrows();
        let mut a = DMatrix::zeros(m + N_PARAMS, N_PARAMS);
        a.view_mut((0, 0), (m, N_PARAMS)).copy_from(&lh);
        for k in 0..N_PARAMS {
            a[(m + k, k)] = 1.0 / sp;
        }
        let mut b = DVector::zeros(m + N_PARAMS);
        b.rows_mut(0, m).copy_from(&ll);
        let want = a.svd(true, true).solve(&b, 1e-14).unwrap();
        for k in 0..N_PARAMS {
            assert!(est.identifiable[k]);
            assert!(
                (est.values[k] - want[k]).abs() < 1e-7 * want.amax(),
                "prior {k}: {} vs {}",
                est.values[k],
                want[k]
            );
            assert!(
                (est.std_mm[k] / inv[(k, k)].sqrt() - 1.0).abs() < 1e-6,
                "σ {k}"
            );
            let unseen = !base.identifiable()[k];
            if unseen {
                assert!(est.values[k].abs() < 1e-6 * sp && (est.std_mm[k] / sp - 1.0).abs() < 1e-6);
                assert_eq!(est.source[k], "prior");
            }
        }
        let post = s.posterior_covariance();
        assert!((&post - &inv).amax() < 1e-6 * inv.amax());
        // At the MAP the linear model's Gauss–Newton step is zero.
        let r = &l - &h * est.values;
        let mut step = ErrorVector::zeros();
        s.step(r.as_slice(), &est.values, &mut step);
        assert!(step.amax() < 1e-9 * est.values.amax().max(1e-6), "{step}");
    }
}
