//! `export --format json` for the Tricept: its identified geometry as
//! geometry.json (the hexapod's LinuxCNC export is in hexapod/mod.rs).

use super::compensate::{check_nominal, gate_rejected_fit};
use crate::cli::console;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::{io, store};
use std::path::Path;

pub fn run_json(
    cfg: &Config,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    let size = cfg.resolved().geometry.a.min(cfg.resolved().geometry.b);
    let bound = store::inputs::identified_bound_mm(size);
    let model = store::inputs::read_identified(identified, bound, cfg.unknowns())?;
    check_nominal(cfg, identified)?;
    gate_rejected_fit(identified, accept_rejected_fit)?;
    // identify's report beside identified.csv: its covariance and checks.
    let fit = match store::inputs::checks_beside(identified) {
        None => serde_json::Value::Null,
        Some(path) => {
            let (file, bytes) = io::read_bytes(&path)?;
            serde_json::from_slice(&bytes)
                .map_err(|e| Error::csv(&file, format!("is not identify's JSON ({e})")))?
        }
    };
    let mut geometry =
        crate::calibration::geometry::geometry_json(&cfg.homed(), cfg.unknowns(), &model, &fit);
    geometry["identified_file"] = serde_json::json!(identified.display().to_string());
    geometry["config"] = serde_json::json!(cfg.source);
    write_geometry(&geometry, out)?;
    Ok(())
}

/// geometry.json (either machine's) into `out`, whole or not at all, and
/// say where.
pub fn write_geometry(geometry: &serde_json::Value, out: &Path) -> Result<()> {
    let text = serde_json::to_string_pretty(geometry)
        .map_err(|e| Error::Internal(format!("json: {e}")))?
        + "\n";
    let _lock = io::claim_dir(out)?;
    let path = out.join(store::names::GEOMETRY_JSON);
    let mut outputs = io::Outputs::default();
    outputs.add(path.clone(), text.into_bytes());
    outputs.write()?;
    console::line(format!(
        "wrote the calibrated geometry to {}",
        path.display()
    ));
    Ok(())
}
