//! The files of any mechanism's commands: the readings log, identified.csv
//! and the identifiability.json identify writes beside it, and a targets
//! CSV.

use crate::calibration::readings_check::{self, what_to_check};
use crate::cli::console;
use crate::config::general::MechanismConfig;
use crate::error::{Error, Result};
use crate::identify::repeats::{Counted, Repeats, Unit};
use crate::io;
use crate::mechanism::{Mechanism, Quantity, ReadingFact};
use std::path::Path;

/// Rows a readings log or targets file may have, counted before any work
/// (identify builds a dense design of every row's readings).
pub const MAX_POSES: usize = crate::config::general::MAX_POSES;

/// Target of a config's mechanism.
type Target<C> = <<C as MechanismConfig>::M as Mechanism>::Target;

/// The likeliest slip of the log that makes a row's readings `read` differ
/// from `nominal` (the generic readings diagnosis, by the machine's reading
/// facts); where none explains them, what to check.
fn slip(facts: &[ReadingFact], read: &[f64], nominal: &[f64]) -> String {
    readings_check::slip(facts, read, nominal).unwrap_or_else(|| {
        format!(
            "{}, or whether the log is another machine's",
            what_to_check(facts)
        )
    })
}

/// The readings' header: the target, then each instrumented joint.
pub fn header(m: &impl Mechanism) -> Vec<String> {
    let mut h: Vec<String> = m.target_columns().iter().map(|s| s.to_string()).collect();
    h.extend(m.reading_facts().iter().map(|f| f.column.to_string()));
    h
}

/// A log: each row's target and readings, read as identify and verify
/// read it (at most [`MAX_POSES`] rows, counted before any work).
pub struct Log<T> {
    pub file: String,
    /// Each row's line in the file.
    pub lines: Vec<u64>,
    pub targets: Vec<T>,
    /// The targets' cells as read, row after row.
    pub cells: Vec<f64>,
    /// The readings, row after row (the mechanism's readings a pose).
    pub readings: Vec<f64>,
}

impl<T: Copy> Log<T> {
    /// The log's rows that repeat a pose ([`Repeats`]), counted as the
    /// readings' σ `white` (file units, per reading of a pose or one for
    /// all; empty: unstated; stated by `what`), each reading's unit in
    /// the note by `units` ([`Repeats::judged`]) says: repeats that scatter as fresh readings
    /// of it stay rows (each row's distinct pose returned, for the
    /// held-out folds); otherwise each distinct pose once, at the mean of
    /// its readings and its first line (no groups returned), how they
    /// count said by the [`Counted`] returned. The note
    /// identify prints with it, when rows repeat. Loggings a steady offset
    /// apart are counted at the pose's mean, or refused where the poses
    /// are not all logged equally often ([`Repeats::judged`]).
    pub fn by_pose(
        self,
        (width, per): (usize, usize),
        (white, what): (&[f64], &str),
        units: &[Unit],
    ) -> Result<(Self, Vec<usize>, Counted, Option<String>)> {
        let r = Repeats::of(&self.cells, width);
        if r.repeated() == 0 {
            return Ok((self, Vec::new(), Counted::Rows, None));
        }
        let (counted, note) = r
            .judged((&self.readings, per), white, what, units)
            .map_err(|why| Error::csv(&self.file, why))?;
        if counted == Counted::Rows {
            return Ok((self, r.of_row, counted, note));
        }
        let log = Log {
            lines: r.first.iter().map(|&i| self.lines[i]).collect(),
            targets: r.first.iter().map(|&i| self.targets[i]).collect(),
            cells: r
                .first
                .iter()
                .flat_map(|&i| self.cells[i * width..(i + 1) * width].iter().copied())
                .collect(),
            readings: r.means(&self.readings, per),
            file: self.file,
        };
        Ok((log, Vec::new(), counted, note))
    }
}

/// A number in a message: as written (or to `digits` decimals), or in
/// scientific notation where it is too large to read in full (1e300 as
/// "1.0000e300", not 301 digits).
fn compact(x: f64, digits: Option<usize>) -> String {
    match (x.abs() >= 1e6, digits) {
        (true, _) => format!("{x:.4e}"),
        (false, Some(d)) => format!("{x:.d$}"),
        (false, None) => format!("{x}"),
    }
}

