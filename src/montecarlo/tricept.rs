//! The Tricept's sizes in the study: the runner's blocks of error vectors
//! (each calibration's estimate − truth and its linearisation error) hold
//! its 15. The records they are summed into ([`super::partial::Partial`],
//! their codec and the memory count) hold any number, stated as
//! `Partial::errors`; the kernel (context, trial, workspace, statement)
//! reads the Tricept's model directly.

use crate::mechanism::tricept::N_PARAMS;

/// The errors a calibration estimates: the Tricept's 15.
pub const ERRORS: usize = N_PARAMS;

/// One calibration's errors, as the runner's blocks hold them.
pub type Errors = nalgebra::SVector<f64, ERRORS>;
