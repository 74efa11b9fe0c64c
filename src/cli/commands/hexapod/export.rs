//! `export` for the hexapod: genhexkins' files and geometry.json.

use super::hexapod_errors;
use crate::cli::commands::general::files::{
    fit_beside, gate_rejected_fit, read_identified, read_std,
};
use crate::cli::console;
use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::hexapod::convention::{self, CONVENTION};
use crate::mechanism::hexapod::N_ERRORS;
use std::path::Path;

/// `export --format linuxcnc`: genhexkins.hal and joints.ini of the
/// identified geometry in `out`.
pub fn run_export(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    gate_rejected_fit(identified, accept_rejected_fit)?;
    use crate::mechanism::hexapod::export::{genhexkins_hal, joints_ini};
    use crate::store::names::{GENHEXKINS_HAL, JOINTS_INI, LINUXCNC_FILES};
    let errors = hexapod_errors(identified, read_identified(&cfg.hexapod, identified)?)?;
    let header = vec![
        format!(
            "tricept-calib {}: the hexapod geometry identified in {}",
            env!("CARGO_PKG_VERSION"),
            identified.display()
        ),
        format!("config {}; mm; the convention: {CONVENTION}", cfg.source),
    ];
    let mut hal_header = header.clone();
    hal_header.push("after `loadrt genhexkins`: base joints in world coordinates, platform joints in platform coordinates".into());
    let mut ini_header = header;
    ini_header.push("each strut's length when its actuator reads 0 (the nominal home length plus the identified leg offset), mm".into());
    let _lock = io::claim_dir(out)?;
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &LINUXCNC_FILES);
    outputs.add(
        out.join(GENHEXKINS_HAL),
        genhexkins_hal(&cfg.hexapod, &errors, &hal_header).into_bytes(),
    );
    outputs.add(
        out.join(JOINTS_INI),
        joints_ini(&cfg.hexapod, &errors, &ini_header).into_bytes(),
    );
    outputs.write()?;
    console::line(format!(
        "wrote {} (36 genhexkins pins) and {} (6 joints' homes) to {}",
        GENHEXKINS_HAL,
        JOINTS_INI,
        out.display()
    ));
    Ok(())
}

/// `export --format json`: geometry.json from identified.csv and the
/// identifiability.json identify wrote beside it.
pub fn run_export_json(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    gate_rejected_fit(identified, accept_rejected_fit)?;
    use crate::mechanism::hexapod::export::{geometry_json, Fit};
    let errors = hexapod_errors(identified, read_identified(&cfg.hexapod, identified)?)?;
    let std = hexapod_errors(identified, read_std(&cfg.hexapod, identified)?)?;
    let (file, fit) = fit_beside(identified).ok_or_else(|| {
        Error::csv(
            identified.display().to_string(),
            "has no readable identifiability.json beside it: export --format json reads the one identify wrote (its correlations and checks)",
        )
    })?;
    if fit["mechanism"] != "hexapod" {
        return Err(Error::csv(&file, "is not a hexapod's identify output"));
    }
    let names: Vec<String> = fit["correlations"]["names"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    let matrix: Vec<Vec<f64>> = fit["correlations"]["matrix"]
        .as_array()
        .map(|rows| {
            rows.iter()
                .map(|r| {
                    r.as_array()
                        .map(|c| c.iter().filter_map(|x| x.as_f64()).collect())
                        .unwrap_or_default()
                })
                .collect()
        })
        .unwrap_or_default();
    if matrix.len() != names.len() || matrix.iter().any(|r| r.len() != names.len()) {
        return Err(Error::csv(
            &file,
            "correlations: the matrix is not one row and column per name",
        ));
    }
    let geometry = geometry_json(
        &cfg.hexapod,
        &errors,
        &Fit {
            std: &std,
            correlations: (names, matrix),
            checks: fit["checks"].clone(),
            sources: (0..N_ERRORS).map(convention::source).collect(),
        },
        CONVENTION,
    );
    crate::cli::commands::export::write_geometry(&geometry, out)
}
