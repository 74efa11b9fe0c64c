//! What `identify` checks of its own result: the fit's misfit against the
//! declared sensors (χ²), poses left out in folds, and the accuracy the
//! compensated machine is predicted to reach. The three share the
//! sensors' covariance Σ at the poses and the fit's residual, built once
//! ([`FitInputs`], [`checks`]); Σ is dense, so they run only within
//! [`crate::identify::MAX_DENSE_ROWS`] rows.

use super::{fit_residual, Calibration};
use crate::config::Config;
use crate::identify::{LinearSolver, Weighting};
use crate::io::data_line;
use crate::model::poses::workspace_grid;
use crate::model::Joints;
use crate::sensors::Reading;
use nalgebra::{DMatrix, DVector};

/// What the checks share, each built once.
pub struct FitInputs {
    /// The declared sensors' covariance of the homed observation.
    pub sigma: DMatrix<f64>,
    /// The residual the estimator minimised.
    pub resid: DVector<f64>,
}

impl FitInputs {
    /// None beyond the rows a dense covariance is built for, or when the
    /// estimated machine cannot reach a pose.
    pub fn of(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<Self> {
        crate::identify::check_dense_rows(cal.solver.rows()).ok()?;
        Some(FitInputs {
            sigma: crate::sensors::observation_covariance(
                &cfg.sensors.covariances(),
                &cal.poses.joints,
            ),
            resid: fit_residual(cfg, cal, readings)?,
        })
    }
}

/// Every check of a calibration (identifiability.json's `checks`).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Checks {
    pub misfit: Option<Misfit>,
    pub held_out: Option<HeldOut>,
    pub predicted_accuracy: Option<PredictedAccuracy>,
}

/// All three checks from one Σ and one residual; the predicted accuracy is
/// scaled by the misfit when its test rejects.
pub fn checks(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Checks {
    let Some(f) = FitInputs::of(cfg, cal, readings) else {
        return Checks {
            misfit: None,
            held_out: None,
            predicted_accuracy: None,
        };
    };
    let misfit = misfit_of(cal, &f);
    let scale = misfit.filter(|m| m.rejected).map_or(1.0, |m| m.ratio);
    Checks {
        misfit,
        held_out: held_out_of(cfg, cal, &f),
        predicted_accuracy: predicted_of(cfg, cal, &f.sigma, scale),
    }
}

/// The fit's misfit against the sensors the config declares: χ² of the
/// residual whitened by their covariance Σ, after the best linear
/// correction of the identifiable errors (GLS's own residual, whatever the
/// estimator), on m − rank degrees of freedom.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Misfit {
    pub chi2: f64,
    pub dof: usize,
    /// P(χ²_dof ≥ chi2): the chance of a misfit this large from the
    /// declared sensors alone.
    pub p_value: f64,
    /// √(χ²/dof): how many times the declared noise the residual is; the
    /// factor the uncertainties are scaled by when the test rejects.
    pub ratio: f64,
    /// The test rejects the model at 1 %.
    pub rejected: bool,
}

/// Significance of the misfit test.
pub const MISFIT_LEVEL: f64 = 0.01;

/// The misfit of `cal` (None without degrees of freedom, a positive
/// definite Σ or a residual).
pub fn misfit(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<Misfit> {
    misfit_of(cal, &FitInputs::of(cfg, cal, readings)?)
}

fn misfit_of(cal: &Calibration, f: &FitInputs) -> Option<Misfit> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let (r, sigma) = (f.resid.clone(), f.sigma.clone());
    let w = Weighting::whiten(sigma).ok()?;
    let rw = w.apply_vector(&r);
    let h = cal.solver.design();
    let active: Vec<usize> = (0..h.ncols())
        .filter(|&c| cal.solver.analysis.identifiable[c])
        .collect();
    let hw = w.apply(&h.select_columns(&active));
    let rank = active.len();
    let dof = hw.nrows().checked_sub(rank).filter(|&d| d > 0)?;
    let resid = if rank > 0 {
        let q = hw.qr().q();
        &rw - &q * (q.transpose() * &rw)
    } else {
        rw
    };
    let chi2 = resid.norm_squared();
    let p_value = ChiSquared::new(dof as f64).ok()?.sf(chi2);
    Some(Misfit {
        chi2,
        dof,
        p_value,
        ratio: (chi2 / dof as f64).sqrt(),
        rejected: p_value < MISFIT_LEVEL,
    })
}

