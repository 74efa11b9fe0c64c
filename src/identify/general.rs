//! Identifying any [`Mechanism`]'s errors from its passive joints'
//! readings: least squares in the convention's free directions, once at the
//! nominal machine (one linearisation) or by Gauss–Newton from there, each
//! step at the current estimate's exact kinematics. What the user holds
//! besides the readings ([`Holds`]): errors measured elsewhere, fixed at
//! their values, and a Gaussian prior on the free ones. Its checks: a
//! held-out prediction of poses left out of the fit ([`held_out`]) and the
//! accuracy the estimate's uncertainty leaves over a workspace
//! ([`predicted_accuracy`]). The hexapod's identify runs through it; the
//! Tricept's (`identify::gauss_newton`, fixed-size) is tested against it.
//!
//! Readings' σ are given per reading of a pose (file units); rows are
//! weighted by σ₀/σₖ, so σ₀ — the first reading's — is the scale the
//! residuals, the prior's weights and the covariance are stated on. With no
//! σ stated every row weighs 1 and σ₀ is the residuals' s.

use super::{analyse_named, Identifiability};
pub use crate::mechanism::general::predict;
use crate::mechanism::general::{column_of, error_of, worst_of};
use crate::mechanism::{Judged, Mechanism};
use nalgebra::{DMatrix, DVector, Vector3};

/// An identification's result.
#[derive(Debug, Clone)]
pub struct Identified {
    /// Every error of the mechanism (zero where the convention holds it, or
    /// the machine lacks it).
    pub errors: Vec<f64>,
    /// RMS of the weighted measured − predicted readings at the estimate,
    /// in the first reading's unit.
    pub residual_rms: f64,
    pub iterations: usize,
    /// The estimate's covariance over every error (mm², mm·deg, deg²):
    /// σ₀²·N·(JᵀWJ)⁻¹·Nᵀ with J the design at the estimate in the
    /// convention's free directions N, W the rows' weights (zero rows and
    /// columns where the convention holds an error or the machine lacks it).
    pub covariance: DMatrix<f64>,
    /// σ₀, the first reading's σ the covariance takes (file unit): the
    /// stated one, or without it the residuals' s = √(rss/(m − p)).
    pub sigma: f64,
    /// Readings less free errors (m − p).
    pub dof: usize,
    /// The errors held at measured values (their σ is 0).
    pub fixed: Vec<usize>,
}

/// What the user holds besides the readings: errors measured elsewhere
/// held at their values, and a Gaussian prior N(0, σp²) on every free
/// coordinate (σp in mm for lengths, degrees for angles).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Holds {
    /// (error index, value): only errors no frame choice changes
    /// ([`Mechanism::fixable`]).
    pub fixed: Vec<(usize, f64)>,
    pub prior_std_mm: Option<f64>,
    pub prior_std_deg: Option<f64>,
}

impl Holds {
    /// The prior's σ of error `j`'s coordinate (mm or degrees), if any.
    pub fn prior_std(&self, m: &impl Mechanism, j: usize) -> Option<f64> {
        if m.is_angle(j) {
            self.prior_std_deg
        } else {
            self.prior_std_mm
        }
    }
}

impl Identified {
    /// Each error's standard uncertainty (mm or degrees).
    pub fn std(&self) -> Vec<f64> {
        (0..self.errors.len())
            .map(|j| self.covariance[(j, j)].max(0.0).sqrt())
            .collect()
    }
}

/// The rank analysis of the design at the nominal machine over `targets`,
/// over the columns of the errors the machine has (the hexapod: rank 45 of
/// 54 with both encoders, 39 of 48 with one).
pub fn identifiability<M: Mechanism>(
    m: &M,
    targets: &[M::Target],
    rank_tolerance: f64,
) -> Result<Identifiability, String> {
    let names = m.error_names();
    let h = m.design(&vec![0.0; names.len()], targets)?;
    let present = m.present();
    let h = h.select_columns(&present);
    let names: Vec<&str> = present.iter().map(|&j| names[j].as_str()).collect();
    Ok(analyse_named(&h, rank_tolerance, &names))
}

