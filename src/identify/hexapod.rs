//! Identifying the hexapod's errors from its encoders' readings: least
//! squares in the convention's free directions, once at the nominal machine
//! (one linearisation) or by Gauss–Newton from there, each step at the
//! current estimate's exact kinematics.

use super::{analyse_named, Identifiability};
use crate::mechanism::hexapod::convention::basis;
use crate::mechanism::hexapod::design::design;
use crate::mechanism::hexapod::{Errors, Hexapod, Pose, N_ERRORS};
use nalgebra::{DMatrix, DVector};

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
) -> Result<(usize, usize), String> {
    let h = design(hex, &[0.0; N_ERRORS], targets)? * basis(hex);
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
/// residuals'.
pub fn identify(
    hex: &Hexapod,
    targets: &[Pose],
    measured: &DVector<f64>,
    iterations: usize,
    sigma_deg: Option<f64>,
) -> Result<Identified, String> {
    let n = basis(hex);
    let mut errors = [0.0; N_ERRORS];
    let mut used = 0;
    for _ in 0..iterations.max(1) {
        used += 1;
        let r = measured - predict(hex, &errors, targets)?;
        let h = design(hex, &errors, targets)? * &n;
        let step = least_squares(&h, &r)?;
        let delta = &n * step;
        for (e, d) in errors.iter_mut().zip(delta.iter()) {
            *e += d;
        }
        if delta.amax() < 1e-10 {
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
    // (JᵀJ)⁻¹ through the column-scaled SVD, as the fit itself.
    let scale: Vec<f64> = (0..p).map(|c| j.column(c).norm().max(1e-300)).collect();
    let js = DMatrix::from_fn(m, p, |i, c| j[(i, c)] / scale[c]);
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
