//! The CSV inputs of `identify` and `compensate`: readings, identified
//! parameters, targets. Their errors name the file and the line.

use crate::error::{Error, Result};
use crate::io::{for_each_row, number, read_bytes, read_table};
use crate::mechanism::{AxisAngles, Homed, LogRow, Unknowns};
use nalgebra::{SVector, Vector3};
use std::path::Path;

/// Columns of a target: where the tool centre is commanded.
pub const TARGET_COLUMNS: [&str; 3] = ["x_mm", "y_mm", "z_mm"];

/// Columns of a readings file: the target's, then the mechanism's readings
/// ([`LogRow::FACTS`]).
pub fn readings_columns<L: LogRow<R>, const R: usize>() -> Vec<&'static str> {
    TARGET_COLUMNS
        .iter()
        .copied()
        .chain(L::FACTS.iter().map(|r| r.column))
        .collect()
}

/// Read a readings file (first row = reference pose) of a mechanism whose
/// log rows are `L`.
/// Each row comes with its line in the file.
pub fn read_readings<L: LogRow<R>, const R: usize>(path: &Path) -> Result<(Vec<L>, Vec<u64>)> {
    let (file, bytes) = read_bytes(path)?;
    parse_readings(&file, &bytes)
}

/// Parse the bytes of a readings file named `file` (for messages).
pub fn parse_readings<L: LogRow<R>, const R: usize>(
    file: &str,
    bytes: &[u8],
) -> Result<(Vec<L>, Vec<u64>)> {
    let columns = readings_columns::<L, R>();
    // Row by row: a long log never exists as a table of its cells.
    let mut out = Vec::new();
    let mut lines = Vec::new();
    for_each_row(file, bytes, &columns, &[], |line, cells| {
        lines.push(line);
        let mut target = [0.0; 3];
        for (k, x) in target.iter_mut().enumerate() {
            *x = number(file, line, columns[k], cells[k])?;
        }
        let mut values = [0.0; R];
        for (k, x) in values.iter_mut().enumerate() {
            *x = number(file, line, columns[3 + k], cells[3 + k])?;
        }
        out.push(L::from_file(Vector3::from(target), values));
        Ok(())
    })?;
    if out.len() < 2 {
        return Err(Error::csv(
            file,
            "needs at least 2 rows (the reference pose and one more)",
        ));
    }
    Ok((out, lines))
}

/// The bound on an identified error, mm: beyond it a value in
/// identified.csv is no geometric error of a machine, and the file is to
/// blame.
pub const MAX_IDENTIFIED_MM: f64 = 10.0;

/// The bound on identified.csv's estimates for a machine whose smaller
/// circumradius is `size_mm`: [`MAX_IDENTIFIED_MM`], or a tenth of
/// `size_mm` when that is larger (a config's `[errors]` may go that far, and
/// what a simulation of them identifies must be read back).
pub fn identified_bound_mm(size_mm: f64) -> f64 {
    MAX_IDENTIFIED_MM.max(0.1 * size_mm)
}

/// The largest standard uncertainty of an identified error that
/// `compensate` accepts, mm.
pub const MAX_USABLE_UNCERTAINTY_MM: f64 = 1.0;

/// The largest standard uncertainty of an identified Hooke-axis angle that
/// `compensate` accepts, degrees: beyond it the readings do not determine
/// the angle (an angle's own effect on position is small; what its
/// uncertainty costs shows in the 15 errors', held to ±1 mm).
pub const MAX_USABLE_UNCERTAINTY_DEG: f64 = 0.1;

/// The largest Hooke-axis angle identified.csv may hold, degrees (as
/// `[second_class]` allows).
pub const MAX_IDENTIFIED_DEG: f64 = 5.0;

/// An identified model as `identify` writes it: a mechanism's P errors,
/// which of them the readings identified, and its A second-class angles
/// when they were identified too (the Tricept's Hooke axes,
/// `[identification] second_class = true`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifiedModel<const P: usize, const A: usize> {
    pub errors: SVector<f64, P>,
    pub identifiable: [bool; P],
    /// Each error's standard uncertainty, mm (NaN where the file states
    /// none).
    pub std_mm: [f64; P],
    /// The angles, degrees.
    pub angles: Option<SVector<f64, A>>,
    /// Where each value came from, as identified.csv says ([`SOURCES`];
    /// where the file has no `source`, "readings" or "unidentifiable").
    pub source: [&'static str; P],
}