/// Read the log at `path` for `verb` (the command, for messages). A
/// reading far from what the nominal machine reads at its pose is not a
/// calibration's error (a wrapped angle, a column swapped, another
/// machine's log): refused here, naming its line and column.
pub fn read_log<C: MechanismConfig>(cfg: &C, path: &Path, verb: &str) -> Result<Log<Target<C>>> {
    let m = cfg.machine();
    let (file, bytes) = io::read_bytes(path)?;
    let head = header(m);
    let cols: Vec<&str> = head.iter().map(String::as_str).collect();
    let width = m.target_columns().len();
    let per = m.reading_facts().len();
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let most = MAX_POSES;
    if table.rows.len() > most {
        return Err(Error::csv(
            &file,
            format!(
                "has {} poses; {verb} reads at most {most} (a dense design of {per} rows each): split the log",
                table.rows.len(),
            ),
        ));
    }
    let zero = vec![0.0; m.error_names().len()];
    let plausible: Vec<f64> = m.reading_facts().iter().map(|f| f.plausible).collect();
    // A row's slip is named from these (each reading's plausible distance
    // the slip's tolerance): the refusal itself is at each reading's
    // plausible distance.
    let facts: Vec<ReadingFact> = m
        .reading_facts()
        .into_iter()
        .enumerate()
        .map(|(k, f)| ReadingFact {
            plausible: m.slip_tolerance(k),
            ..f
        })
        .collect();
    let mut log = Log {
        file: file.clone(),
        lines: Vec::with_capacity(table.rows.len()),
        targets: Vec::with_capacity(table.rows.len()),
        cells: Vec::with_capacity(table.rows.len() * width),
        readings: Vec::with_capacity(table.rows.len() * per),
    };
    for (line, cells) in &table.rows {
        let mut v = Vec::with_capacity(cells.len());
        for (c, cell) in cols.iter().zip(cells) {
            v.push(io::number(&file, *line, c, cell)?);
        }
        // Within the machine's travel, as a target of compensate must be:
        // a pose the machine cannot reach is not one it was logged at.
        let target = checked_target(cfg, (&file, *line), &v[..width])?;
        let nominal = m
            .readings(&zero, &target)
            .map_err(|why| Error::csv(&file, format!("line {line}: the nominal machine cannot reach the target ({why}): check the target's columns and units (mm, degrees)")))?;
        let read = &v[width..];
        if let Some(k) = (0..read.len()).find(|&k| (read[k] - nominal[k]).abs() > plausible[k]) {
            let (r, n) = (read[k], nominal[k]);
            let u = if facts[k].quantity == Quantity::Angle {
                "°"
            } else {
                " mm"
            };
            return Err(Error::csv(
                &file,
                format!(
                    "line {line}: {} = {}{u} is {}{u} from what the nominal machine reads at that pose ({n:.4}{u}); a calibration moves a reading by well under {}{u}: {}",
                    cols[width + k],
                    compact(r, None),
                    compact(r - n, Some(3)),
                    plausible[k],
                    slip(&facts, read, &nominal)
                ),
            ));
        }
        log.lines.push(*line);
        log.targets.push(target);
        log.cells.extend_from_slice(&v[..width]);
        log.readings.extend_from_slice(read);
    }
    Ok(log)
}

/// identified.csv: one row per error the machine has; lengths in
/// `estimate_mm` and `std_uncertainty_mm`, the encoders' zeros in
/// `estimate_deg` and `std_uncertainty_deg`; `source` says what the
/// convention did with it, or that it was fixed or is the prior's.
pub fn identified_csv<C: MechanismConfig>(
    cfg: &C,
    id: &crate::identify::general::Identified,
) -> String {
    let m = cfg.machine();
    let names = m.error_names();
    let sd = id.std();
    let mut s = String::from(
        "parameter,estimate_mm,std_uncertainty_mm,estimate_deg,std_uncertainty_deg,source\n",
    );
    for j in m.present() {
        let v = if id.errors[j] == 0.0 {
            0.0
        } else {
            id.errors[j]
        };
        let cells = format!("{v},{}", sd[j]);
        let (mm, deg) = if m.is_angle(j) {
            (",".to_string(), cells)
        } else {
            (cells, ",".to_string())
        };
        // A source with a comma ("in the plane of p1, p2, p3") is quoted.
        // Held: "fixed"; a single error the prior outweighs the readings on
        // (posterior σ above σp/√2): "prior".
        let source = match m.error_source(j) {
            _ if id.fixed.contains(&j) => "fixed",
            "identified"
                if cfg
                    .holds()
                    .prior_std(m, j)
                    .is_some_and(|sp| sd[j] > sp / std::f64::consts::SQRT_2) =>
            {
                "prior"
            }
            other => other,
        };
        let source = if source.contains(',') {
            format!("\"{source}\"")
        } else {
            source.to_string()
        };
        s += &format!("{},{mm},{deg},{source}\n", names[j]);
    }
    s
}

