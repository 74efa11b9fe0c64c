//! What `identify` checks of its own result: the fit's misfit against the
//! declared sensors (χ²), poses left out in folds, and the accuracy the
//! compensated machine is predicted to reach. The three share the
//! sensors' covariance Σ at the poses and the fit's residual, built once
//! ([`FitInputs`], [`checks_of`]); Σ is held factored
//! ([`crate::sensors::ObservationCovariance`]), so each costs O(rows).
//! Any mechanism's calibration ([`CalibrationOf`]) is checked here: what a
//! check reads of its config comes as [`Folds`] and [`Grid`].

use super::CalibrationOf;
use crate::identify::second_class::SecondClassSolver;
use crate::identify::{Method, Weighting};
use crate::io::data_line;
use crate::mechanism::{AxisAngles, Homed, PoseReadings};
use crate::sensors::{ObservationCovariance, SensorModel};
use nalgebra::{DMatrix, DVector, Vector3};

/// What the checks share, each built once.
pub struct FitInputs {
    /// The declared sensors' covariance of the homed observation.
    pub sigma: ObservationCovariance,
    /// The residual the estimator minimised.
    pub resid: DVector<f64>,
}

/// What the held-out folds read of a config: the sensors it declares (a
/// fold's weighting where its readings fell), its estimator and the rank
/// tolerance.
pub struct Folds<'a, const R: usize> {
    pub sensors: &'a SensorModel<R>,
    pub method: Method,
    pub rank_tolerance: f64,
}

/// Where the predicted accuracy is judged: the nominal machine, the
/// workspace's points (mm; one its nominal machine cannot reach is left
/// out) and the reference pose's target (None: no pose, no prediction).
pub struct Grid<'a, T: AxisAngles<P, R, A>, const P: usize, const R: usize, const A: usize> {
    pub homed: &'a Homed<'a, T, P, R>,
    pub points: &'a [Vector3<f64>],
    pub reference: Option<Vector3<f64>>,
}

/// Every check of a calibration (identifiability.json's `checks`).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Checks {
    pub misfit: Option<Misfit>,
    pub held_out: Option<HeldOut>,
    pub predicted_accuracy: Option<PredictedAccuracy>,
}

/// All three checks from one Σ and one residual (None: the estimated
/// machine cannot reach a pose); the predicted accuracy is scaled by the
/// misfit when its test rejects.
pub fn checks_of<T, Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
    fit: Option<FitInputs>,
    folds: &Folds<R>,
    grid: &Grid<T, P, R, A>,
) -> Checks
where
    T: AxisAngles<P, R, A>,
    J: PoseReadings<R> + Clone,
{
    let Some(f) = fit else {
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
        held_out: held_out_of(folds, cal, &f),
        predicted_accuracy: predicted_of(grid, cal, scale),
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

/// The misfit of `cal` (None without degrees of freedom or a positive
/// definite Σ).
pub fn misfit_of<Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
    f: &FitInputs,
) -> Option<Misfit> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let w = Weighting::whiten(&f.sigma).ok()?;
    let rw = w.apply_vector(&f.resid);
    let h = full_design(cal);
    // The columns the fit moved: identifiable from the readings and not
    // fixed (and the identified angles).
    let fixed = cal.solver.constraints().fixed;
    let active: Vec<usize> = (0..h.ncols())
        .filter(|&c| match c.checked_sub(P) {
            None => cal.solver.analysis.identifiable[c] && fixed[c].is_none(),
            Some(a) => cal.axes.as_ref().is_some_and(|x| x.identifiable[a]),
        })
        .collect();
    // With a prior the fit is the MAP: its own χ², the whitened residual
    // plus each free error's (x̂/σp)², on as many degrees of freedom as
    // rows (the prior adds one pseudo-reading per error it estimates). A
    // prior far tighter than the machine's errors then shows as misfit.
    if let Some(sp) = cal.solver.constraints().prior_std_mm {
        let prior: f64 = (0..P)
            .filter(|&c| fixed[c].is_none())
            .map(|c| (cal.estimate.values[c] / sp).powi(2))
            .sum();
        let chi2 = rw.norm_squared() + prior;
        let dof = rw.len().max(1);
        let p_value = ChiSquared::new(dof as f64).ok()?.sf(chi2);
        return Some(Misfit {
            chi2,
            dof,
            p_value,
            ratio: (chi2 / dof as f64).sqrt(),
            rejected: p_value < MISFIT_LEVEL,
        });
    }
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

/// The design of every unknown of the fit: the errors', and the angles'
/// beside it when they were identified.
fn full_design<Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
) -> DMatrix<f64> {
    let h = cal.solver.design();
    match &cal.axes {
        None => h.clone(),
        Some(a) => {
            let h3 = a.solver.design();
            let mut full = DMatrix::zeros(h.nrows(), P + A);
            full.columns_mut(0, P).copy_from(h);
            full.columns_mut(P, A).copy_from(h3);
            full
        }
    }
}

