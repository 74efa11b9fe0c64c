//! The hexapod's own commands (`[mechanism] kind = "hexapod"`): compensate
//! with its workspace maps, export, and the sweep's flags. identifiability,
//! simulate, identify, the sweep with its report, and compensate and verify
//! are any mechanism's (`super::general`). The other commands refuse a hexapod config in one
//! sentence until they run it.

mod compensate;
mod export;

pub use compensate::run_compensate;
pub use export::{run_export, run_export_json};

use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use std::path::Path;

/// `sweep` on a hexapod config's `text` (read from `source`): the Tricept's
/// study flags (`unsupported`, each with whether it was given) refused in
/// one sentence, `--trials` bounded as `sweep.trials`, then the study.
pub fn sweep_from_flags(
    text: &str,
    source: &str,
    out: &Path,
    (threads, trials, seed): (usize, Option<u64>, Option<u64>),
    unsupported: &[(&str, bool)],
) -> Result<()> {
    if let Some((flag, _)) = unsupported.iter().find(|(_, set)| *set) {
        return Err(Error::Argument(format!(
            "a hexapod sweep does not take {flag} (the Tricept's study does): it takes --config, --out, --trials, --seed and --threads"
        )));
    }
    if let Some(n) = trials.filter(|&n| n > 10_000_000) {
        return Err(Error::Argument(format!(
            "--trials must be at most 10000000 for a hexapod sweep (got {n}), as sweep.trials"
        )));
    }
    let cfg = HexapodConfig::parse(text, source)?;
    crate::cli::commands::general::run_sweep(&cfg, out, threads, trials, seed)
}

/// The hexapod's 54 errors of a vector read from `path` (identified.csv).
fn hexapod_errors(path: &Path, e: Vec<f64>) -> Result<crate::mechanism::hexapod::Errors> {
    crate::mechanism::hexapod::errors_of(&e)
        .map_err(|why| Error::csv(path.display().to_string(), why))
}
