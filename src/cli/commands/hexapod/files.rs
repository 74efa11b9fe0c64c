//! The hexapod's files: the readings log, identified.csv and the
//! identifiability.json identify writes beside it, and a targets CSV.

use crate::calibration::readings_check::{self, what_to_check};
use crate::cli::console;
use crate::config::hexapod::{HexapodConfig, MAX_POSES};
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::hexapod::convention::{self, CONVENTION};
use crate::mechanism::hexapod::{
    error_names, is_angle, Errors, Pose, N_ERRORS, PLAUSIBLE_DEG, SLIP_DEG,
};
use crate::mechanism::ReadingFact;
use std::path::Path;

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

/// The readings' header: the target pose, then each instrumented angle.
pub fn header(cfg: &HexapodConfig) -> Vec<String> {
    let mut h: Vec<String> = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    h.extend(
        cfg.hexapod
            .reading_facts()
            .iter()
            .map(|f| f.column.to_string()),
    );
    h
}

/// A hexapod log: each row's target pose and readings, read as identify
/// and verify read it (at most `MAX_POSES` rows, counted before any work).
pub struct Log {
    pub file: String,
    /// Each row's line in the file.
    pub lines: Vec<u64>,
    pub targets: Vec<Pose>,
    /// The readings, row after row (`readings_per_pose` a row).
    pub readings: Vec<f64>,
}

/// Read the log at `path` for `verb` (the command, for messages). A
/// reading far from what the nominal machine reads at its pose is not a
/// calibration's error (a wrapped angle, a column swapped, another
/// machine's log): refused here, naming its line and column.
pub fn read_log(cfg: &HexapodConfig, path: &Path, verb: &str) -> Result<Log> {
    let (file, bytes) = io::read_bytes(path)?;
    let head = header(cfg);
    let cols: Vec<&str> = head.iter().map(String::as_str).collect();
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let most = MAX_POSES;
    if table.rows.len() > most {
        return Err(Error::csv(
            &file,
            format!(
                "has {} poses; {verb} reads at most {most} (a dense design of {} rows each): split the log",
                table.rows.len(),
                cfg.hexapod.readings_per_pose()
            ),
        ));
    }
    let zero = [0.0; N_ERRORS];
    // A row's slip is named from these (each reading's plausible distance
    // the slip's tolerance): the refusal itself is at PLAUSIBLE_DEG.
    let facts: Vec<ReadingFact> = cfg
        .hexapod
        .reading_facts()
        .into_iter()
        .map(|f| ReadingFact {
            plausible: SLIP_DEG,
            ..f
        })
        .collect();
    let mut log = Log {
        file: file.clone(),
        lines: Vec::with_capacity(table.rows.len()),
        targets: Vec::with_capacity(table.rows.len()),
        readings: Vec::with_capacity(table.rows.len() * cfg.hexapod.readings_per_pose()),
    };
    for (line, cells) in &table.rows {
        let mut v = Vec::with_capacity(cells.len());
        for (c, cell) in cols.iter().zip(cells) {
            v.push(io::number(&file, *line, c, cell)?);
        }
        let target = pose_of(&file, *line, &v[..6])?;
        let nominal = cfg
            .hexapod
            .readings(&zero, &target)
            .map_err(|why| Error::csv(&file, format!("line {line}: the target pose {why}")))?;
        let read = &v[6..];
        if let Some(k) = (0..read.len()).find(|&k| (read[k] - nominal[k]).abs() > PLAUSIBLE_DEG) {
            let (r, n) = (read[k], nominal[k]);
            return Err(Error::csv(
                &file,
                format!(
                    "line {line}: {} = {r}° is {:.3}° from what the nominal machine reads at that pose ({n:.4}°); a calibration moves a reading by well under {PLAUSIBLE_DEG}°: {}",
                    cols[6 + k],
                    r - n,
                    slip(&facts, read, &nominal)
                ),
            ));
        }
        log.lines.push(*line);
        log.targets.push(target);
        log.readings.extend_from_slice(&v[6..]);
    }
    Ok(log)
}

