//! How an estimator weights the rows of its observation before least
//! squares ([`Weighting`]): what [`super::method::Method::weighting`]
//! builds and every solver reads.

use crate::sensors::{ObservationCovariance, Whitening};
use nalgebra::{DMatrix, DVector};

/// How an estimator weights the rows of l = H·Δε before least squares.
#[derive(Debug, Clone, PartialEq)]
pub enum Weighting {
    /// Row r multiplied by w[r] (OLS: 1; WLS: 1/σ of its sensor).
    Rows(DVector<f64>),
    /// Rows multiplied by W = Σ^(−1/2) in factored form (GLS; O(rows) to
    /// apply to a vector, see [`crate::sensors::factored`]).
    Whiten(Box<Whitening>),
}

impl Weighting {
    /// The whitening of covariance `sigma`; Err when it is not positive
    /// definite.
    pub fn whiten(sigma: &ObservationCovariance) -> Result<Self, String> {
        sigma.whitening().map(|w| Weighting::Whiten(Box::new(w)))
    }

    /// W·A for a matrix (or vector) of `rows()` rows.
    pub fn apply(&self, a: &DMatrix<f64>) -> DMatrix<f64> {
        match self {
            Weighting::Rows(w) => DMatrix::from_fn(a.nrows(), a.ncols(), |r, c| a[(r, c)] * w[r]),
            Weighting::Whiten(w) => w.apply(a),
        }
    }

    /// W·v.
    pub fn apply_vector(&self, v: &DVector<f64>) -> DVector<f64> {
        match self {
            Weighting::Rows(w) => v.component_mul(w),
            Weighting::Whiten(w) => w.apply_vector(v),
        }
    }
}