/// The likely cause of a rejected misfit, in words.
pub fn misfit_cause(m: &Misfit, iterations: usize) -> &'static str {
    if m.ratio > 30.0 {
        "readings in other units or column order, readings of another machine, or a geometry ([geometry]) far from this machine's"
    } else if iterations <= 1 {
        "the single linearisation (errors of tenths of a millimetre leave a second-order residual: set [identification] iterations = 5), or errors the model leaves out"
    } else {
        "errors the model leaves out (the UP limb's second-class errors, thermal drift, play) or sensors noisier than [sensors] declares"
    }
}

/// Poses left out in folds: each fold's readings predicted from a fit to
/// the others, against what was read, in units of the prediction's own
/// standard deviation (the readings' covariance and the fit's, by the
/// exact linear propagation: the held-out and fitted rows share the
/// reference reading and, with datasheet sensors, the curves).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct HeldOut {
    pub folds: usize,
    /// Readings predicted (three per held-out pose).
    pub rows: usize,
    /// RMS of the standardised prediction errors: about 1 when the model
    /// predicts poses it was not fitted to as well as the sensors allow.
    pub rms_z: f64,
    pub max_abs_z: f64,
    /// CSV line of the pose with the largest.
    pub worst_line: usize,
    /// Folds skipped because the poses left identified fewer errors.
    pub folds_skipped: usize,
}

/// Folds of the held-out check.
pub const HELD_OUT_FOLDS: usize = 5;

/// The linear operator of `solver` as a matrix (P × rows): its estimate of
/// each unit observation.
fn operator(solver: &LinearSolver) -> nalgebra::DMatrix<f64> {
    let m = solver.rows();
    let mut op = nalgebra::DMatrix::zeros(crate::model::N_PARAMS, m);
    let mut unit = vec![0.0; m];
    let mut out = crate::model::ErrorVector::zeros();
    for j in 0..m {
        unit[j] = 1.0;
        solver.apply(&unit, &mut out);
        op.set_column(j, &out);
        unit[j] = 0.0;
    }
    op
}

/// The held-out check of `cal` with the config's estimator (None without
/// enough poses or a residual).
pub fn held_out(cfg: &Config, cal: &Calibration, readings: &[Reading]) -> Option<HeldOut> {
    held_out_of(cfg, cal, &FitInputs::of(cfg, cal, readings)?)
}

fn held_out_of(cfg: &Config, cal: &Calibration, f: &FitInputs) -> Option<HeldOut> {
    let n = cal.poses.len();
    if n < 2 * HELD_OUT_FOLDS {
        return None;
    }
    let h = cal.solver.design();
    // The observation linearised where the fit ended.
    let y = &f.resid + h * cal.estimate.values;
    let sigma = &f.sigma;
    let method = cfg.identification.method;
    let (mut sum, mut count, mut worst, mut worst_pose, mut skipped) = (0.0, 0, 0.0f64, 0, 0);
    for f in 0..HELD_OUT_FOLDS {
        let held: Vec<usize> = (1..n).filter(|j| j % HELD_OUT_FOLDS == f).collect();
        let kept: Vec<usize> = (1..n).filter(|j| j % HELD_OUT_FOLDS != f).collect();
        let rows_of = |poses: &[usize]| -> Vec<usize> {
            poses
                .iter()
                .flat_map(|&j| (0..3).map(move |k| 3 * (j - 1) + k))
                .collect()
        };
        let (rh, rk) = (rows_of(&held), rows_of(&kept));
        let hk = h.select_rows(&rk);
        let joints: Vec<Joints> = std::iter::once(cal.poses.joints[0])
            .chain(kept.iter().map(|&j| cal.poses.joints[j]))
            .collect();
        let Ok(weighting) = method.weighting(&cfg.sensors, &joints) else {
            skipped += 1;
            continue;
        };
        let solver = LinearSolver::new(&hk, &weighting, cfg.identification.rank_tolerance);
        if solver.analysis.rank < cal.solver.analysis.rank {
            skipped += 1;
            continue;
        }
        let op = operator(&solver);
        let hh = h.select_rows(&rh);
        let yk = nalgebra::DVector::from_iterator(rk.len(), rk.iter().map(|&r| y[r]));
        let pred = &hh * (&op * &yk);
        // A: the prediction error as a linear map of every row of y.
        let m = y.len();
        let mut a = nalgebra::DMatrix::zeros(rh.len(), m);
        let g = -(&hh * &op);
        for (c, &r) in rk.iter().enumerate() {
            a.set_column(r, &g.column(c));
        }
        for (i, &r) in rh.iter().enumerate() {
            a[(i, r)] += 1.0;
        }
        let var = &a * sigma * a.transpose();
        for (i, &r) in rh.iter().enumerate() {
            let sd = var[(i, i)].max(0.0).sqrt();
            if sd <= 0.0 || sd.is_nan() {
                continue;
            }
            let z = (y[r] - pred[i]) / sd;
            sum += z * z;
            count += 1;
            if z.abs() > worst {
                worst = z.abs();
                worst_pose = r / 3 + 1;
            }
        }
    }
    (count > 0).then(|| HeldOut {
        folds: HELD_OUT_FOLDS,
        rows: count,
        rms_z: (sum / count as f64).sqrt(),
        max_abs_z: worst,
        worst_line: data_line(worst_pose),
        folds_skipped: skipped,
    })
}

