//! What the user holds of the errors besides the readings, for every
//! estimator's operator ([`super::linear::Solver`]).

/// What the user holds of the errors besides the readings
/// (`[identification] fix` and `prior_std_mm`): errors measured elsewhere
/// (a CMM) held at their values, the rest identified from what the readings
/// leave; and a Gaussian prior N(0, σp²) on each free error, which keeps the
/// combinations the readings do not determine at the prior (MAP: the prior
/// enters as P more rows ε/σp = 0 of the whitened least squares).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constraints<const P: usize> {
    /// Measured values, mm.
    pub fixed: [Option<f64>; P],
    pub prior_std_mm: Option<f64>,
}

impl<const P: usize> Default for Constraints<P> {
    fn default() -> Self {
        Constraints {
            fixed: [None; P],
            prior_std_mm: None,
        }
    }
}

impl<const P: usize> Constraints<P> {
    /// Nothing held: the readings alone.
    pub fn none(&self) -> bool {
        self.prior_std_mm.is_none() && self.fixed.iter().all(Option::is_none)
    }
}