impl<const P: usize, const A: usize> IdentifiedModel<P, A> {
    /// The identified machine on `homed`'s layout: its errors, and its
    /// second-class axes turned when the model has angles.
    pub fn machine<T: AxisAngles<P, R, A>, const R: usize>(
        &self,
        homed: &Homed<T, P, R>,
    ) -> T::Machine {
        let m = T::machine(homed.layout(), &self.errors);
        match &self.angles {
            Some(a) => T::with_angles(&m, a),
            None => m,
        }
    }
}

/// Did identify's checks reject the fit in `identified` (an identified.csv)?
/// Read from the identifiability.json identify wrote beside it: the misfit
/// test rejected at 1 %, or poses left out predicted more than twice worse
/// than the sensors allow. Some(the check, in words); None when they did
/// not, or when there is no such file beside it (a model from elsewhere).
pub fn rejected_fit(identified: &Path) -> Option<String> {
    let json = checks_beside(identified)?;
    let meta = std::fs::symlink_metadata(&json).ok()?;
    // A report, never a special file: at most a few MB are read.
    if !meta.is_file() || meta.len() > 64 << 20 {
        return None;
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).ok()?).ok()?;
    let checks = v.get("checks")?;
    let misfit = checks.get("misfit");
    let held = checks.get("held_out");
    let num =
        |o: Option<&serde_json::Value>, k: &str| o.and_then(|x| x.get(k)).and_then(|x| x.as_f64());
    if misfit
        .and_then(|m| m.get("rejected"))
        .and_then(|r| r.as_bool())
        == Some(true)
    {
        let p = match num(misfit, "p_value") {
            Some(p) if p >= 1e-99 => format!("p = {p:.1e}"),
            _ => "p < 1e-99".to_string(),
        };
        return Some(format!(
            "the misfit test: the residual is {:.2} × what the declared sensors explain, {p}, in {}",
            num(misfit, "ratio").unwrap_or(f64::NAN),
            json.display()
        ));
    }
    match num(held, "rms_z") {
        Some(z) if z > HELD_OUT_LIMIT => Some(format!(
            "the held-out check: poses left out are predicted {z:.2} × worse than the sensors allow, in {}",
            json.display()
        )),
        _ => None,
    }
}

/// The identifiability.json identify wrote beside an identified.csv (None
/// for stdin, or when there is none).
pub fn checks_beside(identified: &Path) -> Option<std::path::PathBuf> {
    if identified.as_os_str() == "-" {
        return None;
    }
    let json = identified.with_file_name(super::names::IDENTIFIABILITY_JSON);
    json.is_file().then_some(json)
}

/// Held-out RMS above which identify warns and compensate refuses.
pub const HELD_OUT_LIMIT: f64 = 2.0;

/// Read `identified.csv` of a mechanism whose unknowns are `names`: every
/// one of its errors, once, and its second-class angles all or none.
/// Estimates larger than `max_abs_mm` are refused naming their line.
pub fn read_identified<const P: usize, const A: usize>(
    path: &Path,
    max_abs_mm: f64,
    names: &Unknowns<P, A>,
) -> Result<IdentifiedModel<P, A>> {
    let (file, bytes) = read_bytes(path)?;
    parse_identified(&file, &bytes, max_abs_mm, names)
}