/// The identified errors from `path` (identify's identified.csv): one row
/// per error this machine has, each once, lengths in `estimate_mm` and
/// angles in `estimate_deg`.
pub fn read_identified(m: &impl Mechanism, path: &Path) -> Result<Vec<f64>> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["parameter", "estimate_mm", "estimate_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &["source"])?;
    let names = m.error_names();
    let present = m.present();
    let mut e = vec![0.0; names.len()];
    let mut seen = vec![false; names.len()];
    for (line, cells) in &table.rows {
        let name = cells[0].as_str();
        let Some(j) = names
            .iter()
            .position(|n| n == name)
            .filter(|j| present.contains(j))
        else {
            return Err(Error::csv(
                &file,
                format!(
                    "line {line}: {name} is not an error of this {} ({} … {}, as it is instrumented)",
                    m.name(),
                    names[present[0]],
                    names[present[present.len() - 1]]
                ),
            ));
        };
        if seen[j] {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} is listed twice"),
            ));
        }
        seen[j] = true;
        let (col, cell) = if m.is_angle(j) {
            ("estimate_deg", &cells[2])
        } else {
            ("estimate_mm", &cells[1])
        };
        let v = io::number(&file, *line, col, cell)?;
        let cap = runaway(m, j);
        if v.abs() > cap {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} = {v} is beyond ±{cap}, not a calibration's size"),
            ));
        }
        e[j] = v;
    }
    if let Some(j) = present.iter().find(|&&j| !seen[j]) {
        return Err(Error::csv(
            &file,
            format!(
                "{} is missing: identified.csv lists every error of the machine",
                names[*j]
            ),
        ));
    }
    Ok(e)
}

/// The largest an error may be and still be a calibration's: 5° for an
/// angle, 10 mm for a length.
pub fn runaway(m: &impl Mechanism, j: usize) -> f64 {
    if m.is_angle(j) {
        5.0
    } else {
        10.0
    }
}

/// Each error's standard uncertainty from identified.csv (0 where absent).
pub fn read_std(m: &impl Mechanism, path: &Path) -> Result<Vec<f64>> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["parameter", "std_uncertainty_mm", "std_uncertainty_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let names = m.error_names();
    let mut sd = vec![0.0; names.len()];
    for (line, cells) in &table.rows {
        if let Some(j) = names.iter().position(|n| *n == cells[0]) {
            let (col, cell) = if m.is_angle(j) {
                (cols[2], &cells[2])
            } else {
                (cols[1], &cells[1])
            };
            let v = io::number(&file, *line, col, cell)?;
            if v < 0.0 {
                return Err(Error::csv(&file, format!("line {line}: {col} is negative")));
            }
            sd[j] = v;
        }
    }
    Ok(sd)
}

/// A file row's target, checked against the machine's limits: a malformed
/// one said as the mechanism says it, one beyond the limits as "the
/// target needs …" (both at the file's line).
fn checked_target<C: MechanismConfig>(
    cfg: &C,
    (file, line): (&str, u64),
    cells: &[f64],
) -> Result<Target<C>> {
    cfg.machine()
        .target_of(cells)
        .map_err(|why| Error::csv(file, format!("line {line}: {why}")))?;
    cfg.target(cells)
        .map_err(|why| Error::csv(file, format!("line {line}: the target {why}")))
}

/// A targets CSV: the mechanism's target columns per row, each within the
/// machine's limits ([`MechanismConfig::target`]): the rows as written and
/// as targets.
pub type Targets<T> = (Vec<Vec<f64>>, Vec<T>);

pub fn read_targets<C: MechanismConfig>(path: &Path, cfg: &C) -> Result<Targets<Target<C>>> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = cfg.machine().target_columns();
    let (table, _) = io::read_table(&file, &bytes, cols, &[])?;
    if table.rows.len() > MAX_POSES {
        return Err(Error::csv(
            &file,
            format!(
                "has {} targets; at most {} are read",
                table.rows.len(),
                MAX_POSES
            ),
        ));
    }
    let mut list = Vec::with_capacity(table.rows.len());
    let mut poses = Vec::with_capacity(table.rows.len());
    for (line, cells) in &table.rows {
        let mut x = Vec::with_capacity(cols.len());
        for (c, cell) in cols.iter().zip(cells) {
            x.push(io::number(&file, *line, c, cell)?);
        }
        let p = checked_target(cfg, (&file, *line), &x)?;
        poses.push(p);
        list.push(x);
    }
    Ok((list, poses))
}

