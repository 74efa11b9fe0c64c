//! `verify` of any mechanism with actuators ([`Commanded`]): an identified
//! machine against a fresh log of its sensors.

use super::compensate::amounts;
use super::files::{check_nominal, read_identified, read_log, Log};
use crate::cli::console;
use crate::config::general::MechanismConfig;
use crate::error::{Error, Result};
use crate::mechanism::{Commanded, Mechanism};
use std::path::Path;

/// `verify`: for each row of the log at `readings`, where the identified
/// machine lands with the commands it was given (its own, or with
/// `nominal_commands` the nominal machine's), against where its sensors'
/// readings put it (through the same identified machine): their distance
/// is how far the model's prediction is from where the readings say it
/// stood. It passes when every row is within `threshold_mm` (exit 3
/// otherwise), and says what such a check cannot see.
pub fn run_verify<C: MechanismConfig>(
    cfg: &C,
    identified: &Path,
    readings: &Path,
    threshold_mm: f64,
    nominal_commands: bool,
) -> Result<()>
where
    C::M: Commanded,
{
    if !(threshold_mm.is_finite() && threshold_mm > 0.0) {
        return Err(Error::Argument(format!(
            "--threshold must be a positive number of mm (got {threshold_mm})"
        )));
    }
    let errors = read_identified(cfg.machine(), identified)?;
    check_nominal(cfg, identified)?;
    let log = read_log(cfg, readings, "verify")?;
    let (passed, text) = verify_text(cfg.machine(), &errors, &log, threshold_mm, nominal_commands)?;
    if !passed {
        return Err(Error::TargetNotMet(format!("{}: FAIL: {text}", log.file)));
    }
    let w = cfg.machine().words();
    console::line(format!(
        "PASS relative to {} only: {text}; what it cannot see: {}",
        w.readers, w.cannot_see
    ));
    Ok(())
}

/// Whether the machine with `errors` passes the check on `log` at
/// `threshold_mm` (the position), and the sentence that says how close it
/// came by each judged quantity, with the worst row's line.
pub fn verify_text<M: Commanded>(
    m: &M,
    errors: &[f64],
    log: &Log<M::Target>,
    threshold_mm: f64,
    nominal_commands: bool,
) -> Result<(bool, String)> {
    let per = m.reading_facts().len();
    let zero = vec![0.0; errors.len()];
    let file = &log.file;
    let judged = m.judged();
    let n = log.targets.len();
    if judged.is_empty() || log.lines.len() != n || log.readings.len() != per * n {
        return Err(Error::Internal(format!(
            "{file}: {n} targets, {} lines and {} readings for {per} a pose, {} judged quantities",
            log.lines.len(),
            log.readings.len(),
            judged.len()
        )));
    }
    let mut worst = vec![0.0f64; judged.len()];
    let mut worst_line = log.lines.first().copied().unwrap_or(0);
    for (k, (target, line)) in log.targets.iter().zip(&log.lines).enumerate() {
        let read = &log.readings[k * per..(k + 1) * per];
        let by = if nominal_commands { &zero[..] } else { errors };
        let q = m
            .commands(by, target)
            .map_err(|why| Error::csv(file, format!("line {line}: {why}")))?;
        let reached = m.reach(errors, &q, target).map_err(|why| {
            Error::csv(file, format!("line {line}: the identified machine {why}"))
        })?;
        let seen = m
            .seen(errors, read, &reached)
            .map_err(|why| Error::csv(file, format!("line {line}: {why}")))?;
        let miss = m.miss(&seen, &reached);
        if miss.len() != judged.len() || miss.iter().any(|d| !d.is_finite()) {
            return Err(Error::csv(
                file,
                format!("line {line}: the identified machine's prediction and the readings' account cannot be compared ({miss:?})"),
            ));
        }
        if miss[0] > worst[0] {
            worst_line = *line;
        }
        for (w, d) in worst.iter_mut().zip(&miss) {
            *w = w.max(*d);
        }
    }
    let w = m.words();
    let within = amounts(judged, worst.iter().copied(), 2);
    let text = format!(
        "{} poses: the identified machine puts the {} within {within} of where {} say it stood (worst at line {worst_line}); threshold {threshold_mm} mm",
        log.targets.len(),
        w.moving,
        w.readers,
    );
    Ok((worst[0] <= threshold_mm, text))
}
