//! An identification's result (estimate, uncertainties, how it stopped)
//! and an estimate split by noise source, for any topology of P errors.

use nalgebra::SVector;
use serde::Serialize;

/// An identification result of a topology of P errors.
#[derive(Debug, Clone)]
pub struct EstimateOf<const P: usize> {
    /// Estimates, mm (0 for unidentifiable parameters).
    pub values: SVector<f64, P>,
    /// Standard uncertainties, mm (0 when unidentifiable): from the residual
    /// variance (OLS, WLS) or the sensors' covariance (GLS); see
    /// [`Solver::posterior`].
    pub std_mm: SVector<f64, P>,
    pub identifiable: [bool; P],
    /// Where each value comes from: "readings", "fixed" (held at its
    /// measured value, no uncertainty stated), "prior" (the prior's
    /// information outweighs the readings': posterior σ > σp/√2) or
    /// "unidentifiable" (set to 0).
    pub source: [&'static str; P],
    /// RMS of the weighted residual.
    pub residual_rms: f64,
    /// Degrees of freedom m − p.
    pub dof: usize,
    /// Linearisations used.
    pub iterations: usize,
    /// Why the identification stopped.
    pub termination: Termination,
}

/// Why an identification stopped (argmin's `TerminationReason` style).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// One linearisation at the nominal poses (the paper; `iterations = 1`).
    SingleLinearisation,
    /// Gauss–Newton: the largest step fell below `tolerance`.
    StepBelowTolerance,
    /// Gauss–Newton: the step stopped shrinking within 100 × `tolerance`, at
    /// the round-off floor that forward kinematics (exact to ~1e-11 mm) sets.
    StagnatedAtRoundoff,
    /// Gauss–Newton: the iteration limit came first; the last estimate is kept.
    MaxIterations,
}

impl Termination {
    /// False only when the iteration limit stopped Gauss–Newton.
    pub fn converged(&self) -> bool {
        !matches!(self, Termination::MaxIterations)
    }

    /// One phrase for the console.
    pub fn describe(&self) -> &'static str {
        match self {
            Termination::SingleLinearisation => "one linearisation at the nominal poses",
            Termination::StepBelowTolerance => "converged: the last step was below the tolerance",
            Termination::StagnatedAtRoundoff => {
                "converged at the round-off floor: the step stopped shrinking within 100 × the tolerance"
            }
            Termination::MaxIterations => "NOT converged: the iteration limit was reached first",
        }
    }
}

/// One observation's estimate split by source (see
/// [`Solver::apply_split`]): the estimate from the exact observation
/// and, per sensor, the estimate from its unit noise.
#[derive(Debug, Clone, Copy)]
pub struct Split<const P: usize, const R: usize> {
    pub exact: SVector<f64, P>,
    /// One per reading (the mechanism's: ψ4 encoder, θ4 encoder, scale).
    pub noise: [SVector<f64, P>; R],
}

impl<const P: usize, const R: usize> Default for Split<P, R> {
    fn default() -> Self {
        Split {
            exact: SVector::zeros(),
            noise: [SVector::zeros(); R],
        }
    }
}

impl<const P: usize, const R: usize> Split<P, R> {
    /// The estimate from `l0 + s ⊙ dz`: exact + Σ s_k·noise_k.
    #[inline]
    pub fn estimate(&self, s: &SVector<f64, R>) -> SVector<f64, P> {
        estimate_of(&self.exact, &self.noise, s)
    }
}

/// [`Split::estimate`] from its parts where they lie (no split formed).
#[inline]
pub fn estimate_of<const P: usize, const R: usize>(
    exact: &SVector<f64, P>,
    noise: &[SVector<f64, P>; R],
    s: &SVector<f64, R>,
) -> SVector<f64, P> {
    let mut e = *exact;
    for k in 0..R {
        e.axpy(s[k], &noise[k], 1.0);
    }
    e
}