/// Parse the bytes of an `identified.csv`.
pub fn parse_identified<const P: usize, const A: usize>(
    file: &str,
    bytes: &[u8],
    max_abs_mm: f64,
    names: &Unknowns<P, A>,
) -> Result<IdentifiedModel<P, A>> {
    let (t, present) = read_table(
        file,
        bytes,
        &["parameter", "estimate_mm"],
        &[
            "identifiable",
            "std_uncertainty_mm",
            "estimate_deg",
            "std_uncertainty_deg",
            "source",
        ],
    )?;
    let mut source = [""; P];
    let mut values = SVector::<f64, P>::zeros();
    let mut ident = [true; P];
    let mut std_mm = [f64::NAN; P];
    let mut seen = [false; P];
    let mut angles = SVector::<f64, A>::zeros();
    let mut angle_seen = [false; A];
    for (line, cells) in &t.rows {
        let name = cells[0].as_str();
        let identifiable = if present[0] {
            match cells[2].to_ascii_lowercase().as_str() {
                "true" | "1" => true,
                "false" | "0" => false,
                other => {
                    return Err(Error::csv(
                        &t.file,
                        format!(
                            "line {line}: identifiable must be true or false (got \"{other}\")"
                        ),
                    ))
                }
            }
        } else {
            true
        };
        if let Some(a) = names.angles.iter().position(|n| *n == name) {
            if angle_seen[a] {
                return Err(Error::csv(
                    &t.file,
                    format!("line {line}: {name} is listed twice"),
                ));
            }
            angle_seen[a] = true;
            if !present[2] || cells[4].is_empty() {
                return Err(Error::csv(
                    &t.file,
                    format!("line {line}: {name} is an angle: its value belongs in an estimate_deg column (identify writes one when [identification] second_class = true)"),
                ));
            }
            if !cells[1].is_empty() {
                return Err(Error::csv(
                    &t.file,
                    format!("line {line}: {name} is an angle, but its estimate_mm cell holds \"{}\": an angle's value belongs in estimate_deg alone (leave estimate_mm empty, as identify writes it)", cells[1]),
                ));
            }
            let v = number(&t.file, *line, "estimate_deg", &cells[4])?;
            if v.abs() > MAX_IDENTIFIED_DEG {
                return Err(Error::csv(
                    &t.file,
                    format!("line {line}: {name} estimate_deg = {v} is not a {} (beyond {MAX_IDENTIFIED_DEG}°); is this identify's identified.csv?", names.angle_is),
                ));
            }
            if present[3] && !cells[5].is_empty() {
                let sd = number(&t.file, *line, "std_uncertainty_deg", &cells[5])?;
                if sd < 0.0 {
                    return Err(Error::csv(
                        &t.file,
                        format!("line {line}: {name} std_uncertainty_deg = {sd} is not a standard uncertainty (it must be 0 or more)"),
                    ));
                }
                if sd > MAX_USABLE_UNCERTAINTY_DEG {
                    return Err(Error::csv(
                        &t.file,
                        format!("line {line}: {name} std_uncertainty_deg = {sd} says the readings do not determine it to ±{MAX_USABLE_UNCERTAINTY_DEG}°: this calibration is not usable for compensation (identify from more poses spread over the workspace, or without second_class)"),
                    ));
                }
            }
            angles[a] = if identifiable { v } else { 0.0 };
            continue;
        }
        let Some(k) = names.errors.iter().position(|n| *n == name) else {
            return Err(Error::csv(
                &t.file,
                format!(
                    "line {line}: \"{name}\" is not one of the {P} error names ({}) or {} ({})",
                    names.errors.join(", "),
                    names.angles_are,
                    names.angles.join(", ")
                ),
            ));
        };
        if seen[k] {
            return Err(Error::csv(
                &t.file,
                format!("line {line}: {name} is listed twice"),
            ));
        }
        seen[k] = true;
        if present[4] && !cells[6].is_empty() {
            let Some(word) = SOURCES.iter().find(|w| **w == cells[6]) else {
                return Err(Error::csv(
                    &t.file,
                    format!(
                        "line {line}: {name} source \"{}\" is not one of identify's ({})",
                        cells[6],
                        SOURCES.join(", ")
                    ),
                ));
            };
            source[k] = word;
        }
        values[k] = number(&t.file, *line, "estimate_mm", &cells[1])?;
        // Beyond the bound it is no geometric error of the machine: the
        // file is to blame.
        if values[k].abs() > max_abs_mm {
            return Err(Error::csv(
                &t.file,
                format!(
                    "line {line}: {name} estimate_mm = {} is not a geometric error of this machine (beyond {max_abs_mm} mm, the largest this tool accepts: 10 mm, or a tenth of the machine's smaller circumradius when that is larger); is this identify's identified.csv?",
                    if values[k].abs() >= 1e9 { format!("{:e}", values[k]) } else { values[k].to_string() }
                ),
            ));
        }
        // The readings' own uncertainty: a correction known to worse than
        // ±1 mm is not one to load into a controller.
        if present[1] && !cells[3].is_empty() {
            let sd = number(&t.file, *line, "std_uncertainty_mm", &cells[3])?;
            if sd < 0.0 {
                return Err(Error::csv(
                    &t.file,
                    format!("line {line}: {name} std_uncertainty_mm = {sd} is not a standard uncertainty (it must be 0 or more)"),
                ));
            }
            if sd > MAX_USABLE_UNCERTAINTY_MM {
                return Err(Error::csv(
                    &t.file,
                    format!(
                        "line {line}: {name} std_uncertainty_mm = {sd} says the readings do not determine it to ±{MAX_USABLE_UNCERTAINTY_MM} mm: this calibration is not usable for compensation (identify from more poses, or fix what its misfit warning names)"
                    ),
                ));
            }
            std_mm[k] = sd;
        }
        ident[k] = identifiable;
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        return Err(Error::csv(
            &t.file,
            format!(
                "parameter {} is missing (all {P} are needed)",
                names.errors[k]
            ),
        ));
    }
    let angles = match angle_seen.iter().filter(|&&s| s).count() {
        0 => None,
        n if n == A => Some(angles),
        _ => {
            let missing = angle_seen.iter().position(|s| !s).expect("one is missing");
            return Err(Error::csv(
                &t.file,
                format!(
                    "parameter {} is missing ({} are identified together: {})",
                    names.angles[missing],
                    names.angles_are,
                    names.angles.join(", ")
                ),
            ));
        }
    };
    for k in 0..P {
        if !ident[k] {
            values[k] = 0.0;
        }
    }
    // Unstated: the words identify would write.
    for k in 0..P {
        if source[k].is_empty() {
            source[k] = if ident[k] {
                "readings"
            } else {
                "unidentifiable"
            };
        }
    }
    Ok(IdentifiedModel {
        errors: values,
        identifiable: ident,
        std_mm,
        angles,
        source,
    })
}