/// The rank of the design in the convention's free directions (full when
/// the convention fixes exactly what the readings cannot see).
pub fn convention_rank<M: Mechanism>(
    m: &M,
    targets: &[M::Target],
    rank_tolerance: f64,
    holds: &Holds,
) -> Result<(usize, usize), String> {
    let zero = vec![0.0; m.error_names().len()];
    let h = m.design(&zero, targets)? * free_basis(m, holds);
    let free = h.ncols();
    let names: Vec<String> = (0..free).map(|c| format!("free{c}")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    Ok((analyse_named(&h, rank_tolerance, &names).rank, free))
}

/// The rows' weights σ₀/σₖ over `rows` stacked readings of `per` a pose,
/// and σ₀: `sigma` is empty (unstated: every weight 1, σ₀ None), one σ for
/// every reading, or one per reading of a pose (file units).
fn weights(sigma: &[f64], per: usize, rows: usize) -> Result<(Vec<f64>, Option<f64>), String> {
    if sigma.is_empty() {
        return Ok((vec![1.0; rows], None));
    }
    if sigma.len() != 1 && sigma.len() != per {
        return Err(format!(
            "{} readings' σ given for {per} readings a pose",
            sigma.len()
        ));
    }
    if sigma.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err("a reading's σ must be finite and positive".into());
    }
    let s0 = sigma[0];
    let w = (0..rows)
        .map(|i| s0 / sigma[if sigma.len() == 1 { 0 } else { i % per }])
        .collect();
    Ok((w, Some(s0)))
}

/// Identify from `measured` readings (stacked as [`predict`]) at
/// `targets`: `iterations` = 1 is one linearisation at the nominal machine;
/// more re-linearise at the estimate until the step is below 1e-10. The
/// covariance takes the readings' σ `sigma` when given (see [`weights`]),
/// else the residuals'. `holds`: errors fixed at their values (taken out of
/// the free directions, their part of the readings with them) and a prior,
/// read as more rows y/σp = 0 of the least squares (each step as −y/σp, so
/// the iteration converges to the MAP of the exact model; its covariance
/// (JᵀWJ/σ₀² + I/σp²)⁻¹). A prior needs `sigma` (readings and prior on one
/// scale).
pub fn identify<M: Mechanism>(
    m: &M,
    targets: &[M::Target],
    measured: &DVector<f64>,
    iterations: usize,
    sigma: &[f64],
    holds: &Holds,
) -> Result<Identified, String> {
    let mut errors = vec![0.0; m.error_names().len()];
    for &(j, v) in &holds.fixed {
        errors[j] = v;
    }
    let n = free_basis(m, holds);
    let per = m.reading_facts().len();
    if measured.len() != per * targets.len() {
        return Err(format!(
            "{} readings for {} poses of {per}",
            measured.len(),
            targets.len()
        ));
    }
    let facts = m.reading_facts();
    if sigma.is_empty() && facts.iter().any(|f| f.quantity != facts[0].quantity) {
        return Err(
            "readings of different units (angles and lengths) need each one's σ stated: the residuals cannot give one σ for both".into(),
        );
    }
    let (w, stated) = weights(sigma, per, measured.len())?;
    // The prior's weight of each free coordinate, in σ₀'s units.
    let prior: Vec<f64> = (0..n.ncols())
        .map(|c| match (holds.prior_std(m, error_of(&n, c)), stated) {
            (Some(sp), Some(s)) => s / sp,
            _ => 0.0,
        })
        .collect();
    if (holds.prior_std_mm.is_some() || holds.prior_std_deg.is_some()) && stated.is_none() {
        return Err("a prior needs the readings' σ".into());
    }
    let weigh = |mut r: DVector<f64>| {
        for (x, w) in r.iter_mut().zip(&w) {
            *x *= w;
        }
        r
    };
    let weigh_rows = |mut h: DMatrix<f64>| {
        for (i, w) in w.iter().enumerate() {
            h.row_mut(i).scale_mut(*w);
        }
        h
    };
    let fixed_part = DVector::from_column_slice(&errors);
    let mut y = DVector::zeros(n.ncols());
    let mut used = 0;
    for _ in 0..iterations.max(1) {
        used += 1;
        let r = weigh(measured - predict(m, &errors, targets)?);
        let h = weigh_rows(m.design(&errors, targets)? * &n);
        let step = least_squares(&augment(&h, &prior), &augment_rhs(&r, &y, &prior))?;
        y += &step;
        let e = &fixed_part + &n * &y;
        errors.copy_from_slice(e.as_slice());
        if step.amax() < 1e-10 {
            break;
        }
    }
    let r = weigh(measured - predict(m, &errors, targets)?);
    let j = weigh_rows(m.design(&errors, targets)? * &n);
    let (rows, p) = (j.nrows(), j.ncols());
    let dof = rows.saturating_sub(p);
    let sigma = match stated {
        Some(s) => s,
        None if dof > 0 => (r.norm_squared() / dof as f64).sqrt(),
        None => 0.0,
    };
    // (JᵀWJ + prior)⁻¹ through the column-scaled SVD, as the fit itself.
    let ja = augment(&j, &prior);
    let norms: Vec<f64> = (0..p).map(|c| ja.column(c).norm()).collect();
    let scale = guarded_scale(&norms, norms.iter().copied().fold(0.0, f64::max));
    let js = DMatrix::from_fn(ja.nrows(), p, |i, c| ja[(i, c)] / scale[c]);
    let svd = js.svd(false, true);
    let v_t = svd.v_t.as_ref().ok_or("the SVD gave no V")?;
    let inv = DMatrix::from_fn(p, p, |a, b| {
        let acc: f64 = (0..svd.singular_values.len())
            .map(|k| v_t[(k, a)] * v_t[(k, b)] / svd.singular_values[k].powi(2))
            .sum();
        acc / (scale[a] * scale[b])
    });
    let covariance = &n * inv * n.transpose() * (sigma * sigma);
    Ok(Identified {
        errors,
        residual_rms: (r.norm_squared() / r.len().max(1) as f64).sqrt(),
        iterations: used,
        covariance,
        sigma,
        dof,
        fixed: holds.fixed.iter().map(|&(j, _)| j).collect(),
    })
}

