//! `verify`: an identified model against a fresh log of the machine, with
//! a pass/fail against a stated threshold.

use crate::calibration::{self, VerifyRow};
use crate::cli::console;
use crate::config::{Config, ConfigRow};
use crate::error::{Error, Result};
use crate::export::csv::csv_bytes;
use crate::io::{self, Outputs, Source};
use crate::mechanism::LogRow;
use crate::metrics::stats;
use crate::store;
use crate::store::names::{VERIFY_CSV, VERIFY_REFERENCE_CSV};
use nalgebra::Vector3;
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
    /// Every row (and reference point) within the threshold.
    pub passed: bool,
    /// "pass" (absolute: reference points given and within), "pass_relative"
    /// (the passive limb's rows within, relative to the reference pose:
    /// `untested` says what they cannot see) or "fail".
    pub verdict: &'static str,
    /// What the passive limb's rows cannot see: the identified model's
    /// error at the reference pose (docs/method.md §18).
    pub untested: Option<calibration::Untested>,
    /// Externally measured points (`--reference`) and their largest error.
    pub reference_points: usize,
    pub reference_max_mm: Option<f64>,
    /// The reference file's line of the largest.
    pub reference_worst_line: Option<usize>,
}

pub struct VerifyArgs<'a> {
    pub identified: &'a Path,
    pub readings: &'a Path,
    pub threshold_mm: f64,
    pub nominal_commands: bool,
    pub reference: Option<&'a Path>,
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
    let model = store::inputs::read_identified(a.identified, bound, cfg.unknowns())?;
    super::compensate::check_nominal(cfg, a.identified)?;
    let identified = model.machine(&cfg.homed());
    let (readings, lines) = store::inputs::read_readings::<ConfigRow, _>(a.readings)?;
    let file = a.readings.display().to_string();
    let source = Source::new(&file, &lines);
    let reach = cfg.reach();
    let rows = calibration::verify(&reach, &identified, &readings, a.nominal_commands, source)?;
    let rfile = a
        .reference
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let (reference, rlines) = match a.reference {
        Some(p) => {
            let (points, rlines) = store::inputs::read_reference(p)?;
            let rows = calibration::reference_rows(
                &reach,
                &identified,
                &points,
                a.nominal_commands,
                (Source::new(&rfile, &rlines), bound),
            )?;
            (rows, rlines)
        }
        None => (Vec::new(), Vec::new()),
    };
    let rsource = Source::new(&rfile, &rlines);
    let mut v = summarise(&rows, a.threshold_mm, a.nominal_commands, source);
    let ref_worst = reference
        .iter()
        .enumerate()
        .fold(None, |m: Option<(usize, f64)>, (i, r)| match m {
            Some((_, x)) if x >= r.error_mm => m,
            _ => Some((i, r.error_mm)),
        });
    let ref_max = ref_worst.map(|w| w.1);
    v.reference_points = reference.len();
    v.reference_max_mm = ref_max;
    v.reference_worst_line = ref_worst.map(|w| rsource.line(w.0) as usize);
    if ref_max.is_some_and(|m| m > a.threshold_mm) {
        v.passed = false;
    }
    if reference.is_empty() {
        let cov = store::inputs::read_covariance(a.identified);
        let first = readings.first().map_or(Vector3::zeros(), |r| r.target());
        v.untested = Some(calibration::untested(
            &reach,
            cfg.unknowns(),
            &model,
            cov.as_ref(),
            &first,
        )?);
    }
    v.verdict = match (v.passed, reference.is_empty()) {
        (false, _) => "fail",
        (true, true) => "pass_relative",
        (true, false) => "pass",
    };
    if let Some(out) = a.out {
        let _lock = io::claim_dir(out)?;
        let mut outputs = Outputs::default();
        outputs.replace_all(out, &[VERIFY_CSV, VERIFY_REFERENCE_CSV]);
        outputs.add(out.join(VERIFY_CSV), csv_bytes(&rows)?);
        if !reference.is_empty() {
            outputs.add(out.join(VERIFY_REFERENCE_CSV), csv_bytes(&reference)?);
        }
        outputs.write()?;
    }
    let mut words = format!(
        "{} rows ({} commands): position error by the passive limb max {:.4} mm (line {}), p95 {:.4} mm, mean {:.4} mm",
        v.rows, v.commands, v.max_mm, v.worst_line, v.p95_mm, v.mean_mm,
    );
    if let (Some((i, m)), Some(p)) = (ref_worst, a.reference) {
        words.push_str(&format!(
            "; {} externally measured point(s) in {}: largest error {m:.4} mm (line {})",
            reference.len(),
            p.display(),
            rsource.line(i)
        ));
    }
    words.push_str(&format!(" against the threshold {} mm: ", v.threshold_mm));
    words.push_str(&match (v.verdict, &v.untested) {
        ("fail", _) => "FAIL".to_string(),
        ("pass", _) => {
            "PASS (absolute: the reference points test what the passive limb cannot see)"
                .to_string()
        }
        (_, Some(u)) => format!(
            "PASS relative to the reference pose only; {}",
            untested_words(u, v.threshold_mm)
        ),
        _ => "PASS relative to the reference pose only".to_string(),
    });
    if a.json {
        console::json(&v)?;
    } else {
        console::line(format_args!("verify: {words}"));
    }
    if v.passed {
        Ok(())
    } else {
        // Name the file whose rows miss: the log's, the reference's, or both.
        let log_misses = v.max_mm > a.threshold_mm;
        let who = match (log_misses, a.reference) {
            (false, Some(p)) => p.display().to_string(),
            (true, Some(p)) if ref_max.is_some_and(|m| m > a.threshold_mm) => {
                format!("{file} and {}", p.display())
            }
            _ => file.clone(),
        };
        Err(Error::TargetNotMet(format!(
            "{who}: the machine misses the threshold: {words}"
        )))
    }
}

/// What the passive limb's rows cannot see, in words.
fn untested_words(u: &calibration::Untested, threshold: f64) -> String {
    let mut parts = Vec::new();
    match u.bound_mm {
        Some(b) => parts.push(format!(
            "not tested: an error the reference pose shares with every pose, up to {b:.4} mm (95 %, from the identification's {})",
            u.source
        )),
        None => parts.push("not tested, and nothing bounds it: an error the reference pose shares with every pose (identified.csv states no uncertainty, and identify's covariance does not lie beside it)".to_string()),
    }
    if !u.unbounded.is_empty() {
        parts.push(format!(
            "nor whatever {} (not bounded by the identification) contribute",
            u.unbounded.join(", ")
        ));
    }
    let short = u.bound_mm.is_none_or(|b| b > threshold) || !u.unbounded.is_empty();
    let mut out = parts.join(", ");
    if short {
        out.push_str(&format!(
            ": more than this check can vouch for at {threshold} mm"
        ));
    }
    out.push_str("; measure one absolute point (a touch-off or tracker point at the reference pose) and pass it with --reference to test it");
    out
}

/// Max, p95 and mean of the rows' errors; pass when the largest is within
/// the threshold. The worst row's line is its line in `file`.
pub fn summarise(
    rows: &[VerifyRow],
    threshold_mm: f64,
    nominal: bool,
    file: Source,
) -> Verification {
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
        worst_line: file.line(worst) as usize,
        passed: max <= threshold_mm,
        verdict: if max <= threshold_mm {
            "pass_relative"
        } else {
            "fail"
        },
        untested: None,
        reference_points: 0,
        reference_max_mm: None,
        reference_worst_line: None,
    }
}
