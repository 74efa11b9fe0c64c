//! The hexapod's own commands (`[mechanism] kind = "hexapod"`): compensate
//! and verify, export, and the sweep with its report. identifiability,
//! simulate and identify are any mechanism's (`super::general`). The
//! other commands refuse a hexapod config in one sentence until they run
//! it.

mod compensate;
mod export;
mod report;
mod sweep;

pub use compensate::{run_compensate, run_verify};
pub use export::{run_export, run_export_json};
pub use sweep::sweep_from_flags;

/// The hexapod's 54 errors of a vector read from `path` (identified.csv).
fn hexapod_errors(
    path: &std::path::Path,
    e: Vec<f64>,
) -> crate::error::Result<crate::mechanism::hexapod::Errors> {
    crate::mechanism::hexapod::errors_of(&e)
        .map_err(|why| crate::error::Error::csv(path.display().to_string(), why))
}