/// The words identified.csv's `source` column holds.
pub const SOURCES: [&str; 4] = ["readings", "fixed", "prior", "unidentifiable"];

/// The estimate's covariance identify wrote into the identifiability.json
/// beside `identified` (an identified.csv): the unknowns' names and the
/// matrix (mm², degrees for the Hooke axes' angles). None when there is no
/// such file or it holds none.
pub fn read_covariance(identified: &Path) -> Option<(Vec<String>, nalgebra::DMatrix<f64>)> {
    let json = checks_beside(identified)?;
    let meta = std::fs::symlink_metadata(&json).ok()?;
    if !meta.is_file() || meta.len() > 64 << 20 {
        return None;
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).ok()?).ok()?;
    let c = v.get("covariance")?;
    let names: Vec<String> = c
        .get("unknowns")?
        .as_array()?
        .iter()
        .map(|n| n.as_str().map(str::to_string))
        .collect::<Option<_>>()?;
    let rows = c.get("matrix")?.as_array()?;
    let n = names.len();
    if rows.len() != n {
        return None;
    }
    let mut m = nalgebra::DMatrix::zeros(n, n);
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array()?;
        if row.len() != n {
            return None;
        }
        for (j, x) in row.iter().enumerate() {
            m[(i, j)] = x.as_f64().filter(|x| x.is_finite())?;
        }
    }
    Some((names, m))
}

/// Columns of a reference file: a target and where an external instrument
/// measured the tool when commanded to it.
pub const REFERENCE_COLUMNS: [&str; 6] = [
    "x_mm",
    "y_mm",
    "z_mm",
    "measured_x_mm",
    "measured_y_mm",
    "measured_z_mm",
];

/// A reference point: the target commanded, and where an external
/// instrument measured the tool (mm).
pub type ReferencePoint = (Vector3<f64>, Vector3<f64>);

/// Read a reference file (`verify --reference`): (target, measured
/// absolute position) per row, and each row's line in the file.
pub fn read_reference(path: &Path) -> Result<(Vec<ReferencePoint>, Vec<u64>)> {
    let (file, bytes) = read_bytes(path)?;
    let cols = REFERENCE_COLUMNS;
    let (t, _) = read_table(&file, &bytes, &cols, &[])?;
    let mut out = Vec::with_capacity(t.rows.len());
    let lines = t.rows.iter().map(|(line, _)| *line).collect();
    for (line, cells) in &t.rows {
        let v: Vec<f64> = (0..6)
            .map(|c| number(&t.file, *line, cols[c], &cells[c]))
            .collect::<Result<_>>()?;
        out.push((
            Vector3::new(v[0], v[1], v[2]),
            Vector3::new(v[3], v[4], v[5]),
        ));
    }
    if out.is_empty() {
        return Err(Error::csv(
            &file,
            "holds no reference point (a header, then one row per externally measured point)",
        ));
    }
    Ok((out, lines))
}

/// Read a targets file (`x_mm,y_mm,z_mm`), each row's line in the file
/// beside it.
pub fn read_targets(path: &Path) -> Result<(Vec<Vector3<f64>>, Vec<u64>)> {
    let (file, bytes) = read_bytes(path)?;
    parse_targets(&file, &bytes)
}

