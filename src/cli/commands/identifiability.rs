//! `identifiability`: rank, singular values, condition number, O1–O5.

use crate::calibration::analyse_poses;
use crate::cli::{console, OutputFormat};
use crate::config::Config;
use crate::error::Result;
use crate::export::rows::{identifiability_json, with_hooke_axes};
use crate::export::text::identifiability_text;

pub fn run(cfg: &Config, format: OutputFormat) -> Result<()> {
    let p = analyse_poses(cfg)?;
    let method = cfg.identification.method;
    match format {
        OutputFormat::Json => {
            let bytes = identifiability_json(
                &cfg.unknowns().errors,
                method,
                p.poses,
                p.rows,
                &p.analysis,
                None::<&()>,
                None,
            )?;
            let bytes = with_hooke_axes(bytes, p.axes.as_ref())?;
            console::text(String::from_utf8_lossy(&bytes));
        }
        OutputFormat::Text => {
            console::text(identifiability_text(
                p.poses,
                &cfg.poses[0],
                method,
                &p.analysis,
            ));
            if let Some(x) = &p.axes {
                console::text(x.in_words());
            }
        }
    }
    Ok(())
}