/// The convention's free directions less the fixed errors' columns.
pub fn free_basis(m: &impl Mechanism, holds: &Holds) -> DMatrix<f64> {
    let n = m.free_directions();
    let keep: Vec<usize> = (0..n.ncols())
        .filter(|&c| {
            !holds
                .fixed
                .iter()
                .any(|&(j, _)| column_of(&n, j) == Some(c))
        })
        .collect();
    n.select_columns(&keep)
}

/// H with the prior's rows (diag(w), w = σ/σp; none where w is 0) below.
fn augment(h: &DMatrix<f64>, w: &[f64]) -> DMatrix<f64> {
    let rows: Vec<usize> = (0..w.len()).filter(|&c| w[c] > 0.0).collect();
    let mut a = h.clone().resize_vertically(h.nrows() + rows.len(), 0.0);
    for (k, &c) in rows.iter().enumerate() {
        a[(h.nrows() + k, c)] = w[c];
    }
    a
}

/// The residual with the prior's rows: −w·y (the step towards y = 0).
fn augment_rhs(r: &DVector<f64>, y: &DVector<f64>, w: &[f64]) -> DVector<f64> {
    let extra: Vec<f64> = (0..w.len())
        .filter(|&c| w[c] > 0.0)
        .map(|c| -w[c] * y[c])
        .collect();
    let mut out = r.clone().resize_vertically(r.len() + extra.len(), 0.0);
    out.rows_mut(r.len(), extra.len()).copy_from_slice(&extra);
    out
}