/// A row's [x, y, z, a, b, c] as a pose; angles beyond ±90° refused.
fn pose_of(file: &str, line: u64, x: &[f64]) -> Result<Pose> {
    if x[3..6].iter().any(|a| a.abs() > 90.0) {
        return Err(Error::csv(
            file,
            format!("line {line}: the pose's angles must be within ±90°"),
        ));
    }
    Ok(Pose::from_xyzabc(&[x[0], x[1], x[2], x[3], x[4], x[5]]))
}

/// identified.csv: one row per error the machine has; lengths in
/// `estimate_mm` and `std_uncertainty_mm`, the encoders' zeros in
/// `estimate_deg` and `std_uncertainty_deg`; `source` says what the
/// convention did with it, or that it was fixed or is the prior's.
pub fn identified_csv(cfg: &HexapodConfig, id: &crate::identify::general::Identified) -> String {
    let names = error_names();
    let sd = id.std();
    let mut s = String::from(
        "parameter,estimate_mm,std_uncertainty_mm,estimate_deg,std_uncertainty_deg,source\n",
    );
    for j in cfg.hexapod.error_indices() {
        let v = if id.errors[j] == 0.0 {
            0.0
        } else {
            id.errors[j]
        };
        let cells = format!("{v},{}", sd[j]);
        let (mm, deg) = if is_angle(j) {
            (",".to_string(), cells)
        } else {
            (cells, ",".to_string())
        };
        // A source with a comma ("in the plane of p1, p2, p3") is quoted.
        // Held: "fixed"; a single error the prior outweighs the readings on
        // (posterior σ above σp/√2): "prior".
        let source = match convention::source(j) {
            _ if id.fixed.contains(&j) => "fixed",
            "identified"
                if cfg
                    .holds
                    .prior_std(&cfg.hexapod, j)
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
/// per error this machine has, each once, lengths in `estimate_mm` and the
/// encoders' zeros in `estimate_deg`.
pub fn read_identified(cfg: &HexapodConfig, path: &Path) -> Result<Errors> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["parameter", "estimate_mm", "estimate_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &["source"])?;
    let names = error_names();
    let present = cfg.hexapod.error_indices();
    let mut e = [0.0; N_ERRORS];
    let mut seen = [false; N_ERRORS];
    for (line, cells) in &table.rows {
        let name = cells[0].as_str();
        let Some(j) = names
            .iter()
            .position(|n| n == name)
            .filter(|j| present.contains(j))
        else {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} is not an error of this hexapod (dbx1 … dpsi6, as hexapod.encoders reads)"),
            ));
        };
        if seen[j] {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} is listed twice"),
            ));
        }
        seen[j] = true;
        let (col, cell) = if is_angle(j) {
            ("estimate_deg", &cells[2])
        } else {
            ("estimate_mm", &cells[1])
        };
        let v = io::number(&file, *line, col, cell)?;
        let cap = if is_angle(j) { 5.0 } else { 10.0 };
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

