//! What a calibration achieved, and what a study decides from it: the
//! paper's residual μ (docs/method.md §8), summary statistics across machines
//! ([`stats`]), the rows of a study's summary ([`summary`]) and the typed
//! decision metric with the rule that picks a grade ([`decision`]).

pub mod buyer;
pub mod decision;
pub mod finite;
pub mod ranking;
pub mod stats;
pub mod summary;
pub mod verdict;

pub use decision::{decide, Confidence, Decision, DecisionMetric, DecisionRow};
pub use ranking::{mark_what_ifs, rank_combinations, RankedRow};
pub use summary::{
    BudgetRow, DvSummary, GradeSummary, ParameterRow, TermSplit, BUDGET_SENSORS, BUDGET_TERMS,
};
pub use verdict::{IdentifiedAxes, Tolerance, Verdict};

use nalgebra::SVector;

/// μ = ‖Δε − Δε_e‖₁ / n_e (docs/method.md §8; the paper's residual metric), for any
/// topology's n_e = P errors (the mechanism's 15).
pub fn mu<const P: usize>(truth: &SVector<f64, P>, estimate: &SVector<f64, P>) -> f64 {
    (truth - estimate).abs().sum() / P as f64
}

/// μ0: μ with no calibration (estimate 0).
pub fn mu0<const P: usize>(truth: &SVector<f64, P>) -> f64 {
    truth.abs().sum() / P as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{ErrorVector, N_PARAMS, PAPER_ERRORS_MM};

    #[test]
    fn paper_mu0_is_0_2853() {
        let e = ErrorVector::from_row_slice(&PAPER_ERRORS_MM);
        assert!((mu0(&e) - 0.285_333).abs() < 1e-5, "{}", mu0(&e));
        assert_eq!(mu(&e, &e), 0.0);
    }

    #[test]
    fn mu_is_the_mean_absolute_error() {
        let truth = ErrorVector::from_fn(|i, _| i as f64 * 0.1 - 0.7);
        let est = ErrorVector::from_fn(|i, _| if i % 2 == 0 { 0.3 } else { -0.2 });
        let by_hand: f64 = (0..N_PARAMS)
            .map(|i| (truth[i] - est[i]).abs())
            .sum::<f64>()
            / 15.0;
        assert!((mu(&truth, &est) - by_hand).abs() < 1e-15);
        assert!((mu0(&truth) - mu(&truth, &ErrorVector::zeros())).abs() < 1e-15);
    }
}
