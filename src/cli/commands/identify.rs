//! `identify`: identification from a readings file.

use crate::calibration;
use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use crate::export::names::{IDENTIFIABILITY_JSON, IDENTIFIED_CSV};
use crate::export::rows::{identifiability_json, identified_csv};
use crate::io::{self, Outputs};
use std::path::Path;

pub fn run(cfg: &Config, readings_path: &Path, out: &Path) -> Result<()> {
    let file = readings_path.display().to_string();
    let readings = io::read_readings(readings_path)?;
    let cal = calibration::identify_from(cfg, &readings, &file)?;
    let (est, solver) = (&cal.estimate, &cal.solver);
    io::ensure_dir(out)?;
    let mut outputs = Outputs::default();
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
    outputs.write()?;
    console::print_estimate(est, None);
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
