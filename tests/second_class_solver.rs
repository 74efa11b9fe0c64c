//! The Hooke axes' operator (`identify/second_class.rs`) against the
//! 18-column least squares solved outright: its estimates, its stated
//! uncertainties, the angles it cannot identify and what it refuses.
use nalgebra::{DMatrix, DVector};
use tricept_calib::config::{parse_raw, Config, PAPER_TOML};
use tricept_calib::identify::second_class::MIN_OUTSIDE_SPAN;
use tricept_calib::identify::tricept::{angle_design, AxesSolver};
use tricept_calib::identify::tricept::{design_matrix, LinearSolver};
use tricept_calib::identify::Method;
use tricept_calib::mechanism::tricept::second_class::Angles;
use tricept_calib::mechanism::tricept::ErrorVector;
use tricept_calib::sensors::ObservationCovariance;

fn paper() -> Config {
    Config::from_raw(parse_raw(PAPER_TOML, "paper").unwrap(), "paper").unwrap()
}

fn paper_angle_design(
    cfg: &Config,
) -> (
    DMatrix<f64>,
    tricept_calib::mechanism::tricept::NominalPoses,
) {
    let poses = cfg.nominal_poses().unwrap();
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints).unwrap();
    (h3, poses)
}

/// The split operator is the 18-column weighted least squares solved
/// outright: pinv(W·[H15 H3])·W, by an SVD of the equilibrated matrix
/// with the unidentifiable dyA3 column left out.
#[test]
fn the_split_is_the_eighteen_column_least_squares() {
    let cfg = paper();
    let (h3, poses) = paper_angle_design(&cfg);
    let h15 = design_matrix(&cfg.nominal(), &poses).unwrap();
    for method in [Method::Ols, Method::Wls, Method::Gls] {
        let weighting = method.weighting(&cfg.sensors, &poses.joints).unwrap();
        let base = LinearSolver::new(&h15, &weighting, 1e-10);
        let ext = AxesSolver::new(&base, &h3, 1e-10).unwrap();
        assert_eq!(ext.rank(&base), 17, "{method:?}");
        assert_eq!(ext.identifiable(), [true; 3]);
        let op = ext.operator(&base);
        // Direct: the 17 identifiable columns, equilibrated.
        let keep: Vec<usize> = (0..18).filter(|&c| c != 11).collect();
        let mut h = DMatrix::zeros(h15.nrows(), keep.len());
        for (k, &c) in keep.iter().enumerate() {
            let col = if c < 15 {
                h15.column(c)
            } else {
                h3.column(c - 15)
            };
            h.set_column(k, &col);
        }
        let hw = weighting.apply(&h);
        let norms: Vec<f64> = (0..hw.ncols()).map(|c| hw.column(c).norm()).collect();
        let mut hs = hw.clone();
        for (c, n) in norms.iter().enumerate() {
            hs.column_mut(c).unscale_mut(*n);
        }
        let pinv = hs.pseudo_inverse(1e-14).unwrap();
        // op·l for a few observations.
        for seed in 0..3u64 {
            let l = nalgebra::DVector::from_fn(h15.nrows(), |r, _| {
                ((r as f64 + 1.0) * (seed as f64 + 0.7)).sin() * 1e-3
            });
            let direct = &pinv * weighting.apply_vector(&l);
            let ours = &op * &l;
            for (k, &c) in keep.iter().enumerate() {
                let d = direct[k] / norms[k];
                assert!(
                    (ours[c] - d).abs() <= 1e-8 * d.abs().max(1e-6),
                    "{method:?} unknown {c}: {} vs {d}",
                    ours[c]
                );
            }
            assert_eq!(ours[11], 0.0);
            // apply() agrees with the operator.
            let mut e15 = ErrorVector::zeros();
            base.apply(l.as_slice(), &mut e15);
            let x = ext.apply(l.as_slice(), &e15);
            for c in 0..15 {
                assert!((x.errors[c] - ours[c]).abs() < 1e-12 * ours.amax().max(1e-9));
            }
            for c in 0..3 {
                assert!((x.angles[c] - ours[15 + c]).abs() < 1e-12 * ours.amax().max(1e-9));
            }
        }
    }
}