/// identify's identifiability.json (`fitted` rows, one a pose where
/// repeats were averaged; the log's `rows`; `poses` distinct among them):
/// the rank, the convention, the
/// readings' σ (in the first reading's sensor unit) and the checks, and the
/// free errors' correlations.
pub fn fit_json<C: MechanismConfig>(
    cfg: &C,
    id: &crate::identify::general::Identified,
    (fitted, rows, poses): (usize, usize, usize),
    (rank, free): (usize, usize),
    stated_sigma: bool,
    predicted: &Predicted,
) -> Result<String> {
    let m = cfg.machine();
    let names = m.error_names();
    let sd = id.std();
    let kept: Vec<usize> = (0..names.len()).filter(|&j| sd[j] > 0.0).collect();
    let matrix: Vec<Vec<f64>> = kept
        .iter()
        .map(|&a| {
            kept.iter()
                .map(|&b| id.covariance[(a, b)] / (sd[a] * sd[b]))
                .collect()
        })
        .collect();
    let misfit = match misfit(cfg, id, fitted, stated_sigma) {
        Some(m) => serde_json::json!({
            "chi2": m.chi2,
            "dof": m.dof,
            "p_value": if m.p.is_finite() { serde_json::json!(m.p) } else { serde_json::Value::Null },
            // The readings fit worse than their stated σ allows (1 in
            // 1,000 by chance): a model or sensor error beyond the noise.
            "passed": m.passed(),
        }),
        None => serde_json::json!(format!(
            "not tested: σ taken from the residuals (state {} to test the fit)",
            cfg.reading_sigma().1
        )),
    };
    let held = match &predicted.held_out {
        Some((h, line)) => serde_json::json!({
            "folds": h.folds,
            "readings": h.readings,
            "rms_z": h.rms_z,
            "max_abs_z": h.max_abs_z,
            "worst_line": line,
            "folds_skipped": h.folds_skipped,
            // Poses left out predicted more than twice as badly as the
            // readings' σ allows: the model does not carry over.
            "passed": h.rms_z <= HELD_OUT_LIMIT,
        }),
        None => serde_json::json!(format!(
            "not tested: it needs {} poses or more",
            2 * crate::identify::general::HELD_OUT_FOLDS
        )),
    };
    let a = &predicted.accuracy;
    let tool = cfg.tool_mm();
    let mut accuracy = serde_json::json!({
        "draws": a.draws,
        "workspace_poses": a.poses,
        "tool_point_mm": [tool.x, tool.y, tool.z],
        // The covariance scaled by √(χ²/dof) where the misfit rejected the
        // stated σ (1 where it did not).
        "covariance_scale": predicted.scale,
    });
    for (q, [median, p95]) in &a.worst {
        accuracy[format!("{}_{}", q.name, q.unit)] =
            serde_json::json!({"median": median, "p95": p95});
    }
    let unit = sigma_unit(m);
    let v = serde_json::json!({
        "mechanism": m.name(),
        "config": cfg.source(),
        "nominal": crate::store::nominal::to_json(&m.nominal()),
        "poses": poses,
        "log_rows": rows,
        "readings_per_pose": m.reading_facts().len(),
        "rank_after_convention": rank,
        "free_after_convention": free,
        "convention": m.convention(),
        "iterations": id.iterations,
        format!("sigma_{}", unit.0): id.sigma * unit.1,
        "sigma_from": if stated_sigma { cfg.reading_sigma().1 } else { "residuals" },
        format!("residual_rms_{}", unit.0): id.residual_rms * unit.1,
        "checks": {
            "misfit": misfit,
            "held_out": held,
            "predicted_accuracy": accuracy,
        },
        "correlations": {
            "names": kept.iter().map(|&j| names[j].clone()).collect::<Vec<_>>(),
            "matrix": matrix,
        },
    });
    serde_json::to_string_pretty(&v)
        .map(|t| t + "\n")
        .map_err(|e| Error::Argument(format!("json: {e}")))
}

/// The misfit test of a fit against the readings' stated σ: χ² of the
/// residuals on m − p degrees of freedom; None where the σ is the
/// residuals' own (nothing to test).
pub struct Misfit {
    pub chi2: f64,
    pub dof: usize,
    pub p: f64,
}

impl Misfit {
    /// Passed unless the readings fit worse than their σ allows 1 in 1,000
    /// times by chance.
    pub fn passed(&self) -> bool {
        self.p.is_finite() && self.p >= 1e-3
    }
}

