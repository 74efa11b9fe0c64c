//! The design matrix of eq. 11: H = [J_1 − J_0; …; J_{n−1} − J_0], with J the
//! error Jacobian at each pose (the reference pose's is subtracted because
//! the sensors are homed there). [`stack_differences`] is the one stacker of
//! H, for the nominal design, Gauss–Newton's re-linearised designs and the
//! reduced designs of pose-set design.

use crate::error::PoseError;
use crate::mechanism::Kinematic;
use nalgebra::{DMatrix, Dim, Matrix, RawStorage, SMatrix, SVector};
use std::borrow::Borrow;

/// H of a topology's `machine` in the configurations whose readings are
/// `x` (one per pose, the reference first), e.g. a [`crate::mechanism::PoseSet`]'s.
pub fn design_of<T: Kinematic<P, R>, const P: usize, const R: usize>(
    machine: &T::Machine,
    x: &[SVector<f64, R>],
) -> Result<DMatrix<f64>, PoseError> {
    design_into::<T, P, R>(machine, x, &mut Vec::with_capacity(x.len()))
}

/// [`design_of`] with the pose Jacobians gathered in `jac` (cleared first),
/// so that Gauss–Newton's iterations reuse one buffer.
pub fn design_into<T: Kinematic<P, R>, const P: usize, const R: usize>(
    machine: &T::Machine,
    x: &[SVector<f64, R>],
    jac: &mut Vec<SMatrix<f64, R, P>>,
) -> Result<DMatrix<f64>, PoseError> {
    jac.clear();
    for (k, xk) in x.iter().enumerate() {
        jac.push(T::error_jacobian(machine, xk).map_err(|e| PoseError::new(k, e))?);
    }
    Ok(match jac.split_first() {
        Some((reference, others)) => stack_differences(reference, others),
        None => DMatrix::zeros(0, P),
    })
}

/// Rows r·k .. r·(k+1) of the result are `others[k] − reference` (r rows per
/// block): the observation rows of pose k+1 relative to the reference pose.
pub fn stack_differences<R, C, S, B>(reference: &Matrix<f64, R, C, S>, others: &[B]) -> DMatrix<f64>
where
    R: Dim,
    C: Dim,
    S: RawStorage<f64, R, C>,
    B: Borrow<Matrix<f64, R, C, S>>,
{
    let (r, c) = reference.shape();
    let mut h = DMatrix::zeros(r * others.len(), c);
    for (k, block) in others.iter().enumerate() {
        let block = block.borrow();
        for i in 0..r {
            for j in 0..c {
                h[(r * k + i, j)] = block[(i, j)] - reference[(i, j)];
            }
        }
    }
    h
}
