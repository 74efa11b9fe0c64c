//! The Tricept's sizes in the study's records: the one place the records
//! (an [`super::outcome::Outcome`], a [`super::partial::Partial`]), their
//! codec and the memory count take the number of errors a calibration
//! holds from. The kernel (context, trial, workspace, statement) reads the
//! Tricept's model directly; a generic record is this file's next step.

use crate::mechanism::tricept::N_PARAMS;

/// The errors a record holds per calibration: the Tricept's 15.
pub const ERRORS: usize = N_PARAMS;

/// One calibration's errors, as the records hold them.
pub type Errors = nalgebra::SVector<f64, ERRORS>;
