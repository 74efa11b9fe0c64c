//! Identification (SPEC §6; paper eqs. 10–12).
//!
//! Observation at pose j (eq. 10): l_j = reading_j − nominal_j relative to the
//! reference, l_j = (J_j − J_0)·Δε; stacked, l = H·Δε (eq. 11) and solved by
//! least squares (eq. 12) — here through an SVD of the column-equilibrated
//! (and, for WLS, row-weighted) H, never by inverting HᵀH. Rank is decided on
//! that SVD after numerically zero columns are removed, so neither column
//! scale nor a column of round-off can fake an identifiable parameter.

pub mod analysis;
pub mod solver;

pub use analysis::{analyse, Identifiability};
pub use solver::{Estimate, IdentifyOptions, LinearSolver, Method};

use crate::error::KinematicsError;
use crate::model::jacobian::jacobian_at;
use crate::model::{Joints, Machine, N_PARAMS};
use crate::sensors::NominalPoses;
use nalgebra::{DMatrix, DVector, Vector3};

/// H = [J_1 − J_0; …; J_{n−1} − J_0] with J at the nominal configurations.
pub fn design_matrix(
    nominal: &Machine,
    poses: &NominalPoses,
) -> Result<DMatrix<f64>, (usize, KinematicsError)> {
    let jac: Vec<_> = poses
        .joints
        .iter()
        .enumerate()
        .map(|(k, j)| jacobian_at(&nominal.pose(j)).map_err(|e| (k, e)))
        .collect::<Result<_, _>>()?;
    Ok(stack_differences(&jac))
}

/// Rows 3(j−1)..3j of the result are J_j − J_0.
pub fn stack_differences(jac: &[crate::model::ErrorJacobian]) -> DMatrix<f64> {
    let n = jac.len().saturating_sub(1);
    let mut h = DMatrix::zeros(3 * n, N_PARAMS);
    for j in 1..jac.len() {
        let d = jac[j] - jac[0];
        h.view_mut((3 * (j - 1), 0), (3, N_PARAMS)).copy_from(&d);
    }
    h
}

/// l from readings: l_j = (reading_j − reading_0) − (nominal_j − nominal_0),
/// j ≥ 1 (equal to reading_j − nominal_j when the reference reads nominal_0,
/// as homing makes it; robust to a controller that logs a homing offset).
pub fn observation_vector(nominal: &[Joints], readings: &[Vector3<f64>]) -> DVector<f64> {
    let n = nominal.len().saturating_sub(1);
    let mut l = DVector::zeros(3 * n);
    let n0 = nominal[0].as_vector();
    let r0 = readings[0];
    for j in 1..nominal.len() {
        let d = (readings[j] - r0) - (nominal[j].as_vector() - n0);
        l.fixed_rows_mut::<3>(3 * (j - 1)).copy_from(&d);
    }
    l
}
