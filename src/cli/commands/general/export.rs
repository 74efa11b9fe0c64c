//! `export --format json` for any mechanism: geometry.json, the calibrated
//! geometry in a neutral file for other tools — the mechanism, the
//! convention, its units and layout nominal and identified
//! ([`Mechanism::layout`]), every error with its σ and what the convention
//! does with it, the correlations and identify's checks.

use super::files::{check_nominal, fit_beside, gate_rejected_fit, read_identified, read_std};
use crate::config::general::MechanismConfig;
use crate::error::{Error, Result};
use crate::mechanism::Mechanism;
use serde_json::{json, Value};
use std::path::Path;

/// −0 written as 0.
fn clean(x: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else {
        x
    }
}

/// geometry.json in `out` from identified.csv and the identifiability.json
/// identify wrote beside it; a fit identify's checks rejected is refused
/// unless `accept_rejected_fit`.
pub fn run_export_json<C: MechanismConfig>(
    cfg: &C,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    gate_rejected_fit(identified, accept_rejected_fit)?;
    let m = cfg.machine();
    let errors = read_identified(m, identified)?;
    let std = read_std(m, identified)?;
    let (file, fit) = fit_beside(identified).ok_or_else(|| {
        Error::csv(
            identified.display().to_string(),
            "has no readable identifiability.json beside it: export --format json reads the one identify wrote (its correlations and checks)",
        )
    })?;
    if fit["mechanism"] != m.name() {
        return Err(Error::csv(
            &file,
            format!("is not a {}'s identify output", m.name()),
        ));
    }
    check_nominal(cfg, identified)?;
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
    let mut geometry = m
        .layout(&errors)
        .map_err(|why| Error::csv(identified.display().to_string(), why))?;
    let error_names = m.error_names();
    let errs: Vec<Value> = m
        .present()
        .into_iter()
        .map(|j| {
            json!({
                "name": error_names[j],
                "unit": if m.is_angle(j) { "deg" } else { "mm" },
                "estimate": clean(errors[j]),
                "std_uncertainty": std[j],
                "source": m.error_source(j),
            })
        })
        .collect();
    geometry.insert("mechanism".into(), m.name().into());
    geometry.insert("convention".into(), m.convention().into());
    geometry.insert("errors".into(), errs.into());
    geometry.insert(
        "correlations".into(),
        json!({"names": names, "matrix": matrix}),
    );
    geometry.insert("checks".into(), fit["checks"].clone());
    geometry.insert(
        "identified_file".into(),
        identified.display().to_string().into(),
    );
    geometry.insert("config".into(), cfg.source().into());
    crate::cli::commands::export::write_geometry(&Value::Object(geometry), out)
}