/// The stated uncertainties are the 18-column least squares' spread under
/// the declared sensors, whatever the estimator: √diag(op·Σ·opᵀ) with
/// op = (AᵀA)⁻¹Aᵀ·W (A = W·H of the 17 identifiable unknowns) and Σ built
/// entry by entry (dense) — for GLS that is diag((AᵀA)⁻¹) itself; for WLS
/// it does not depend on the residual (an observation three times noisier
/// than the weights say states the same), and the RMS is the weighted
/// residual's.
#[test]
fn uncertainties_are_the_eighteen_column_covariance() {
    let cfg = paper();
    let (h3, poses) = paper_angle_design(&cfg);
    let h15 = design_matrix(&cfg.nominal(), &poses).unwrap();
    let sigma = ObservationCovariance::new(&cfg.sensors.covariances(), &poses.joints);
    let dense =
        tricept_calib::sensors::observation_covariance(&cfg.sensors.covariances(), &poses.joints);
    let keep: Vec<usize> = (0..18).filter(|&c| c != 11).collect();
    let mut h = DMatrix::zeros(h15.nrows(), keep.len());
    for (k, &c) in keep.iter().enumerate() {
        let col = if c < 15 {
            h15.column(c)
        } else {
            h3.column(c - 15)
        };
        h.set_column(k, &col);
    }
    for method in [Method::Wls, Method::Gls] {
        let weighting = method.weighting(&cfg.sensors, &poses.joints).unwrap();
        let base = LinearSolver::new(&h15, &weighting, 1e-10);
        let ext = AxesSolver::new(&base, &h3, 1e-10).unwrap();
        let a = weighting.apply(&h);
        let w = weighting.apply(&DMatrix::identity(h.nrows(), h.nrows()));
        let sd = weighting.apply_vector(&DVector::from_element(h.nrows(), 1.0));
        let ata_inv = (a.transpose() * &a).try_inverse().unwrap();
        let op = &ata_inv * a.transpose() * &w;
        let cov = &op * &dense * op.transpose();
        let mut stated = Vec::new();
        for noise in [1.0, 3.0] {
            let l = DVector::from_fn(h.nrows(), |r, _| {
                noise * ((r as f64 * 1.7).sin() + (r as f64 * 0.37).cos()) / sd[r].abs().max(1e-300)
            });
            let mut e15 = ErrorVector::zeros();
            base.apply(l.as_slice(), &mut e15);
            let x = ext.apply(l.as_slice(), &e15);
            let (std, rms) = ext.uncertainties(&base, &l, &x, &sigma);
            let resid = ext.residual(&base, &l, &x);
            let rss = weighting.apply_vector(&resid).norm_squared();
            assert!((rms - (rss / h.nrows() as f64).sqrt()).abs() < 1e-12 * rms);
            for (k, &c) in keep.iter().enumerate() {
                let want = cov[(k, k)].sqrt();
                assert!(
                    (std[c] - want).abs() < 1e-6 * want,
                    "{method:?} unknown {c}: {} vs {want}",
                    std[c]
                );
                if method == Method::Gls {
                    let own = ata_inv[(k, k)].sqrt();
                    assert!(
                        (std[c] - own).abs() < 1e-6 * own,
                        "{c}: {} vs {own}",
                        std[c]
                    );
                }
            }
            stated.push(std);
        }
        assert_eq!(
            stated[0], stated[1],
            "{method:?}: the statement reads no residual"
        );
    }
}

/// Five poses: H15 (rank 12 of 12 rows) spans every observation row, so
/// what is left of the angles' columns is rounding: none is identified
/// (the equilibrated SVD alone would call the noise rank 3).
#[test]
fn angles_the_errors_imitate_to_rounding_are_not_identified() {
    let cfg = paper();
    let (h3, poses) = paper_angle_design(&cfg);
    let h15 = design_matrix(&cfg.nominal(), &poses).unwrap();
    let rows: Vec<usize> = (0..12).collect();
    let (h15, h3) = (h15.select_rows(&rows), h3.select_rows(&rows));
    let base = LinearSolver::unweighted(&h15, 1e-9);
    assert_eq!(base.analysis.rank, 12);
    let ext = AxesSolver::new(&base, &h3, 1e-9).unwrap();
    assert_eq!(ext.identifiable(), [false; 3]);
    assert_eq!(ext.rank(&base), 12);
    assert!(ext
        .outside_span(&base)
        .iter()
        .all(|&s| s < MIN_OUTSIDE_SPAN));
    // A column no reading sees at all: share 0, not 0/0.
    let mut flat = h3.clone();
    flat.column_mut(0).fill(0.0);
    let ext = AxesSolver::new(&base, &flat, 1e-9).unwrap();
    assert_eq!(ext.outside_span(&base)[0], 0.0);
}

#[test]
fn held_errors_are_refused_in_one_sentence() {
    let cfg = paper();
    let (h3, poses) = paper_angle_design(&cfg);
    let h15 = design_matrix(&cfg.nominal(), &poses).unwrap();
    let w = Method::Ols.weighting(&cfg.sensors, &poses.joints).unwrap();
    let c = tricept_calib::identify::Constraints {
        prior_std_mm: Some(0.5),
        ..Default::default()
    };
    let base = LinearSolver::constrained(&h15, &w, 1e-10, &c);
    let why = AxesSolver::new(&base, &h3, 1e-10).unwrap_err();
    assert!(why.contains("prior_std_mm"), "{why}");
}