/// The accuracy the compensated machine is predicted to reach over the
/// workspace from the estimate's uncertainty alone (first order, the
/// identifiable errors; an unidentifiable error's true value is not in it):
/// for each of `DRAWS` draws of the estimate's error, dV at every grid
/// point; the median and the 2.5–97.5 % range over draws of the largest,
/// the 95th percentile and the mean.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct PredictedAccuracy {
    pub draws: usize,
    pub points: usize,
    /// (median, 2.5 %, 97.5 %) over draws, mm.
    pub max_mm: [f64; 3],
    pub p95_mm: [f64; 3],
    pub mean_mm: [f64; 3],
}

const DRAWS: usize = 1000;

/// [`PredictedAccuracy`] with the estimate's covariance op·Σ·opᵀ scaled by
/// `scale²` (the misfit's, when its test rejects).
pub fn predicted_accuracy(
    cfg: &Config,
    cal: &Calibration,
    scale: f64,
) -> Option<PredictedAccuracy> {
    crate::identify::check_dense_rows(cal.solver.rows()).ok()?;
    let sigma =
        crate::sensors::observation_covariance(&cfg.sensors.covariances(), &cal.poses.joints);
    predicted_of(cfg, cal, &sigma, scale)
}

fn predicted_of(
    cfg: &Config,
    cal: &Calibration,
    sigma: &DMatrix<f64>,
    scale: f64,
) -> Option<PredictedAccuracy> {
    use rand::SeedableRng;
    let op = operator(&cal.solver);
    let cov = &op * sigma * op.transpose() * (scale * scale);
    let eig = cov.symmetric_eigen();
    let root = &eig.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let nominal = cfg.nominal();
    let step = cfg.grid_step_mm.max(cfg.workspace.radius_mm / 20.0);
    let s: Vec<crate::model::ErrorJacobian> = workspace_grid(&cfg.workspace, step, cfg.layers)
        .iter()
        .filter_map(|r| nominal.inverse(r).ok())
        .filter_map(|p| crate::model::jacobian::position_sensitivity(&p).ok())
        .collect();
    if s.is_empty() {
        return None;
    }
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let (mut mx, mut p95, mut mean) = (Vec::new(), Vec::new(), Vec::new());
    let mut dv = vec![0.0; s.len()];
    for _ in 0..DRAWS {
        let z = nalgebra::DVector::from_fn(crate::model::N_PARAMS, |_, _| {
            rand::RngExt::sample::<f64, _>(&mut rng, rand_distr::StandardNormal)
        });
        let d = &root * z;
        let delta = crate::model::ErrorVector::from_iterator(d.iter().copied());
        for (v, sk) in dv.iter_mut().zip(&s) {
            *v = (sk * delta).norm();
        }
        mean.push(dv.iter().sum::<f64>() / dv.len() as f64);
        dv.sort_by(f64::total_cmp);
        mx.push(dv[dv.len() - 1]);
        p95.push(crate::metrics::stats::quantile_sorted(&dv, 0.95));
    }
    let band = |v: &mut Vec<f64>| -> [f64; 3] {
        v.sort_by(f64::total_cmp);
        [0.5, 0.025, 0.975].map(|p| crate::metrics::stats::quantile_sorted(v, p))
    };
    Some(PredictedAccuracy {
        draws: DRAWS,
        points: s.len(),
        max_mm: band(&mut mx),
        p95_mm: band(&mut p95),
        mean_mm: band(&mut mean),
    })
}