/// Every estimated value (the errors, then the angles when identified).
fn full_values<Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
) -> DVector<f64> {
    let e = cal.estimate.values.iter().copied();
    match &cal.axes {
        None => DVector::from_iterator(P, e),
        Some(a) => DVector::from_iterator(P + A, e.chain(a.angles.iter().copied())),
    }
}

/// What compensate will refuse of a calibration, each in words: the
/// identified errors known to worse than
/// [`crate::store::inputs::MAX_USABLE_UNCERTAINTY_MM`] and the identified
/// angles to worse than its degrees' bound.
pub fn loose<Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
) -> Vec<String> {
    use crate::store::inputs::{MAX_USABLE_UNCERTAINTY_DEG, MAX_USABLE_UNCERTAINTY_MM};
    let est = &cal.estimate;
    let mut loose: Vec<String> = cal
        .unknowns
        .errors
        .iter()
        .enumerate()
        .filter(|&(k, _)| est.identifiable[k] && est.std_mm[k] > MAX_USABLE_UNCERTAINTY_MM)
        .map(|(k, n)| format!("{n} ± {:.3} mm", est.std_mm[k]))
        .collect();
    if let Some(a) = &cal.axes {
        loose.extend(
            cal.unknowns
                .angles
                .iter()
                .enumerate()
                .filter(|&(k, _)| a.identifiable[k] && a.std_deg[k] > MAX_USABLE_UNCERTAINTY_DEG)
                .map(|(k, n)| format!("{n} ± {:.4}°", a.std_deg[k])),
        );
    }
    loose
}

/// The estimate's covariance (the errors, then the angles when
/// identified; mm², degrees for the angles): op·Σ·opᵀ under the stated Σ
/// at the measured readings, or with a prior its posterior; zero rows for
/// errors not estimated (unidentifiable or fixed).
pub fn estimate_covariance<Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
) -> DMatrix<f64> {
    if let Some(c) = &cal.covariance {
        return c.clone();
    }
    if cal.solver.constraints().prior_std_mm.is_some() {
        cal.solver.posterior_covariance()
    } else {
        cal.stated.sandwich(&full_operator(cal))
    }
}