/// Parse the bytes of a targets file.
pub fn parse_targets(file: &str, bytes: &[u8]) -> Result<(Vec<Vector3<f64>>, Vec<u64>)> {
    let cols = TARGET_COLUMNS;
    let (t, _) = read_table(file, bytes, &cols, &[])?;
    let mut out = Vec::with_capacity(t.rows.len());
    let lines = t.rows.iter().map(|(line, _)| *line).collect();
    for (line, cells) in &t.rows {
        let x = number(&t.file, *line, cols[0], &cells[0])?;
        let y = number(&t.file, *line, cols[1], &cells[1])?;
        let z = number(&t.file, *line, cols[2], &cells[2])?;
        out.push(Vector3::new(x, y, z));
    }
    Ok((out, lines))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::second_class::UNKNOWNS;
    use crate::mechanism::tricept::PARAM_NAMES;

    /// An identified.csv whose dq1 estimate is `dq1` mm (the rest 0).
    fn identified(dq1: &str) -> String {
        let mut text = String::from("parameter,estimate_mm\n");
        for name in PARAM_NAMES {
            let v = if name == "dq1" { dq1 } else { "0" };
            text.push_str(&format!("{name},{v}\n"));
        }
        text
    }

    #[test]
    fn the_bound_is_10_mm_unless_a_config_may_declare_more() {
        // The paper's machine (smaller circumradius 100 mm) and smaller
        // ones: 10 mm. A machine whose [errors] may reach 25 mm: 25 mm.
        assert_eq!(identified_bound_mm(100.0), 10.0);
        assert_eq!(identified_bound_mm(40.0), 10.0);
        assert_eq!(identified_bound_mm(250.0), 25.0);
        let paper = identified_bound_mm(100.0);
        assert!(
            parse_identified("id.csv", identified("10.0").as_bytes(), paper, &UNKNOWNS).is_ok()
        );
        assert!(
            parse_identified("id.csv", identified("-10.0").as_bytes(), paper, &UNKNOWNS).is_ok()
        );
        let err = parse_identified("id.csv", identified("10.001").as_bytes(), paper, &UNKNOWNS)
            .unwrap_err();
        assert!(err.to_string().contains("beyond 10 mm"), "{err}");
        assert_eq!(err.exit_code(), 2);
    }

    /// identified.csv's source column is read in identify's words (and
    /// stated as identify would where the column is absent); another word
    /// is refused naming its line.
    #[test]
    fn the_source_column_is_identify_s_words() {
        let mut text = String::from("parameter,estimate_mm,identifiable,source\n");
        for (k, name) in PARAM_NAMES.iter().enumerate() {
            let (ident, word) = match k {
                0 => ("true", "fixed"),
                1 => ("true", "prior"),
                11 => ("false", "unidentifiable"),
                _ => ("true", "readings"),
            };
            text.push_str(&format!("{name},0.1,{ident},{word}\n"));
        }
        let m = parse_identified("id.csv", text.as_bytes(), 10.0, &UNKNOWNS).unwrap();
        assert_eq!(&m.source[..3], &["fixed", "prior", "readings"]);
        assert_eq!(m.source[11], "unidentifiable");
        let plain =
            parse_identified("id.csv", identified("1.0").as_bytes(), 10.0, &UNKNOWNS).unwrap();
        assert!(plain.source.iter().all(|s| *s == "readings"));
        let bad = text.replacen("fixed", "guessed", 1);
        let err = parse_identified("id.csv", bad.as_bytes(), 10.0, &UNKNOWNS).unwrap_err();
        assert!(
            err.to_string()
                .contains("line 2: dxB1 source \"guessed\" is not one of identify's"),
            "{err}"
        );
    }

    #[test]
    fn an_estimate_beyond_the_machines_bound_is_the_files_fault() {
        // 12 mm of leg offset is a large error, not an absurd one, for a
        // machine whose bound is 50 mm; beyond the bound it is refused with
        // its line, huge values in scientific notation.
        let e = parse_identified("id.csv", identified("12.0").as_bytes(), 50.0, &UNKNOWNS)
            .unwrap()
            .errors;
        assert_eq!(
            e[crate::mechanism::tricept::params::param_index("dq1").unwrap()],
            12.0
        );
        let err =
            parse_identified("id.csv", identified("12.0").as_bytes(), 10.0, &UNKNOWNS).unwrap_err();
        assert!(err.to_string().contains("dq1 estimate_mm = 12"), "{err}");
        assert!(err.to_string().contains("id.csv: line 14: "), "{err}");
        assert!(err.to_string().contains("beyond 10 mm"), "{err}");
        let err = parse_identified("id.csv", identified("1e300").as_bytes(), 50.0, &UNKNOWNS)
            .unwrap_err();
        let text = err.to_string();
        assert!(text.contains("id.csv") && text.contains("1e300"), "{text}");
        assert_eq!(err.exit_code(), 2);
    }
}
