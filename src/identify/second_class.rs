//! Identifying a mechanism's `A` second-class unknowns beside its `P`
//! errors (the Tricept's Hooke axes' yaw, pitch and skew beside its 15,
//! `[identification] second_class = true`), from the same readings and
//! with the same estimator, as two operators of the existing kind instead
//! of one of P + A columns (the P-error operator runs in 16 vector lanes).
//! Written for any sizes; the Tricept's are in `super::tricept`
//! (`AxesSolver`, and `angle_design`, its readings' derivatives in the
//! angles).
//!
//! With A = W·H, B = W·H₂ (W the estimator's weighting, H the design of
//! the P errors, H₂ the readings' derivatives in the A unknowns) and
//! y = W·l, the least squares in all P + A unknowns splits (a Schur
//! complement): the unknowns are the least squares of B̃·a ≈ y with
//! B̃ = (I − A·A⁺)·B, the part of their columns the P errors cannot
//! imitate; the P errors are then A⁺·(y − B·a) = op·l − G·a with
//! G = op·H₂. B̃ = W·H̃₂ with H̃₂ = H₂ − H·G, so the unknowns' operator is
//! an ordinary [`Solver`] of design H̃₂ under the same weighting, and an
//! estimate costs one more application of A rows. Tested on the
//! Tricept (15 errors, 3 angles) against the 18-column least squares
//! solved outright
//! (`tests/second_class_solver.rs`) and by a Monte-Carlo of the spread
//! against the predicted covariance (`tests/second_class_identification.rs`).

use super::linear::Solver;
use super::weighting::Weighting;
use crate::sensors::ObservationCovariance;
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// The smallest share of an unknown's weighted column outside the
/// errors' span that counts as identifiable (the paper's poses: 4 % for
/// the yaw, the weakest).
pub const MIN_OUTSIDE_SPAN: f64 = 1e-6;

/// The P errors and the A second-class unknowns (the Tricept's three
/// angles, degrees) of one calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extended<const P: usize, const A: usize> {
    pub errors: SVector<f64, P>,
    pub angles: SVector<f64, A>,
}

/// The unknowns' operator and what the P-error estimate reads of them.
#[derive(Debug, Clone)]
pub struct SecondClassSolver<const P: usize, const A: usize, const R: usize> {
    /// The least squares of the angles' columns the P errors cannot imitate.
    pub angles: Solver<A, R>,
    /// G = op·H₂ (P × A): the P-error estimate's share of each unknown.
    g: SMatrix<f64, P, A>,
    /// H3 itself (the residual of an estimate needs it).
    h3: DMatrix<f64>,
}

impl<const P: usize, const A: usize, const R: usize> SecondClassSolver<P, A, R> {
    /// From the P-error operator `base` (its design and weighting) and the
    /// unknowns' design `h3` (rows as `base`'s, A columns), the unknowns
    /// named `names`. Errors: held errors or a prior in `base` (not
    /// combined with the angles).
    pub fn named(
        base: &Solver<P, R>,
        h3: &DMatrix<f64>,
        rank_tolerance: f64,
        names: &[&str],
    ) -> Result<Self, String> {
        if !base.constraints().none() {
            return Err("second_class = true cannot be combined with identification.fix or identification.prior_std_mm yet: identify the angles without them, or hold the angles by leaving second_class out".into());
        }
        assert_eq!(h3.nrows(), base.rows(), "one row of H3 per observation row");
        assert_eq!(h3.ncols(), A, "one column of H3 per unknown");
        let g_dyn = base.operator() * h3;
        let mut h_tilde = h3 - base.design() * &g_dyn;
        // An unknown whose column the P errors imitate to rounding (every
        // column of few poses does) is not identified: its remainder is
        // noise, however the solver would scale it.
        let w = base.weighting();
        let (full, apart) = (w.apply(h3), w.apply(&h_tilde));
        for c in 0..A {
            if apart.column(c).norm() <= MIN_OUTSIDE_SPAN * full.column(c).norm() {
                h_tilde.column_mut(c).fill(0.0);
            }
        }
        let angles = Solver::<A, R>::named(&h_tilde, base.weighting(), rank_tolerance, names);
        Ok(SecondClassSolver {
            angles,
            g: SMatrix::from_iterator(g_dyn.iter().copied()),
            h3: h3.clone(),
        })
    }

    /// The P + A unknowns from observation `l` and the P-error estimate
    /// `base_estimate` = op·l of the same observation. No allocation.
    #[inline]
    pub fn apply(&self, l: &[f64], base_estimate: &SVector<f64, P>) -> Extended<P, A> {
        let mut a = SVector::<f64, A>::zeros();
        self.angles.apply(l, &mut a);
        Extended {
            errors: base_estimate - self.g * a,
            angles: a,
        }
    }

    /// The (P + A) × rows operator [op − G·op₂; op₂] (errors, then unknowns).
    pub fn operator(&self, base: &Solver<P, R>) -> DMatrix<f64> {
        let op15 = base.operator();
        let op3 = self.angles.operator();
        let g = DMatrix::from_iterator(P, A, self.g.iter().copied());
        let top = op15 - g * &op3;
        let mut op = DMatrix::zeros(P + A, top.ncols());
        op.rows_mut(0, P).copy_from(&top);
        op.rows_mut(P, A).copy_from(&op3);
        op
    }

