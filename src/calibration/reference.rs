//! External reference points in a calibration (`identify --reference`):
//! measured absolute positions of the tool added to the readings' fit as
//! further observations of the 15 errors (docs/method.md §18).

use super::{check_targets, checks, Calibration};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::io::Source;
use nalgebra::Vector3;

/// What external reference points did to a calibration.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct ReferenceUpdate {
    pub points: usize,
    /// χ² of the points against the readings' fit (their innovation
    /// weighted by its predicted covariance), on 3·points degrees of
    /// freedom, and its p-value: small when the points and the readings
    /// disagree.
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
    /// The largest distance between a measured point and where the
    /// readings' fit put the tool, mm.
    pub max_innovation_mm: f64,
}

/// Add externally measured absolute positions (targets commanded with the
/// nominal commands, as a calibration log is) to a calibration as further
/// observations of the 15 errors: with C the estimate's covariance, S the
/// points' position sensitivity and R = σ²·I, ε̂ += K·(m − p̂), C −= K·S·C,
/// K = C·Sᵀ·(S·C·Sᵀ + R)⁻¹ — the least squares of readings and points
/// together, to first order (docs/method.md §18). An error the readings
/// left unidentifiable or that is fixed stays as it is. `file` names the
/// points' file in errors.
pub fn add_reference(
    cfg: &Config,
    cal: &mut Calibration,
    points: &[(Vector3<f64>, Vector3<f64>)],
    sigma_mm: f64,
    file: Source,
) -> Result<ReferenceUpdate> {
    use crate::mechanism::tricept::N_PARAMS;
    if cal.axes.is_some() {
        return Err(Error::Argument(
            "--reference cannot yet be combined with [identification] second_class = true: identify without one of them".into(),
        ));
    }
    if !(sigma_mm.is_finite() && sigma_mm > 0.0 && sigma_mm <= 10.0) {
        return Err(Error::Argument(format!(
            "--reference-sigma must be a standard uncertainty in mm in (0, 10] (got {sigma_mm})"
        )));
    }
    let targets: Vec<Vector3<f64>> = points.iter().map(|p| p.0).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    let identified = cal.machine(cfg);
    let size = cfg.resolved().geometry.a.min(cfg.resolved().geometry.b);
    let bound = crate::store::inputs::identified_bound_mm(size);
    let k = points.len();
    let mut s = nalgebra::DMatrix::zeros(3 * k, N_PARAMS);
    let mut y = nalgebra::DVector::zeros(3 * k);
    let mut max_innovation = 0.0f64;
    for (i, (target, measured)) in points.iter().enumerate() {
        let bad = |e: crate::error::KinematicsError| {
            Error::csv(file.name, format!("line {}: {e}", file.line(i)))
        };
        let pose = nominal.inverse(target).map_err(bad)?;
        let q = nominal.commands(target).map_err(bad)?;
        let j = identified.forward(&q, &pose.joints).map_err(bad)?;
        let innovation = measured - identified.position(&j);
        if innovation.norm().is_nan() || innovation.norm() > bound {
            return Err(Error::csv(
                file.name,
                format!(
                    "line {}: the measured position is {:.3} mm from where the readings' fit puts the tool, more than the {bound} mm any error of this machine may be: is it in another unit or frame?",
                    file.line(i),
                    innovation.norm()
                ),
            ));
        }
        max_innovation = max_innovation.max(innovation.norm());
        let sk = crate::mechanism::tricept::jacobian::position_sensitivity(&pose).map_err(bad)?;
        for a in 0..3 {
            y[3 * i + a] = innovation[a];
            for c in 0..N_PARAMS {
                s[(3 * i + a, c)] = sk[(a, c)];
            }
        }
    }
    let c = checks::estimate_covariance(cal);
    let innov_cov =
        &s * &c * s.transpose() + nalgebra::DMatrix::identity(3 * k, 3 * k) * (sigma_mm * sigma_mm);
    let inv = innov_cov
        .clone()
        .cholesky()
        .map(|ch| ch.inverse())
        .ok_or_else(|| {
            Error::Internal("the reference points' covariance is not positive definite".into())
        })?;
    let gain = &c * s.transpose() * &inv;
    let update = &gain * &y;
    let c_new = &c - &gain * &s * &c;
    let c_new = (&c_new + c_new.transpose()) * 0.5;
    let fixed = cal.solver.constraints().fixed;
    for p in 0..N_PARAMS {
        if cal.estimate.identifiable[p] && fixed[p].is_none() {
            cal.estimate.values[p] += update[p];
            cal.estimate.std_mm[p] = c_new[(p, p)].max(0.0).sqrt();
        }
    }
    cal.covariance = Some(c_new);
    let chi2 = (y.transpose() * &inv * &y)[(0, 0)];
    let dof = 3 * k;
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let p_value = ChiSquared::new(dof as f64).map_or(f64::NAN, |d| d.sf(chi2));
    Ok(ReferenceUpdate {
        points: k,
        chi2,
        dof,
        p_value,
        max_innovation_mm: max_innovation,
    })
}
