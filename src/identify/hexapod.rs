//! Identifying the hexapod's errors from its encoders' readings: least
//! squares in the convention's free directions, once at the nominal machine
//! (one linearisation) or by Gauss–Newton from there, each step at the
//! current estimate's exact kinematics. What the user holds besides the
//! readings ([`Holds`]): errors measured elsewhere, fixed at their values,
//! and a Gaussian prior on the free ones.

use super::{analyse_named, Identifiability};
use crate::mechanism::hexapod::convention::{basis, column_of, error_of};
use crate::mechanism::hexapod::design::design;
use crate::mechanism::hexapod::kinematics::{tool_sensitivity, worst_of};
use crate::mechanism::hexapod::{is_angle, Errors, Hexapod, Pose, N_ERRORS, PER_LEG};
use nalgebra::{DMatrix, DVector, Vector3};

/// An identification's result.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The 54 errors (zero where the convention holds them, or an encoder
    /// is absent).
    pub errors: Errors,
    /// RMS of measured − predicted readings at the estimate, degrees.
    pub residual_rms_deg: f64,
    pub iterations: usize,
    /// The estimate's covariance over the 54 errors (mm², mm·deg, deg²):
    /// σ²·N·(JᵀJ)⁻¹·Nᵀ with J the design at the estimate in the
    /// convention's free directions N and σ the readings' (zero rows and
    /// columns where the convention holds an error or an encoder is absent).
    pub covariance: DMatrix<f64>,
    /// The readings' σ the covariance takes, degrees: the stated one, or
    /// without it the residuals' s = √(rss/(m − p)).
    pub sigma_deg: f64,
    /// Readings less free errors (m − p).
    pub dof: usize,
    /// The errors held at measured values (their σ is 0).
    pub fixed: Vec<usize>,
}

/// What the user holds besides the readings: errors measured elsewhere
/// held at their values, and a Gaussian prior N(0, σp²) on every free
/// coordinate (σp in mm for lengths, degrees for the encoders' zeros).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Holds {
    /// (error index, value): only errors no frame choice changes (the leg
    /// offsets and the encoders' zeros, [`fixable`]).
    pub fixed: Vec<(usize, f64)>,
    pub prior_std_mm: Option<f64>,
    pub prior_std_deg: Option<f64>,
}

impl Holds {
    /// The prior's σ of error `j`'s coordinate (mm or degrees), if any.
    pub fn prior_std(&self, j: usize) -> Option<f64> {
        if is_angle(j) {
            self.prior_std_deg
        } else {
            self.prior_std_mm
        }
    }
}

/// Whether error `j` may be fixed at a measured value: a leg's offset or
/// an encoder's zero, which no choice of frame changes. A joint centre's
/// error is in the frames the convention picks (b1 and p1 nominal), which a
/// measurement elsewhere does not share.
pub fn fixable(j: usize) -> bool {
    j % PER_LEG >= 6
}

impl Identified {
    /// Each error's standard uncertainty (mm or degrees).
    pub fn std(&self) -> Errors {
        std::array::from_fn(|j| self.covariance[(j, j)].max(0.0).sqrt())
    }
}

/// The rank analysis of the design at the nominal machine over `targets`,
/// over the 54 errors' columns (those of an absent encoder are zero, so
/// rank 45 of 54 with both encoders, 39 of 48 with one).
pub fn identifiability(
    hex: &Hexapod,
    targets: &[Pose],
    rank_tolerance: f64,
) -> Result<Identifiability, String> {
    let h = design(hex, &[0.0; N_ERRORS], targets)?;
    let present = hex.error_indices();
    let names = crate::mechanism::hexapod::error_names();
    let h = h.select_columns(&present);
    let names: Vec<&str> = present.iter().map(|&j| names[j].as_str()).collect();
    Ok(analyse_named(&h, rank_tolerance, &names))
}