pub fn misfit<C: MechanismConfig>(
    cfg: &C,
    id: &crate::identify::general::Identified,
    poses: usize,
    stated_sigma: bool,
) -> Option<Misfit> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if !stated_sigma || id.dof == 0 || id.sigma <= 0.0 {
        return None;
    }
    let m = poses * cfg.machine().reading_facts().len();
    let chi2 = id.residual_rms.powi(2) * m as f64 / id.sigma.powi(2);
    let p = ChiSquared::new(id.dof as f64)
        .map(|c| c.sf(chi2))
        .unwrap_or(f64::NAN);
    Some(Misfit {
        chi2,
        dof: id.dof,
        p,
    })
}

/// The unit σ₀ (the first reading's σ) is stated in: its name in files,
/// how many of it a file unit is, and its symbol on the console (arcsec,
/// 3600, ″ for an angle; um, 1000, µm for a length).
pub fn sigma_unit(m: &impl Mechanism) -> (&'static str, f64, &'static str) {
    match m.reading_facts().first().map(|f| f.quantity) {
        Some(Quantity::Length) => ("um", 1e3, " µm"),
        _ => ("arcsec", 3600.0, "″"),
    }
}

/// identify's predicted accuracy and the scale its covariance took, and
/// its held-out check (with the CSV line of the worst pose).
pub struct Predicted {
    pub accuracy: crate::identify::general::PredictedAccuracy,
    pub scale: f64,
    pub held_out: Option<(crate::identify::general::HeldOut, u64)>,
}

/// Held-out RMS above which identify warns and compensate and export
/// refuse (the Tricept's limit).
pub const HELD_OUT_LIMIT: f64 = crate::store::inputs::HELD_OUT_LIMIT;

/// identify's identifiability.json beside identified.csv, when it is
/// there and reads as JSON: (its path, its value).
pub fn fit_beside(identified: &Path) -> Option<(String, serde_json::Value)> {
    let beside = identified
        .parent()
        .unwrap_or(Path::new("."))
        .join(crate::store::names::IDENTIFIABILITY_JSON);
    let (file, bytes) = io::read_bytes(&beside).ok()?;
    Some((file, serde_json::from_slice(&bytes).ok()?))
}

/// Refuse identified.csv where identify's identifiability.json beside it
/// records another nominal machine than `cfg`'s
/// ([`crate::store::nominal::check_beside`]); a note where it records none.
pub fn check_nominal<C: MechanismConfig>(cfg: &C, identified: &Path) -> Result<()> {
    let here = cfg.machine().nominal();
    if let Some(note) = crate::store::nominal::check_beside(identified, &here, cfg.source())? {
        console::note(note);
    }
    Ok(())
}

/// Refuse a fit whose misfit check failed (identify's identifiability.json
/// beside identified.csv), unless the user accepts it.
pub fn gate_rejected_fit(identified: &Path, accept: bool) -> Result<()> {
    let Some((_, fit)) = fit_beside(identified) else {
        return Ok(());
    };
    let checks = &fit["checks"];
    // σ₀ and the residual RMS in the unit identify stated them in.
    let (unit, symbol) = if fit.get("sigma_um").is_some() {
        ("um", " µm")
    } else {
        ("arcsec", "″")
    };
    let (check, why) =
        if checks["misfit"]["passed"] == false {
            (
                "misfit",
                format!(
                "the readings' residual RMS {:.3}{symbol} against a stated σ of {:.3}{symbol}, {}",
                fit[format!("residual_rms_{unit}")].as_f64().unwrap_or(f64::NAN),
                fit[format!("sigma_{unit}")].as_f64().unwrap_or(f64::NAN),
                // Below a double's range the p-value reads 0.
                match checks["misfit"]["p_value"].as_f64() {
                    Some(p) if p >= 1e-99 => format!("p = {p:.1e}"),
                    _ => "p < 1e-99".to_string(),
                }
            ),
            )
        } else if checks["held_out"]["passed"] == false {
            (
                "held-out",
                format!(
                    "poses left out predicted {:.2} times worse than the readings' σ allows",
                    checks["held_out"]["rms_z"].as_f64().unwrap_or(f64::NAN)
                ),
            )
        } else {
            return Ok(());
        };
    if accept {
        console::note(format!(
            "warning: applying a fit its own checks rejected ({why}), as --accept-rejected-fit asks"
        ));
        return Ok(());
    }
    Err(Error::csv(
        identified.display().to_string(),
        format!("identify's {check} check rejected this fit ({why}): the readings do not fit the machine as well as their stated noise allows; find the cause and identify again, or pass --accept-rejected-fit to use it anyway"),
    ))
}
