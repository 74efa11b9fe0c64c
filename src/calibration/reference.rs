//! External reference points in a calibration (`identify --reference`):
//! measured absolute positions of the tool added to the readings' fit as
//! further observations of the errors (docs/method.md §18), for any
//! [`Kinematic`] mechanism.

use super::verify::check_targets;
use crate::error::{Error, KinematicsError, Result};
use crate::identify::EstimateOf;
use crate::io::Source;
use crate::mechanism::{Kinematic, Reach};
use nalgebra::{DMatrix, DVector, Vector3};

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

/// The fit reference points update: the estimate, the errors held at
/// measured values (`fixed`, left as they are) and the estimate's
/// covariance C (P × P).
pub struct Fit<'a, const P: usize> {
    pub estimate: &'a mut EstimateOf<P>,
    pub fixed: &'a [Option<f64>; P],
    pub covariance: DMatrix<f64>,
}

/// Add externally measured absolute positions (targets commanded with the
/// nominal commands of `reach`'s machine, as a calibration log is) to a
/// fit of `identified` (the machine of the fit's estimate) as further
/// observations of its P errors: with C the estimate's covariance, S the
/// points' position sensitivity and R = σ²·I, ε̂ += K·(m − p̂), C −= K·S·C,
/// K = C·Sᵀ·(S·C·Sᵀ + R)⁻¹ — the least squares of readings and points
/// together, to first order (docs/method.md §18). An error the readings
/// left unidentifiable or that is fixed stays as it is. `file` names the
/// points' file in errors; a point farther than `bound_mm` from where the
/// fit puts the tool is refused. Returns what the points did and the new
/// covariance.
pub fn add_reference<T: Kinematic<P, R>, const P: usize, const R: usize>(
    (reach, identified): (&Reach<T, P, R>, &T::Machine),
    fit: Fit<'_, P>,
    points: &[(Vector3<f64>, Vector3<f64>)],
    sigma_mm: f64,
    (file, bound): (Source, f64),
) -> Result<(ReferenceUpdate, DMatrix<f64>)> {
    // NaN fails both comparisons.
    if !(sigma_mm > 0.0 && sigma_mm <= 10.0) {
        return Err(Error::Argument(format!(
            "--reference-sigma must be a standard uncertainty in mm in (0, 10] (got {sigma_mm})"
        )));
    }
    let targets: Vec<Vector3<f64>> = points.iter().map(|p| p.0).collect();
    check_targets(reach, &targets, file)?;
    let nominal = reach.homed.nominal();
    let k = points.len();
    let mut s = DMatrix::zeros(3 * k, P);
    let mut y = DVector::zeros(3 * k);
    let mut max_innovation = 0.0f64;
    for (i, (target, measured)) in points.iter().enumerate() {
        let bad = |e: KinematicsError| Error::csv(file.name, format!("line {}: {e}", file.line(i)));
        let (q, guess) = T::command(nominal, target).map_err(bad)?;
        let x = T::readings(identified, &q, &guess).map_err(bad)?;
        let innovation = measured - T::position(identified, &x);
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
        let sk = T::position_sensitivity(reach.homed.layout(), target).map_err(bad)?;
        for a in 0..3 {
            y[3 * i + a] = innovation[a];
            for c in 0..P {
                s[(3 * i + a, c)] = sk[(a, c)];
            }
        }
    }
    let c = fit.covariance;
    let innov_cov =
        &s * &c * s.transpose() + DMatrix::identity(3 * k, 3 * k) * (sigma_mm * sigma_mm);
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
    for p in 0..P {
        if fit.estimate.identifiable[p] && fit.fixed[p].is_none() {
            fit.estimate.values[p] += update[p];
            fit.estimate.std_mm[p] = c_new[(p, p)].max(0.0).sqrt();
        }
    }
    let chi2 = (y.transpose() * &inv * &y)[(0, 0)];
    let dof = 3 * k;
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let p_value = ChiSquared::new(dof as f64).map_or(f64::NAN, |d| d.sf(chi2));
    let done = ReferenceUpdate {
        points: k,
        chi2,
        dof,
        p_value,
        max_innovation_mm: max_innovation,
    };
    Ok((done, c_new))
}