/// The operator of every unknown (P or P + A rows).
fn full_operator<Q, J, const P: usize, const R: usize, const A: usize>(
    cal: &CalibrationOf<Q, J, P, R, A>,
) -> DMatrix<f64> {
    match &cal.axes {
        None => cal.solver.operator(),
        Some(a) => a.solver.operator(&cal.solver),
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
    /// Readings predicted (R per held-out pose).
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

/// The held-out check of `cal` with the estimator and sensors of `folds`
/// (None without enough poses).
pub fn held_out_of<Q, J, const P: usize, const R: usize, const A: usize>(
    folds: &Folds<R>,
    cal: &CalibrationOf<Q, J, P, R, A>,
    f: &FitInputs,
) -> Option<HeldOut>
where
    J: PoseReadings<R> + Clone,
{
    let n = cal.measured.len();
    // Pose j's distinct pose: a fold leaves out whole poses.
    let group = |j: usize| cal.groups.get(j).copied().unwrap_or(j);
    let distinct = cal.groups.iter().max().map_or(n, |g| g + 1);
    if distinct < 2 * HELD_OUT_FOLDS {
        return None;
    }
    let h = full_design(cal);
    // The observation linearised where the fit ended, less the fixed
    // errors' part (they are held, not predicted: a fold reads the rest).
    let fixed = cal.solver.constraints().fixed;
    let values = full_values(cal);
    let held_values = nalgebra::DVector::from_fn(h.ncols(), |c, _| {
        if c < P && fixed[c].is_some() {
            values[c]
        } else {
            0.0
        }
    });
    let y = &f.resid + &h * (values - &held_values);
    let rank = cal
        .axes
        .as_ref()
        .map_or(cal.solver.analysis.rank, |a| a.solver.rank(&cal.solver));
    let sigma = &f.sigma;
    let method = folds.method;
    let (mut sum, mut count, mut worst, mut worst_pose, mut skipped) = (0.0, 0, 0.0f64, 0, 0);
    for f in 0..HELD_OUT_FOLDS {
        let held: Vec<usize> = (1..n).filter(|&j| group(j) % HELD_OUT_FOLDS == f).collect();
        let kept: Vec<usize> = (1..n).filter(|&j| group(j) % HELD_OUT_FOLDS != f).collect();
        let rows_of = |poses: &[usize]| -> Vec<usize> {
            poses
                .iter()
                .flat_map(|&j| (0..R).map(move |k| R * (j - 1) + k))
                .collect()
        };
        let (rh, rk) = (rows_of(&held), rows_of(&kept));
        let hk = h.select_rows(&rk);
        // The fold's weighting where its readings fell (as the fit's own).
        let joints: Vec<J> = std::iter::once(cal.measured[0].clone())
            .chain(kept.iter().map(|&j| cal.measured[j].clone()))
            .collect();
        let tol = folds.rank_tolerance;
        let Ok(solver) = method.solver(
            (folds.sensors, &joints),
            &hk.columns(0, P).into_owned(),
            tol,
            (cal.solver.constraints(), &cal.unknowns.errors),
        ) else {
            skipped += 1;
            continue;
        };
        // With the angles, the fold identifies them too.
        let (op, fold_rank) = if cal.axes.is_some() {
            let h3k = hk.columns(P, A).into_owned();
            match SecondClassSolver::<P, A, R>::named(&solver, &h3k, tol, &cal.unknowns.angles) {
                Ok(ext) => (ext.operator(&solver), ext.rank(&solver)),
                Err(_) => {
                    skipped += 1;
                    continue;
                }
            }
        } else {
            (solver.operator(), solver.analysis.rank)
        };
        if fold_rank < rank {
            skipped += 1;
            continue;
        }
        let hh = h.select_rows(&rh);
        let yk = nalgebra::DVector::from_iterator(rk.len(), rk.iter().map(|&r| y[r]));
        let pred = &hh * (&op * &yk);
        let variances = prediction_variances(sigma, &hh, &op, &rh, &rk);
        for (i, &r) in rh.iter().enumerate() {
            let sd = variances[i].max(0.0).sqrt();
            if sd <= 0.0 || sd.is_nan() {
                continue;
            }
            let z = (y[r] - pred[i]) / sd;
            sum += z * z;
            count += 1;
            if z.abs() > worst {
                worst = z.abs();
                worst_pose = r / R + 1;
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

/// The variance of each held-out row's prediction error y_r − hh_r·G·y_kept
/// (G = `op`, the fold's operator on the kept rows `rk`; `hh` the held rows'
/// design, rows `rh`): Σ_rr − 2·hh_r·(Σ·X)_r + hh_r·C·hh_rᵀ with X = Gᵀ
/// scattered to the kept rows and C = Xᵀ·Σ·X, all through the factored Σ
/// (O(rows), never the rows × rows matrix).
fn prediction_variances(
    sigma: &ObservationCovariance,
    hh: &nalgebra::DMatrix<f64>,
    op: &nalgebra::DMatrix<f64>,
    rh: &[usize],
    rk: &[usize],
) -> Vec<f64> {
    let mut x = nalgebra::DMatrix::zeros(sigma.rows(), op.nrows());
    for (c, &r) in rk.iter().enumerate() {
        x.set_row(r, &op.column(c).transpose());
    }
    let sx = sigma.mul(&x);
    let cc = x.transpose() * &sx;
    let diag = sigma.diagonal();
    rh.iter()
        .enumerate()
        .map(|(i, &r)| {
            let hr = hh.row(i);
            let cross = (hr * sx.row(r).transpose())[(0, 0)];
            let quad = (hr * &cc * hr.transpose())[(0, 0)];
            diag[r] - 2.0 * cross + quad
        })
        .collect()
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
    /// The relative part: p95 over the workspace of the error less the
    /// reference pose's (what a check by the passive limb can test).
    pub relative_p95_mm: [f64; 3],
    /// The absolute part: the error at the reference pose, shared by every
    /// pose (what only an external point tests).
    pub at_reference_mm: [f64; 3],
}

const DRAWS: usize = 1000;

/// [`PredictedAccuracy`] over `grid` with the estimate's covariance
/// op·Σ·opᵀ scaled by `scale²` (the misfit's, when its test rejects).
pub fn predicted_of<T, Q, J, const P: usize, const R: usize, const A: usize>(
    grid: &Grid<T, P, R, A>,
    cal: &CalibrationOf<Q, J, P, R, A>,
    scale: f64,
) -> Option<PredictedAccuracy>
where
    T: AxisAngles<P, R, A>,
{
    use rand::SeedableRng;
    // With a prior the estimate's error includes the prior's part (what the
    // readings leave): the posterior covariance; else op·Σ·opᵀ.
    let cov = estimate_covariance(cal) * (scale * scale);
    let p = cov.nrows();
    let eig = cov.symmetric_eigen();
    let root = &eig.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let (layout, nominal) = (grid.homed.layout(), grid.homed.nominal());
    // Each point's sensitivity of the tool point to every unknown (the
    // angles' columns when they were identified); None where the nominal
    // machine cannot go.
    let sensitivity = |r: &Vector3<f64>| -> Option<DMatrix<f64>> {
        let se = T::position_sensitivity(layout, r).ok()?;
        let mut s = DMatrix::zeros(3, p);
        s.columns_mut(0, P).copy_from(&se);
        if p > P {
            let sa = T::position_angle_sensitivity(nominal, r).ok()?;
            s.columns_mut(P, A).copy_from(&sa);
        }
        Some(s)
    };
    let s: Vec<DMatrix<f64>> = grid.points.iter().filter_map(sensitivity).collect();
    if s.is_empty() {
        return None;
    }
    // At the reference pose: the part every homed reading shares, which
    // only an external point tests (docs/method.md §18).
    let s0 = sensitivity(&grid.reference?)?;
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let (mut mx, mut p95, mut mean) = (Vec::new(), Vec::new(), Vec::new());
    let (mut rel95, mut at_ref) = (Vec::new(), Vec::new());
    let mut dv = vec![0.0; s.len()];
    let mut rel = vec![0.0; s.len()];
    for _ in 0..DRAWS {
        let z = nalgebra::DVector::from_fn(p, |_, _| {
            rand::RngExt::sample::<f64, _>(&mut rng, rand_distr::StandardNormal)
        });
        let delta = &root * z;
        let e0 = &s0 * &delta;
        for ((v, w), sk) in dv.iter_mut().zip(rel.iter_mut()).zip(&s) {
            let e = sk * &delta;
            *v = e.norm();
            *w = (e - &e0).norm();
        }
        mean.push(dv.iter().sum::<f64>() / dv.len() as f64);
        dv.sort_by(f64::total_cmp);
        mx.push(dv[dv.len() - 1]);
        p95.push(crate::metrics::stats::quantile_sorted(&dv, 0.95));
        rel.sort_by(f64::total_cmp);
        rel95.push(crate::metrics::stats::quantile_sorted(&rel, 0.95));
        at_ref.push(e0.norm());
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
        relative_p95_mm: band(&mut rel95),
        at_reference_mm: band(&mut at_ref),
    })
}

/// Refuse a log whose poses identify fewer error combinations than the
/// config's own pose layout does (`layout`, its rank; None: no layout to
/// compare with): the estimate would move along the null directions with
/// nothing to hold it (12 rows for 15 errors fit exactly and give tens of
/// millimetres). The sentence names the rows, the ranks and how many more
/// poses at the least.
pub fn refuse_below_layout<const P: usize, const R: usize>(
    solver: &crate::identify::Solver<P, R>,
    layout: Option<usize>,
    poses: usize,
    file: crate::io::Source,
) -> crate::error::Result<()> {
    let a = &solver.analysis;
    let Some(reach) = layout else {
        return Ok(());
    };
    if a.rank >= reach {
        return Ok(());
    }
    // One sentence a first-time user can act on: how many rows, how many
    // combinations, how many more poses at the least. The null directions
    // themselves are long; `identifiability` lists them.
    let more = match reach.saturating_sub(solver.rows()).div_ceil(R) {
        0 => "log poses spread over more of the workspace".to_string(),
        n => format!("log at least {n} more pose(s) spread over the workspace"),
    };
    Err(crate::error::Error::csv(
        file.name,
        format!(
            "{poses} poses ({} observation rows) identify {} of the {reach} error combinations this machine's own pose layout identifies, so the fit would be underdetermined: {more} (design-poses proposes a set), or identify from the config's [poses]",
            solver.rows(),
            a.rank,
        ),
    ))
}

#[cfg(test)]
#[path = "checks_tests.rs"]
mod tests;