/// The accuracy the compensated machine is predicted to reach over the
/// workspace from the estimate's uncertainty alone (first order, the
/// convention's frames, as the study judges): for each of [`DRAWS`] draws
/// of the estimate's error from its covariance, the largest of each judged
/// quantity ([`Mechanism::judged`]: the tool point's position, the
/// platform's orientation) over the workspace; their median and 95th
/// percentile over the draws.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictedAccuracy {
    pub draws: usize,
    pub poses: usize,
    /// Per judged quantity, (median, 95th percentile) over draws of its
    /// largest value over the workspace, in its unit.
    pub worst: Vec<(Judged, [f64; 2])>,
}

impl PredictedAccuracy {
    /// (median, p95) of the quantity `name` ("position", "orientation").
    pub fn of(&self, name: &str) -> Option<[f64; 2]> {
        self.worst.iter().find(|(q, _)| q.name == name).map(|x| x.1)
    }
}

/// Draws of the estimate's error [`predicted_accuracy`] takes.
pub const DRAWS: usize = 1000;

/// [`PredictedAccuracy`] of an estimate with `covariance` (errors × errors,
/// mm and degrees) over `workspace`, the tool point `tool`; the draws are
/// seeded, so the statement is the same bytes every run.
pub fn predicted_accuracy<M: Mechanism>(
    m: &M,
    covariance: &DMatrix<f64>,
    workspace: &[M::Target],
    tool: &Vector3<f64>,
) -> Result<PredictedAccuracy, String> {
    use rand::SeedableRng;
    let errors = covariance.nrows();
    let judged = m.judged();
    let rows = 3 * judged.len();
    let eig = covariance.clone().symmetric_eigen();
    let root =
        &eig.eigenvectors * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let mut stacked = DMatrix::zeros(rows * workspace.len(), errors);
    for (w, pose) in workspace.iter().enumerate() {
        let s = m
            .sensitivity(pose, tool)
            .map_err(|e| format!("workspace pose {}: {e}", w + 1))?;
        stacked.rows_mut(rows * w, rows).copy_from(&s);
    }
    let map = stacked * root;
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let mut worst: Vec<Vec<f64>> = vec![Vec::with_capacity(DRAWS); judged.len()];
    for _ in 0..DRAWS {
        let z = DVector::from_fn(errors, |_, _| {
            rand::RngExt::sample::<f64, _>(&mut rng, rand_distr::StandardNormal)
        });
        for (q, v) in worst.iter_mut().zip(worst_of(judged, &(&map * z))) {
            q.push(v);
        }
    }
    let stat = |mut v: Vec<f64>| -> [f64; 2] {
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        [at(0.5), at(0.95)]
    };
    Ok(PredictedAccuracy {
        draws: DRAWS,
        poses: workspace.len(),
        worst: judged
            .iter()
            .copied()
            .zip(worst.into_iter().map(stat))
            .collect(),
    })
}

/// Poses left out in folds: each fold's readings predicted from a fit to
/// the other poses (the same Gauss–Newton, holds and σ), against what was
/// read, in units of the prediction's own standard deviation √(σₖ² +
/// (J·C·Jᵀ)ᵢᵢ), C the fold's fit's covariance. About 1 when the model
/// predicts poses it was not fitted to as well as the readings' σ allows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldOut {
    pub folds: usize,
    /// Readings predicted.
    pub readings: usize,
    /// RMS of the standardised prediction errors.
    pub rms_z: f64,
    pub max_abs_z: f64,
    /// The pose (index into the targets) with the largest.
    pub worst_pose: usize,
    /// Folds skipped because the poses left do not determine the free
    /// errors.
    pub folds_skipped: usize,
}

/// Folds of the held-out check; it needs twice as many poses.
pub const HELD_OUT_FOLDS: usize = 5;

