//! Identifying the hexapod's errors from its encoders' readings: least
//! squares in the convention's free directions, once at the nominal machine
//! (one linearisation) or by Gauss–Newton from there, each step at the
//! current estimate's exact kinematics.

use super::convention::basis;
use super::design::design;
use super::{Errors, Hexapod, Pose, N_ERRORS};
use crate::identify::{analyse_named, Identifiability};
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
    let names = super::error_names();
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
/// more re-linearise at the estimate until the step is below 1e-10.
pub fn identify(
    hex: &Hexapod,
    targets: &[Pose],
    measured: &DVector<f64>,
    iterations: usize,
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
    Ok(Identified {
        errors,
        residual_rms_deg: (r.norm_squared() / r.len().max(1) as f64).sqrt(),
        iterations: used,
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