/// The rank of the design in the convention's free directions (full when
/// the convention fixes exactly what the readings cannot see).
pub fn convention_rank(
    hex: &Hexapod,
    targets: &[Pose],
    rank_tolerance: f64,
    holds: &Holds,
) -> Result<(usize, usize), String> {
    let h = design(hex, &[0.0; N_ERRORS], targets)? * free_basis(hex, holds);
    let free = h.ncols();
    let names: Vec<String> = (0..free).map(|c| format!("free{c}")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    Ok((analyse_named(&h, rank_tolerance, &names).rank, free))
}

/// Every target's readings of the machine with `errors`, stacked.
pub fn predict(hex: &Hexapod, errors: &Errors, targets: &[Pose]) -> Result<DVector<f64>, String> {
    let mut out = Vec::with_capacity(hex.readings_per_pose() * targets.len());
    for (j, t) in targets.iter().enumerate() {
        out.extend(
            hex.readings(errors, t)
                .map_err(|e| format!("pose {}: {e}", j + 1))?,
        );
    }
    Ok(DVector::from_vec(out))
}

/// Identify from `measured` readings (stacked as [`predict`]) at
/// `targets`: `iterations` = 1 is one linearisation at the nominal machine;
/// more re-linearise at the estimate until the step is below 1e-10. The
/// covariance takes the readings' σ `sigma_deg` when given, else the
/// residuals'. `holds`: errors fixed at their values (taken out of the free
/// directions, their part of the readings with them) and a prior, read as
/// more rows y/σp = 0 of the least squares (each step as −y/σp, so the
/// iteration converges to the MAP of the exact model; its covariance
/// (JᵀJ/σ² + I/σp²)⁻¹). A prior needs `sigma_deg` (readings and prior on
/// one scale).
pub fn identify(
    hex: &Hexapod,
    targets: &[Pose],
    measured: &DVector<f64>,
    iterations: usize,
    sigma_deg: Option<f64>,
    holds: &Holds,
) -> Result<Identified, String> {
    let mut errors = [0.0; N_ERRORS];
    for &(j, v) in &holds.fixed {
        errors[j] = v;
    }
    let n = free_basis(hex, holds);
    // The prior's weight of each free coordinate, in readings' σ units.
    let stated = sigma_deg.filter(|s| *s > 0.0);
    let prior: Vec<f64> = (0..n.ncols())
        .map(|c| match (holds.prior_std(error_of(&n, c)), stated) {
            (Some(sp), Some(s)) => s / sp,
            _ => 0.0,
        })
        .collect();
    if (holds.prior_std_mm.is_some() || holds.prior_std_deg.is_some()) && stated.is_none() {
        return Err("a prior needs the readings' σ (sensors.encoder_noise_arcsec)".into());
    }
    let fixed_part = DVector::from_column_slice(&errors);
    let mut y = DVector::zeros(n.ncols());
    let mut used = 0;
    for _ in 0..iterations.max(1) {
        used += 1;
        let r = measured - predict(hex, &errors, targets)?;
        let h = design(hex, &errors, targets)? * &n;
        let step = least_squares(&augment(&h, &prior), &augment_rhs(&r, &y, &prior))?;
        y += &step;
        let e = &fixed_part + &n * &y;
        errors.copy_from_slice(e.as_slice());
        if step.amax() < 1e-10 {
            break;
        }
    }
    let r = measured - predict(hex, &errors, targets)?;
    let j = design(hex, &errors, targets)? * &n;
    let (m, p) = (j.nrows(), j.ncols());
    let dof = m.saturating_sub(p);
    let sigma_deg = match sigma_deg {
        Some(s) if s > 0.0 => s,
        _ if dof > 0 => (r.norm_squared() / dof as f64).sqrt(),
        _ => 0.0,
    };
    // (JᵀJ + prior)⁻¹ through the column-scaled SVD, as the fit itself.
    let ja = augment(&j, &prior);
    let scale: Vec<f64> = (0..p).map(|c| ja.column(c).norm().max(1e-300)).collect();
    let js = DMatrix::from_fn(ja.nrows(), p, |i, c| ja[(i, c)] / scale[c]);
    let svd = js.svd(false, true);
    let v_t = svd.v_t.as_ref().ok_or("the SVD gave no V")?;
    let inv = DMatrix::from_fn(p, p, |a, b| {
        let acc: f64 = (0..svd.singular_values.len())
            .map(|k| v_t[(k, a)] * v_t[(k, b)] / svd.singular_values[k].powi(2))
            .sum();
        acc / (scale[a] * scale[b])
    });
    let covariance = &n * inv * n.transpose() * (sigma_deg * sigma_deg);
    Ok(Identified {
        errors,
        residual_rms_deg: (r.norm_squared() / r.len().max(1) as f64).sqrt(),
        iterations: used,
        covariance,
        sigma_deg,
        dof,
        fixed: holds.fixed.iter().map(|&(j, _)| j).collect(),
    })
}

/// The convention's free directions less the fixed errors' columns.
pub fn free_basis(hex: &Hexapod, holds: &Holds) -> DMatrix<f64> {
    let n = basis(hex);
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
/// of the estimate's error from its covariance, the largest tool-point
/// position error and platform orientation error over the workspace's
/// poses; their median and 95th percentile over the draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedAccuracy {
    pub draws: usize,
    pub poses: usize,
    /// (median, 95th percentile) over draws of the largest position
    /// error, mm.
    pub position_mm: [f64; 2],
    /// The same of the largest orientation error, arc seconds.
    pub orientation_arcsec: [f64; 2],
}

/// Draws of the estimate's error [`predicted_accuracy`] takes.
pub const DRAWS: usize = 1000;

/// [`PredictedAccuracy`] of an estimate with `covariance` (54 × 54, mm and
/// degrees) over `workspace`, the tool point `tool` mm in {P}; the draws
/// are seeded, so the statement is the same bytes every run.
pub fn predicted_accuracy(
    hex: &Hexapod,
    covariance: &DMatrix<f64>,
    workspace: &[Pose],
    tool: &Vector3<f64>,
) -> Result<PredictedAccuracy, String> {
    use rand::SeedableRng;
    let eig = covariance.clone().symmetric_eigen();
    let root =
        &eig.eigenvectors * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let mut stacked = DMatrix::zeros(6 * workspace.len(), N_ERRORS);
    for (w, pose) in workspace.iter().enumerate() {
        let s = tool_sensitivity(hex, pose, tool)
            .map_err(|e| format!("workspace pose {}: {e}", w + 1))?;
        stacked.rows_mut(6 * w, 6).copy_from(&s);
    }
    let map = stacked * root;
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
    let (mut pos, mut rot) = (Vec::with_capacity(DRAWS), Vec::with_capacity(DRAWS));
    for _ in 0..DRAWS {
        let z = DVector::from_fn(N_ERRORS, |_, _| {
            rand::RngExt::sample::<f64, _>(&mut rng, rand_distr::StandardNormal)
        });
        let (p, r) = worst_of(&(&map * z));
        pos.push(p);
        rot.push(r);
    }
    let stat = |v: &mut Vec<f64>| -> [f64; 2] {
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        [at(0.5), at(0.95)]
    };
    Ok(PredictedAccuracy {
        draws: DRAWS,
        poses: workspace.len(),
        position_mm: stat(&mut pos),
        orientation_arcsec: stat(&mut rot),
    })
}

/// Poses left out in folds: each fold's readings predicted from a fit to
/// the other poses (the same Gauss–Newton, holds and σ), against what was
/// read, in units of the prediction's own standard deviation √(σ² +
/// (J·C·Jᵀ)ᵢᵢ), C the fold's fit's covariance. About 1 when the model
/// predicts poses it was not fitted to as well as the encoders allow.
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

/// The held-out check (None with fewer than 2 × [`HELD_OUT_FOLDS`] poses,
/// or when every fold is skipped). Pose j is in fold j mod 5.
pub fn held_out(
    hex: &Hexapod,
    targets: &[Pose],
    measured: &DVector<f64>,
    iterations: usize,
    sigma_deg: f64,
    holds: &Holds,
) -> Option<HeldOut> {
    let n = targets.len();
    let per = hex.readings_per_pose();
    if n < 2 * HELD_OUT_FOLDS || sigma_deg <= 0.0 {
        return None;
    }
    let (mut sum, mut count, mut worst, mut worst_pose, mut skipped) = (0.0, 0, 0.0f64, 0, 0);
    for f in 0..HELD_OUT_FOLDS {
        let (held, kept): (Vec<usize>, Vec<usize>) = (0..n).partition(|j| j % HELD_OUT_FOLDS == f);
        let pick = |poses: &[usize]| -> (Vec<Pose>, DVector<f64>) {
            let t: Vec<Pose> = poses.iter().map(|&j| targets[j]).collect();
            let l = DVector::from_iterator(
                poses.len() * per,
                poses
                    .iter()
                    .flat_map(|&j| (j * per..(j + 1) * per).map(|i| measured[i])),
            );
            (t, l)
        };
        let (kt, kl) = pick(&kept);
        let Ok(fit) = identify(hex, &kt, &kl, iterations, Some(sigma_deg), holds) else {
            skipped += 1;
            continue;
        };
        let (ht, hl) = pick(&held);
        let (Ok(pred), Ok(j)) = (
            predict(hex, &fit.errors, &ht),
            design(hex, &fit.errors, &ht),
        ) else {
            skipped += 1;
            continue;
        };
        let jc = &j * &fit.covariance;
        for i in 0..hl.len() {
            let var = sigma_deg * sigma_deg + jc.row(i).dot(&j.row(i));
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

/// argmin ‖H·x − r‖ by an SVD of the column-scaled H; Err when H is
/// rank-deficient (the poses do not determine the free errors).
fn least_squares(h: &DMatrix<f64>, r: &DVector<f64>) -> Result<DVector<f64>, String> {
    let scale: Vec<f64> = (0..h.ncols())
        .map(|c| h.column(c).norm().max(1e-300))
        .collect();
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
#[path = "hexapod_tests.rs"]
mod tests;
