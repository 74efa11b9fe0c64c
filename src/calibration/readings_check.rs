//! What a row of readings that no geometric error can explain looks like,
//! read from the readings' facts alone ([`ReadingFact`]: column, quantity,
//! plausible distance): two readings of one quantity swapped, a sign
//! flipped, a length in metres, angles in radians. Any topology's readings
//! get the same diagnosis; the mechanism's are two angles and a length.

use crate::mechanism::{Quantity, ReadingFact};
use nalgebra::Vector3;

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

#[cfg(test)]
#[path = "readings_check_tests.rs"]
mod tests;
