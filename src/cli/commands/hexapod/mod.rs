//! The hexapod's own parts of the commands (`[mechanism] kind =
//! "hexapod"`): compensate's workspace maps and export. identifiability,
//! simulate, identify, the sweep with its report, and compensate and verify
//! are any mechanism's (`super::general`, dispatched by
//! `cli/mechanism.rs`). The other commands refuse a hexapod config in one
//! sentence until they run it.

mod compensate;
mod export;

pub use compensate::maps;
pub use export::run_export;

use crate::error::{Error, Result};
use std::path::Path;

/// The hexapod's 54 errors of a vector read from `path` (identified.csv).
fn hexapod_errors(path: &Path, e: Vec<f64>) -> Result<crate::mechanism::hexapod::Errors> {
    crate::mechanism::hexapod::errors_of(&e)
        .map_err(|why| Error::csv(path.display().to_string(), why))
}
