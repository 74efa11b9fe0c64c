//! `identifiability`: rank, singular values, condition number, O1–O5.

use crate::cli::{console, OutputFormat};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::rows::identifiability_json;
use crate::export::text::identifiability_text;
use crate::identify::design_matrix;

pub fn run(cfg: &Config, format: OutputFormat) -> Result<()> {
    let poses = cfg.nominal_poses()?;
    let h = design_matrix(&cfg.nominal(), &poses)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let method = cfg.identification.method;
    // The readings' own rank: no fixed error or prior.
    let solver = method
        .solver(
            &cfg.sensors,
            &poses.joints,
            &h,
            cfg.identification.rank_tolerance,
            &Default::default(),
        )
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    let a = &solver.analysis;
    match format {
        OutputFormat::Json => {
            let bytes = identifiability_json(method, poses.len(), h.nrows(), a, None::<&()>)?;
            console::text(String::from_utf8_lossy(&bytes));
        }
        OutputFormat::Text => {
            console::text(identifiability_text(poses.len(), &cfg.poses[0], method, a))
        }
    }
    Ok(())
}
