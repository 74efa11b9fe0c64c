//! `verify`: an identified model against a fresh log of the machine, with
//! a pass/fail against a stated threshold.

use crate::calibration::{self, VerifyRow};
use crate::cli::console;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::csv::csv_bytes;
use crate::io::{self, Outputs};
use crate::metrics::stats;
use crate::store;
use crate::store::names::VERIFY_CSV;
use serde::Serialize;
use std::path::Path;

/// The verification's result (printed with `--json`).
#[derive(Debug, Serialize)]
pub struct Verification {
    pub rows: usize,
    pub commands: &'static str,
    pub threshold_mm: f64,
    pub max_mm: f64,
    pub p95_mm: f64,
    pub mean_mm: f64,
    /// The line of the worst row.
    pub worst_line: usize,
    pub passed: bool,
}

pub struct VerifyArgs<'a> {
    pub identified: &'a Path,
    pub readings: &'a Path,
    pub threshold_mm: f64,
    pub nominal_commands: bool,
    pub out: Option<&'a Path>,
    pub json: bool,
}

pub fn run(cfg: &Config, a: &VerifyArgs) -> Result<()> {
    if !(a.threshold_mm.is_finite() && a.threshold_mm > 0.0) {
        return Err(Error::Argument(format!(
            "--threshold must be a positive distance in mm (got {})",
            a.threshold_mm
        )));
    }
    let size = cfg.resolved().geometry.a.min(cfg.resolved().geometry.b);
    let bound = store::inputs::identified_bound_mm(size);
    let identified = store::inputs::read_identified(a.identified, bound)?.machine(&cfg.geometry);
    let readings = store::inputs::read_readings(a.readings)?;
    let file = a.readings.display().to_string();
    let rows = calibration::verify(cfg, &identified, &readings, a.nominal_commands, &file)?;
    let v = summarise(&rows, a.threshold_mm, a.nominal_commands);
    if let Some(out) = a.out {
        let _lock = io::claim_dir(out)?;
        let mut outputs = Outputs::default();
        outputs.replace_all(out, &[VERIFY_CSV]);
        outputs.add(out.join(VERIFY_CSV), csv_bytes(&rows)?);
        outputs.write()?;
    }
    let words = format!(
        "{} rows ({} commands): position error by the passive limb max {:.4} mm (line {}), p95 {:.4} mm, mean {:.4} mm against the threshold {} mm: {}",
        v.rows,
        v.commands,
        v.max_mm,
        v.worst_line,
        v.p95_mm,
        v.mean_mm,
        v.threshold_mm,
        if v.passed { "PASS" } else { "FAIL" }
    );
    if a.json {
        console::json(&v)?;
    } else {
        console::line(format_args!("verify: {words}"));
    }
    if v.passed {
        Ok(())
    } else {
        Err(Error::TargetNotMet(format!(
            "{file}: the machine misses the threshold: {words}"
        )))
    }
}

/// Max, p95 and mean of the rows' errors; pass when the largest is within
/// the threshold.
pub fn summarise(rows: &[VerifyRow], threshold_mm: f64, nominal: bool) -> Verification {
    let mut e: Vec<f64> = rows.iter().map(|r| r.error_mm).collect();
    let (worst, max) =
        e.iter().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |a, (i, &x)| if x > a.1 { (i, x) } else { a },
        );
    let mean = e.iter().sum::<f64>() / e.len().max(1) as f64;
    e.sort_by(f64::total_cmp);
    Verification {
        rows: rows.len(),
        commands: if nominal { "nominal" } else { "compensated" },
        threshold_mm,
        max_mm: max,
        p95_mm: stats::quantile_sorted(&e, 0.95),
        mean_mm: mean,
        worst_line: crate::io::data_line(worst),
        passed: max <= threshold_mm,
    }
}
