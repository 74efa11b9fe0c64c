//! `identify`: identification from a readings file.

use crate::calibration;
use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use crate::export::csv::csv_bytes;
use crate::export::rows::{identifiability_json, identified_csv};
use crate::io::{self, Outputs};
use crate::store;
use crate::store::names::{
    IDENTIFIABILITY_JSON, IDENTIFIED_CSV, IDENTIFY_FILES, SENSOR_CURVES_CSV,
};
use std::path::Path;

/// Residual over declared noise beyond which the readings are suspect.
const NOISE_RATIO_WARNING: f64 = 30.0;

pub fn run(cfg: &Config, readings_path: &Path, out: &Path) -> Result<()> {
    let file = readings_path.display().to_string();
    let readings = store::inputs::read_readings(readings_path)?;
    let cal = calibration::identify_from(cfg, &readings, &file)?;
    let (est, solver) = (&cal.estimate, &cal.solver);
    let _lock = io::claim_dir(out)?;
    let mut outputs = Outputs::default();
    outputs.replace_all(out, &IDENTIFY_FILES);
    outputs.add(out.join(IDENTIFIED_CSV), identified_csv(est)?);
    outputs.add(
        out.join(IDENTIFIABILITY_JSON),
        identifiability_json(
            cfg.identification.method,
            cal.poses.len(),
            solver.rows(),
            &solver.analysis,
        )?,
    );
    let curves = calibration::sensor_curves(cfg, &cal, &readings);
    if let Some(c) = &curves {
        outputs.add(out.join(SENSOR_CURVES_CSV), csv_bytes(c)?);
    }
    outputs.write()?;
    console::print_estimate(est, None);
    if let Some(c) = &curves {
        console::print_curves(c);
    }
    if let Some(z) = calibration::noise_ratio(cfg, &cal, &readings) {
        console::line(format_args!(
            "residual: {z:.2} × the declared sensor noise (noise alone gives about 1; linearisation error and errors the model leaves out add to it: 2–5 is usual for errors of ±0.5 mm, 1–2 with gls and datasheet sensors)"
        ));
        if z > NOISE_RATIO_WARNING {
            console::note(format_args!(
                "warning: the residual is {z:.0} times the noise [sensors] declares: the readings do not fit the model — check the units (degrees, mm), the column order ({}) and signs, the sensor grades in [sensors], or the geometry",
                crate::model::READINGS.iter().map(|r| r.ascii).collect::<Vec<_>>().join(", ")
            ));
        }
    }
    console::warn_unidentifiable(&solver.analysis);
    if !est.termination.converged() {
        console::note(format_args!(
            "warning: Gauss-Newton did not converge in {} iterations (tolerance {} mm); the last estimate is written",
            est.iterations, cfg.identification.tolerance_mm
        ));
    }
    console::line(format_args!(
        "{} poses, method {}, {} linearisation(s) ({}), weighted residual RMS {:.3e}; wrote {}",
        cal.poses.len(),
        cfg.identification.method.name(),
        est.iterations,
        est.termination.describe(),
        est.residual_rms,
        out.join(IDENTIFIED_CSV).display()
    ));
    Ok(())
}