    /// Standard deviation of each of the P + A (mm, then degrees) when the
    /// readings' errors have covariance `sigma`: √diag(op·Σ·opᵀ), O(rows).
    pub fn predicted_std(&self, base: &Solver<P, R>, sigma: &ObservationCovariance) -> Vec<f64> {
        let cov = sigma.sandwich(&self.operator(base));
        (0..cov.nrows())
            .map(|i| cov[(i, i)].max(0.0).sqrt())
            .collect()
    }

    /// The angles' design H3.
    pub fn design(&self) -> &DMatrix<f64> {
        &self.h3
    }

    /// The residual l − H·x − H₂·a of an estimate.
    pub fn residual(
        &self,
        base: &Solver<P, R>,
        l: &DVector<f64>,
        x: &Extended<P, A>,
    ) -> DVector<f64> {
        l - base.design() * x.errors - &self.h3 * x.angles
    }

    /// Standard uncertainties of the P + A (mm, then degrees) and the RMS of
    /// the weighted residual. Every estimator states √diag(op·Σ·opᵀ) under
    /// the readings' covariance `sigma` (docs/method.md §18): a residual
    /// variance times independent rows would ignore the shared reference
    /// reading and the sensors' correlations.
    pub fn uncertainties(
        &self,
        base: &Solver<P, R>,
        l: &DVector<f64>,
        x: &Extended<P, A>,
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

    /// The share of each angle's weighted column that the P errors cannot
    /// imitate, ‖W·H̃3_c‖/‖W·H3_c‖: 0 when the angle moves the readings
    /// exactly as some errors do, 1 when unlike any.
    pub fn outside_span(&self, base: &Solver<P, R>) -> [f64; A] {
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

    /// Combinations identified: the P-error model's rank plus the angles'.
    pub fn rank(&self, base: &Solver<P, R>) -> usize {
        base.analysis.rank + self.angles.analysis.rank
    }

    /// Which angles the readings identify.
    pub fn identifiable(&self) -> [bool; A] {
        self.angles.identifiable()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Sizes that are not the Tricept's (4 errors, 3 second-class unknowns,
    /// 2 readings a pose) under WLS (rows of unequal weights): the two
    /// operators' estimate equals the weighted least squares in all seven
    /// columns solved outright, and so does its predicted spread,
    /// op·Σ·opᵀ with Σ the homed readings' (a slot's rows share the
    /// reference's noise).
    #[test]
    fn any_sizes_are_the_least_squares_of_all_columns() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(4);
        let rows = 2 * 9;
        let h = DMatrix::from_fn(rows, 4, |_, _| rng.random_range(-1.0..1.0));
        let h3 = DMatrix::from_fn(rows, 3, |_, _| rng.random_range(-1.0..1.0));
        let l = DVector::from_fn(rows, |_, _| rng.random_range(-1.0..1.0));
        let w = DVector::from_fn(rows, |r, _| if r % 2 == 0 { 3.0 } else { 0.5 });
        let weighting = Weighting::Rows(w.clone());
        let base = Solver::<4, 2>::named(&h, &weighting, 1e-12, &["a", "b", "c", "d"]);
        let ext = SecondClassSolver::<4, 3, 2>::named(&base, &h3, 1e-12, &["u", "v", "x"]).unwrap();
        let mut e = SVector::<f64, 4>::zeros();
        base.apply(l.as_slice(), &mut e);
        let x = ext.apply(l.as_slice(), &e);
        let mut full = DMatrix::zeros(rows, 7);
        full.columns_mut(0, 4).copy_from(&h);
        full.columns_mut(4, 3).copy_from(&h3);
        let w2 = DMatrix::from_diagonal(&w.component_mul(&w));
        let inverse = (full.transpose() * &w2 * &full).try_inverse().unwrap();
        let op = &inverse * full.transpose() * &w2;
        let want = &op * &l;
        for i in 0..4 {
            assert!((x.errors[i] - want[i]).abs() < 1e-10, "error {i}");
        }
        for i in 0..3 {
            assert!((x.angles[i] - want[4 + i]).abs() < 1e-10, "unknown {i}");
        }
        assert_eq!(ext.rank(&base), 7);
        assert_eq!(ext.identifiable(), [true; 3]);
        // Homed white readings of σ: rows of one slot share the reference's
        // noise, Σ = σ²·(δ_ij + 1) on a slot's rows, 0 across slots.
        let sigma = 0.3;
        let cov = [crate::sensors::SensorCovariance::white(sigma); 2];
        let joints = vec![SVector::<f64, 2>::zeros(); 10];
        let sd = ext.predicted_std(&base, &ObservationCovariance::new(&cov, &joints));
        let dense = DMatrix::from_fn(rows, rows, |r, c| match (r % 2 == c % 2, r == c) {
            (true, true) => 2.0 * sigma * sigma,
            (true, false) => sigma * sigma,
            _ => 0.0,
        });
        let spread = &op * dense * op.transpose();
        for i in 0..7 {
            let want = spread[(i, i)].sqrt();
            assert!(
                (sd[i] / want - 1.0).abs() < 1e-9,
                "σ {i}: {} against {want}",
                sd[i]
            );
        }
    }
}
