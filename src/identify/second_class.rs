//! Identifying the Hooke axes' yaw, pitch and skew beside the 15 errors
//! (`[identification] second_class = true`), from the same readings and
//! with the same estimator, as two operators of the existing kind instead
//! of one of 18 columns (the 15-error operator runs in 16 vector lanes).
//!
//! With A = W·H15, B = W·H3 (W the estimator's weighting, H3 the readings'
//! derivatives in the three angles) and y = W·l, the least squares in all
//! 18 unknowns splits (a Schur complement): the angles are the least
//! squares of B̃·a ≈ y with B̃ = (I − A·A⁺)·B, the part of their columns
//! the 15 errors cannot imitate; the 15 errors are then A⁺·(y − B·a) =
//! op15·l − G·a with G = op15·H3. B̃ = W·H̃3 with H̃3 = H3 − H15·G, so the
//! angles' operator is an ordinary [`Solver`] of design H̃3 under the same
//! weighting, and an estimate costs one more application of three rows.
//! Tested against the 18-column least squares solved outright
//! (`tests/second_class_solver.rs`) and by a Monte-Carlo of the spread
//! against the predicted covariance (`tests/second_class_identification.rs`).

use super::design::stack_differences;
use super::linear::Solver;
use super::tricept::LinearSolver;
use super::weighting::Weighting;
use crate::error::PoseError;
use crate::mechanism::tricept::second_class::{angle_jacobian, Angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::{ErrorVector, Joints, Machine, N_PARAMS, N_READINGS};
use crate::sensors::ObservationCovariance;
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// H3: the derivatives of the homed readings in the three angles (degrees)
/// of `machine` (with its axes at `angles`) in the configurations `joints`
/// (the reference first), rows as [`super::design_matrix`]'s.
pub fn angle_design(
    machine: &Machine,
    angles: &Angles,
    joints: &[Joints],
) -> Result<DMatrix<f64>, PoseError> {
    let jac = joints
        .iter()
        .enumerate()
        .map(|(k, j)| angle_jacobian(machine, angles, j).map_err(|e| PoseError::new(k, e)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(match jac.split_first() {
        Some((reference, others)) => stack_differences(reference, others),
        None => DMatrix::zeros(0, N_ANGLES),
    })
}

/// The smallest share of an angle's weighted column outside the 15
/// errors' span that counts as identifiable (the paper's poses: 4 % for
/// the yaw, the weakest).
pub const MIN_OUTSIDE_SPAN: f64 = 1e-6;

/// The 15 errors and the three angles (degrees) of one calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extended {
    pub errors: ErrorVector,
    pub angles: Angles,
}

/// The angles' operator and what the 15-error estimate reads of them.
#[derive(Debug, Clone)]
pub struct SecondClassSolver {
    /// The least squares of the angles' columns the 15 errors cannot imitate.
    pub angles: Solver<N_ANGLES, N_READINGS>,
    /// G = op15·H3 (15 × 3): the 15-error estimate's share of each angle.
    g: SMatrix<f64, N_PARAMS, N_ANGLES>,
    /// H3 itself (the residual of an estimate needs it).
    h3: DMatrix<f64>,
}

impl SecondClassSolver {
    /// From the 15-error operator `base` (its design and weighting) and the
    /// angles' design `h3` (rows as `base`'s, 3 columns). Errors: held
    /// errors or a prior in `base` (not combined with the angles).
    pub fn new(
        base: &LinearSolver,
        h3: &DMatrix<f64>,
        rank_tolerance: f64,
    ) -> Result<Self, String> {
        if !base.constraints().none() {
            return Err("second_class = true cannot be combined with identification.fix or identification.prior_std_mm yet: identify the angles without them, or hold the angles by leaving second_class out".into());
        }
        assert_eq!(h3.nrows(), base.rows(), "one row of H3 per observation row");
        let g_dyn = base.operator() * h3;
        let mut h_tilde = h3 - base.design() * &g_dyn;
        // An angle whose column the 15 errors imitate to rounding (every
        // column of few poses does) is not identified: its remainder is
        // noise, however the solver would scale it.
        let w = base.weighting();
        let (full, apart) = (w.apply(h3), w.apply(&h_tilde));
        for c in 0..N_ANGLES {
            if apart.column(c).norm() <= MIN_OUTSIDE_SPAN * full.column(c).norm() {
                h_tilde.column_mut(c).fill(0.0);
            }
        }
        let angles = Solver::<N_ANGLES, N_READINGS>::named(
            &h_tilde,
            base.weighting(),
            rank_tolerance,
            &ANGLE_NAMES,
        );
        Ok(SecondClassSolver {
            angles,
            g: SMatrix::from_iterator(g_dyn.iter().copied()),
            h3: h3.clone(),
        })
    }

    /// The 18 unknowns from observation `l` and the 15-error estimate
    /// `base_estimate` = op15·l of the same observation. No allocation.
    #[inline]
    pub fn apply(&self, l: &[f64], base_estimate: &ErrorVector) -> Extended {
        let mut a = SVector::<f64, N_ANGLES>::zeros();
        self.angles.apply(l, &mut a);
        Extended {
            errors: base_estimate - self.g * a,
            angles: a,
        }
    }

    /// The 18 × rows operator [op15 − G·op3; op3] (errors then angles).
    pub fn operator(&self, base: &LinearSolver) -> DMatrix<f64> {
        let op15 = base.operator();
        let op3 = self.angles.operator();
        let g = DMatrix::from_iterator(N_PARAMS, N_ANGLES, self.g.iter().copied());
        let top = op15 - g * &op3;
        let mut op = DMatrix::zeros(N_PARAMS + N_ANGLES, top.ncols());
        op.rows_mut(0, N_PARAMS).copy_from(&top);
        op.rows_mut(N_PARAMS, N_ANGLES).copy_from(&op3);
        op
    }

    /// Standard deviation of each of the 18 (mm, then degrees) when the
    /// readings' errors have covariance `sigma`: √diag(op·Σ·opᵀ), O(rows).
    pub fn predicted_std(&self, base: &LinearSolver, sigma: &ObservationCovariance) -> Vec<f64> {
        let cov = sigma.sandwich(&self.operator(base));
        (0..cov.nrows())
            .map(|i| cov[(i, i)].max(0.0).sqrt())
            .collect()
    }

    /// The angles' design H3.
    pub fn design(&self) -> &DMatrix<f64> {
        &self.h3
    }

    /// The residual l − H15·x15 − H3·x3 of an estimate.
    pub fn residual(&self, base: &LinearSolver, l: &DVector<f64>, x: &Extended) -> DVector<f64> {
        l - base.design() * x.errors - &self.h3 * x.angles
    }

    /// Standard uncertainties of the 18 (mm, then degrees) and the RMS of
    /// the weighted residual. Every estimator states √diag(op·Σ·opᵀ) under
    /// the readings' covariance `sigma` (docs/method.md §18): a residual
    /// variance times independent rows would ignore the shared reference
    /// reading and the sensors' correlations.
    pub fn uncertainties(
        &self,
        base: &LinearSolver,
        l: &DVector<f64>,
        x: &Extended,
        sigma: &ObservationCovariance,
    ) -> (Vec<f64>, f64) {
        let resid = self.residual(base, l, x);
        let rss = match base.weighting() {
            Weighting::Rows(w) => resid
                .iter()
                .zip(w.iter())
                .map(|(r, w)| (r * w) * (r * w))
                .sum(),
            Weighting::Whiten(_) => base.weighting().apply_vector(&resid).norm_squared(),
        };
        (
            self.predicted_std(base, sigma),
            (rss / resid.len().max(1) as f64).sqrt(),
        )
    }

    /// The share of each angle's weighted column that the 15 errors cannot
    /// imitate, ‖W·H̃3_c‖/‖W·H3_c‖: 0 when the angle moves the readings
    /// exactly as some errors do, 1 when unlike any.
    pub fn outside_span(&self, base: &LinearSolver) -> [f64; N_ANGLES] {
        let w = base.weighting();
        let (full, apart) = (w.apply(&self.h3), w.apply(self.angles.design()));
        std::array::from_fn(|c| {
            let n = full.column(c).norm();
            if n > 0.0 {
                apart.column(c).norm() / n
            } else {
                0.0
            }
        })
    }

    /// Combinations identified: the 15-error model's rank plus the angles'.
    pub fn rank(&self, base: &LinearSolver) -> usize {
        base.analysis.rank + self.angles.analysis.rank
    }

    /// Which angles the readings identify.
    pub fn identifiable(&self) -> [bool; N_ANGLES] {
        self.angles.identifiable()
    }
}