/// Each error's standard uncertainty from identified.csv (0 where absent).
pub fn read_std(path: &Path) -> Result<Errors> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["parameter", "std_uncertainty_mm", "std_uncertainty_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let names = error_names();
    let mut sd = [0.0; N_ERRORS];
    for (line, cells) in &table.rows {
        if let Some(j) = names.iter().position(|n| *n == cells[0]) {
            let (col, cell) = if is_angle(j) {
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

/// A targets CSV: x_mm,y_mm,z_mm,a_deg,b_deg,c_deg per row, each within
/// the machine's limits (`hexapod.stroke_mm`, `hexapod.joint_angle_deg`).
pub fn read_targets(path: &Path, cfg: &HexapodConfig) -> Result<(Vec<[f64; 6]>, Vec<Pose>)> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
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
        let mut x = [0.0; 6];
        for (k, (c, cell)) in cols.iter().zip(cells).enumerate() {
            x[k] = io::number(&file, *line, c, cell)?;
        }
        let p = pose_of(&file, *line, &x)?;
        cfg.limits
            .check(&cfg.hexapod, &p)
            .map_err(|why| Error::csv(&file, format!("line {line}: the target {why}")))?;
        poses.push(p);
        list.push(x);
    }
    Ok((list, poses))
}

/// identify's identifiability.json for the hexapod: the rank, the
/// convention, the readings' σ and the misfit check, and the free errors'
/// correlations.
pub fn fit_json(
    cfg: &HexapodConfig,
    id: &crate::identify::general::Identified,
    poses: usize,
    (rank, free): (usize, usize),
    stated_sigma: bool,
    predicted: &Predicted,
) -> Result<String> {
    let names = error_names();
    let sd = id.std();
    let kept: Vec<usize> = (0..N_ERRORS).filter(|&j| sd[j] > 0.0).collect();
    let matrix: Vec<Vec<f64>> = kept
        .iter()
        .map(|&a| {
            kept.iter()
                .map(|&b| id.covariance[(a, b)] / (sd[a] * sd[b]))
                .collect()
        })
        .collect();
    let misfit = match misfit(cfg, id, poses, stated_sigma) {
        Some(m) => serde_json::json!({
            "chi2": m.chi2,
            "dof": m.dof,
            "p_value": if m.p.is_finite() { serde_json::json!(m.p) } else { serde_json::Value::Null },
            // The readings fit worse than their stated σ allows (1 in
            // 1,000 by chance): a model or sensor error beyond the noise.
            "passed": m.passed(),
        }),
        None => serde_json::json!("not tested: σ taken from the residuals (state sensors.encoder_noise_arcsec to test the fit)"),
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
            // encoders allow: the model does not carry over.
            "passed": h.rms_z <= HELD_OUT_LIMIT,
        }),
        None => serde_json::json!(format!(
            "not tested: it needs {} poses or more",
            2 * crate::identify::general::HELD_OUT_FOLDS
        )),
    };
    let a = &predicted.accuracy;
    let v = serde_json::json!({
        "mechanism": "hexapod",
        "poses": poses,
        "readings_per_pose": cfg.hexapod.readings_per_pose(),
        "rank_after_convention": rank,
        "free_after_convention": free,
        "convention": CONVENTION,
        "iterations": id.iterations,
        "sigma_arcsec": id.sigma * 3600.0,
        "sigma_from": if stated_sigma { "sensors.encoder_noise_arcsec" } else { "residuals" },
        "residual_rms_arcsec": id.residual_rms * 3600.0,
        "checks": {
            "misfit": misfit,
            "held_out": held,
            "predicted_accuracy": {
                "draws": a.draws,
                "workspace_poses": a.poses,
                "tool_point_mm": [cfg.tool_mm.x, cfg.tool_mm.y, cfg.tool_mm.z],
                "position_mm": {"median": a.worst[0].1[0], "p95": a.worst[0].1[1]},
                "orientation_arcsec": {"median": a.worst[1].1[0], "p95": a.worst[1].1[1]},
                // The covariance scaled by √(χ²/dof) where the misfit
                // rejected the stated σ (1 where it did not).
                "covariance_scale": predicted.scale,
            },
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

pub fn misfit(
    cfg: &HexapodConfig,
    id: &crate::identify::general::Identified,
    poses: usize,
    stated_sigma: bool,
) -> Option<Misfit> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if !stated_sigma || id.dof == 0 || id.sigma <= 0.0 {
        return None;
    }
    let m = poses * cfg.hexapod.readings_per_pose();
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

/// Refuse a fit whose misfit check failed (identify's identifiability.json
/// beside identified.csv), unless the user accepts it.
pub fn gate_rejected_fit(identified: &Path, accept: bool) -> Result<()> {
    let Some((_, fit)) = fit_beside(identified) else {
        return Ok(());
    };
    let checks = &fit["checks"];
    let (check, why) = if checks["misfit"]["passed"] == false {
        (
            "misfit",
            format!(
                "the readings' residual RMS {:.3}″ against a stated σ of {:.3}″, p = {:.2e}",
                fit["residual_rms_arcsec"].as_f64().unwrap_or(f64::NAN),
                fit["sigma_arcsec"].as_f64().unwrap_or(f64::NAN),
                checks["misfit"]["p_value"].as_f64().unwrap_or(0.0)
            ),
        )
    } else if checks["held_out"]["passed"] == false {
        (
            "held-out",
            format!(
                "poses left out predicted {:.2} times worse than the encoders allow",
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