/// The held-out check (None with fewer than 2 × [`HELD_OUT_FOLDS`]
/// distinct poses, or when every fold is skipped). Row j is distinct pose
/// `groups[j]` where a log repeats poses ([`super::repeats::Repeats::of_row`];
/// empty: each row its own), and a fold leaves out whole poses (distinct
/// pose g in fold g mod 5), so no fold predicts a pose the fit has read.
pub fn held_out<M: Mechanism>(
    m: &M,
    targets: &[M::Target],
    measured: &DVector<f64>,
    iterations: usize,
    sigma: &[f64],
    holds: &Holds,
    groups: &[usize],
) -> Option<HeldOut> {
    let n = targets.len();
    let per = m.reading_facts().len();
    let group = |j: usize| groups.get(j).copied().unwrap_or(j);
    let distinct = if groups.is_empty() {
        n
    } else {
        groups.iter().max().map_or(0, |g| g + 1)
    };
    if distinct < 2 * HELD_OUT_FOLDS || weights(sigma, per, per).is_err() || sigma.is_empty() {
        return None;
    }
    let sigma_of = |i: usize| sigma[if sigma.len() == 1 { 0 } else { i % per }];
    let (mut sum, mut count, mut worst, mut worst_pose, mut skipped) = (0.0, 0, 0.0f64, 0, 0);
    for f in 0..HELD_OUT_FOLDS {
        let (held, kept): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&j| group(j) % HELD_OUT_FOLDS == f);
        let pick = |poses: &[usize]| -> (Vec<M::Target>, DVector<f64>) {
            let t: Vec<M::Target> = poses.iter().map(|&j| targets[j]).collect();
            let l = DVector::from_iterator(
                poses.len() * per,
                poses
                    .iter()
                    .flat_map(|&j| (j * per..(j + 1) * per).map(|i| measured[i])),
            );
            (t, l)
        };
        let (kt, kl) = pick(&kept);
        let Ok(fit) = identify(m, &kt, &kl, iterations, sigma, holds) else {
            skipped += 1;
            continue;
        };
        let (ht, hl) = pick(&held);
        let (Ok(pred), Ok(j)) = (predict(m, &fit.errors, &ht), m.design(&fit.errors, &ht)) else {
            skipped += 1;
            continue;
        };
        let jc = &j * &fit.covariance;
        for i in 0..hl.len() {
            let var = sigma_of(i).powi(2) + jc.row(i).dot(&j.row(i));
            let z = (hl[i] - pred[i]) / var.sqrt();
            sum += z * z;
            count += 1;
            if z.abs() > worst {
                worst = z.abs();
                worst_pose = held[i / per];
            }
        }
    }
    (count > 0).then(|| HeldOut {
        folds: HELD_OUT_FOLDS,
        readings: count,
        rms_z: (sum / count as f64).sqrt(),
        max_abs_z: worst,
        worst_pose,
        folds_skipped: skipped,
    })
}

/// Each column's scale: its norm, or for a column of round-off (norm at
/// most 1e-12 of the largest) the largest, so that it stays round-off
/// beside the others whatever the units: no reading sees its error.
fn guarded_scale(norms: &[f64], largest: f64) -> Vec<f64> {
    norms
        .iter()
        .map(|&n| {
            if n > 1e-12 * largest {
                n
            } else {
                largest.max(1e-300)
            }
        })
        .collect()
}

/// argmin ‖H·x − r‖ by an SVD of the column-scaled H ([`guarded_scale`]);
/// Err when H is rank-deficient (the poses do not determine the free
/// errors).
fn least_squares(h: &DMatrix<f64>, r: &DVector<f64>) -> Result<DVector<f64>, String> {
    let norms: Vec<f64> = (0..h.ncols()).map(|c| h.column(c).norm()).collect();
    let largest = norms.iter().copied().fold(0.0, f64::max);
    let scale = guarded_scale(&norms, largest);
    let hs = DMatrix::from_fn(h.nrows(), h.ncols(), |i, j| h[(i, j)] / scale[j]);
    let svd = hs.svd(true, true);
    let top = svd.singular_values.max();
    if svd.singular_values.min() <= 1e-9 * top {
        return Err(format!(
            "the poses do not determine the errors: rank {} of {} free",
            svd.rank(1e-9 * top),
            h.ncols()
        ));
    }
    let x = svd.solve(r, 0.0)?;
    Ok(DVector::from_fn(h.ncols(), |j, _| x[j] / scale[j]))
}

#[cfg(test)]
#[path = "general_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "general_tricept_tests.rs"]
mod tricept_tests;
