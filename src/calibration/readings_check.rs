//! What a row of readings that no geometric error can explain looks like,
//! read from the readings' facts alone ([`ReadingFact`]: column, quantity,
//! plausible distance): two readings of one quantity swapped, a sign
//! flipped, a length in metres, angles in radians. Any topology's readings
//! get the same diagnosis; the mechanism's are two angles and a length.
//! [`check_readings`] refuses a log whose rows no machine near the nominal
//! one could have read, with that diagnosis.

use crate::error::{Error, Result};
use crate::io::Source;
use crate::mechanism::{Homed, Kinematic, LogRow, Quantity, ReadingFact};
use nalgebra::{SVector, Vector3};

/// The unit symbol after a value in a message: "°", " mm".
fn symbol(q: Quantity) -> &'static str {
    match q {
        Quantity::Angle => "°",
        Quantity::Length => " mm",
    }
}

fn near(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// Is every reading within its plausible distance of its nominal value?
pub fn plausible(facts: &[ReadingFact], d: &[f64]) -> bool {
    facts.iter().zip(d).all(|(f, x)| x.abs() <= f.plausible)
}

/// The likeliest slip that makes `read` (file units, homing offset
/// removed) differ from `nom`, the nominal joints at the row's target;
/// where none explains it, what to check.
pub fn cause(facts: &[ReadingFact], read: &[f64], nom: &[f64]) -> String {
    slip(facts, read, nom).unwrap_or_else(|| what_to_check(facts))
}

/// The slip of the log (two readings swapped, a sign flipped, a length in
/// metres, angles in radians) that explains `read` against `nom`, each to
/// its reading's plausible distance; None when none does.
pub fn slip(facts: &[ReadingFact], read: &[f64], nom: &[f64]) -> Option<String> {
    let n = facts.len();
    let tol = |k: usize| facts[k].plausible;
    let is = |k: usize, q: Quantity| facts[k].quantity == q;
    for i in 0..n {
        for j in i + 1..n {
            if facts[i].quantity == facts[j].quantity
                && near(read[i], nom[j], tol(i))
                && near(read[j], nom[i], tol(j))
                && !near(nom[i], nom[j], tol(i) + tol(j))
            {
                return Some(format!(
                    "{} and {} look swapped",
                    facts[i].column, facts[j].column
                ));
            }
        }
    }
    if let Some(k) = (0..n).find(|&k| nom[k].abs() > tol(k) && near(read[k], -nom[k], tol(k))) {
        return Some(format!("{}'s sign looks flipped", facts[k].column));
    }
    let within = |k: usize| near(read[k], nom[k], tol(k));
    let metres = (0..n).find(|&k| {
        is(k, Quantity::Length)
            && near(read[k], nom[k] / 1000.0, 0.05)
            && (0..n).filter(|&o| o != k).all(within)
    });
    if let Some(k) = metres {
        return Some(format!(
            "{} looks like metres (about a thousandth of the nominal length)",
            facts[k].column
        ));
    }
    let angles: Vec<usize> = (0..n).filter(|&k| is(k, Quantity::Angle)).collect();
    if !angles.is_empty()
        && angles.iter().any(|&k| !within(k))
        && angles
            .iter()
            .all(|&k| near(read[k], nom[k].to_radians(), 0.05))
    {
        return Some("the angles look like radians in the _deg columns".into());
    }
    None
}

/// What to check when no slip explains a row: the units the readings use,
/// the column order and the signs.
pub fn what_to_check(facts: &[ReadingFact]) -> String {
    let mut units: Vec<&str> = Vec::new();
    for f in facts {
        let u = match f.quantity {
            Quantity::Angle => "degrees",
            Quantity::Length => "mm",
        };
        if !units.contains(&u) {
            units.push(u);
        }
    }
    format!(
        "check the units ({}), the column order and the signs",
        units.join(", ")
    )
}

/// The sentence for a row whose readings `read` differ from `nom` by more
/// than any geometric error can (`offset_removed`: the reference row's
/// homing offset was taken off `read`).
pub fn describe(facts: &[ReadingFact], read: &[f64], nom: &[f64], offset_removed: bool) -> String {
    let list = |v: &mut dyn Iterator<Item = String>| v.collect::<Vec<_>>().join(", ");
    let readings = list(
        &mut facts
            .iter()
            .zip(read)
            .map(|(f, v)| format!("{} {v:.4}{}", f.ascii, symbol(f.quantity))),
    );
    let diffs = list(
        &mut facts
            .iter()
            .zip(read.iter().zip(nom))
            .map(|(f, (r, m))| format!("{:.3}{}", r - m, symbol(f.quantity))),
    );
    // Each bound once (the mechanism's two angles share theirs).
    let mut bounds: Vec<String> = Vec::new();
    for f in facts {
        let b = format!("{}{}", f.plausible, symbol(f.quantity));
        if !bounds.contains(&b) {
            bounds.push(b);
        }
    }
    format!(
        "the readings ({readings}{}) differ from the nominal joints at this target by {diffs} — more than any geometric error can ({}): {}",
        if offset_removed { ", less the reference row's homing offset" } else { "" },
        bounds.join(", "),
        cause(facts, read, nom)
    )
}

/// The sentence for a row whose readings `read` (file units) fit the
/// target `there` of data line `line`, not its own target `here`.
pub fn out_of_order(
    facts: &[ReadingFact],
    read: &[f64],
    here: &Vector3<f64>,
    line: usize,
    there: &Vector3<f64>,
) -> String {
    let readings: Vec<String> = facts
        .iter()
        .zip(read)
        .map(|(f, v)| format!("{} {v:.4}{}", f.ascii, symbol(f.quantity)))
        .collect();
    // To the µm, without trailing zeros ("141.421", "0", "650").
    let mm = |v: f64| {
        let t = format!("{v:.3}");
        let t = t.trim_end_matches('0').trim_end_matches('.');
        if t == "-0" {
            "0".to_string()
        } else {
            t.to_string()
        }
    };
    let at = |p: &Vector3<f64>| format!("({}, {}, {}) mm", mm(p.x), mm(p.y), mm(p.z));
    format!(
        "this row's readings ({}) fit the target of line {line} {}, not this row's {} — the readings must be in the order of their targets (was the controller's log sorted or pasted in another order?)",
        readings.join(", "),
        at(there),
        at(here)
    )
}

/// Refuse readings that cannot come from the machine at their targets, and
/// say what they look like (units, column order, sign). Rows are compared
/// relative to the reference row, as the observation uses them, so a
/// controller that logs a homing offset passes; when every other row is off,
/// the reference row is the one blamed. How far a reading may plausibly be
/// from its nominal value is the mechanism's fact
/// ([`ReadingFact::plausible`]); the diagnosis reads only the readings'
/// facts, in the files' units.
pub fn check_readings<T, L, const P: usize, const R: usize>(
    homed: &Homed<T, P, R>,
    readings: &[L],
    file: Source,
) -> Result<()>
where
    T: Kinematic<P, R>,
    L: LogRow<R>,
{
    let facts: &[ReadingFact] = L::FACTS;
    debug_assert_eq!(
        facts,
        T::READINGS,
        "the log's row reads the mechanism's readings"
    );
    let to_file = |x: &SVector<f64, R>| -> [f64; R] {
        std::array::from_fn(|k| facts[k].quantity.to_file(x[k]))
    };
    let mut rows = Vec::with_capacity(readings.len());
    for r in readings {
        let Ok((_, nominal)) = T::command(homed.nominal(), &r.target()) else {
            return Ok(()); // the targets' check reports it
        };
        rows.push((r.file_values(), to_file(&nominal)));
    }
    if rows.is_empty() {
        return Ok(());
    }
    let minus = |a: &[f64; R], b: &[f64; R]| -> [f64; R] { std::array::from_fn(|k| a[k] - b[k]) };
    let (r0, n0) = rows[0];
    let offset = minus(&r0, &n0);
    let bad: Vec<usize> = (1..rows.len())
        .filter(|&j| !plausible(facts, &minus(&minus(&rows[j].0, &offset), &rows[j].1)))
        .collect();
    let Some(&first) = bad.first() else {
        return Ok(());
    };
    // Every row off by the same story: the reference row is the odd one.
    let (k, read, nom) =
        if bad.len() == rows.len() - 1 && rows.len() > 2 && !plausible(facts, &offset) {
            (0, r0, n0)
        } else {
            (first, minus(&rows[first].0, &offset), rows[first].1)
        };
    let offset_removed = k > 0 && offset.iter().any(|x| *x != 0.0);
    // Rows out of order: the readings fit another row's target, and that
    // row is off too (a row whose columns are swapped can fit a mirror
    // pose's target, but the mirror row then reads its own target).
    let own = |i: usize| {
        if i == 0 || k == 0 {
            rows[i].0
        } else {
            minus(&rows[i].0, &offset)
        }
    };
    let spread = |d: &[f64; R]| {
        facts
            .iter()
            .zip(d)
            .map(|(f, x)| x.abs() / f.plausible)
            .fold(0.0, f64::max)
    };
    let elsewhere = (0..rows.len())
        .filter(|&i| i != k)
        .filter(|&i| plausible(facts, &minus(&read, &rows[i].1)))
        .filter(|&i| !plausible(facts, &minus(&own(i), &rows[i].1)))
        .min_by(|&a, &b| {
            spread(&minus(&read, &rows[a].1)).total_cmp(&spread(&minus(&read, &rows[b].1)))
        });
    if let Some(i) = elsewhere {
        return Err(Error::csv(
            file.name,
            format!(
                "line {}: rows out of order: {}",
                file.line(k),
                out_of_order(
                    facts,
                    &read,
                    &readings[k].target(),
                    file.line(i) as usize,
                    &readings[i].target()
                )
            ),
        ));
    }
    Err(Error::csv(
        file.name,
        format!(
            "line {}: {}",
            file.line(k),
            describe(facts, &read, &nom, offset_removed)
        ),
    ))
}

#[cfg(test)]
#[path = "readings_check_tests.rs"]
mod tests;
