//! The commands of any mechanism (`identify::general`,
//! `montecarlo::general`, through [`MechanismConfig`]): identifiability and
//! simulate here; identify, the sweep (with its report), and compensate and
//! verify of a mechanism with actuators ([`crate::mechanism::Commanded`])
//! in files of their own; the files they read and write in files.rs. The
//! hexapod runs them; its workspace maps and export are its own
//! (`super::hexapod`).

mod compensate;
mod export;
pub mod files;
mod identify;
mod report;
mod sweep;
mod verify;

pub use compensate::{run_compensate, Maps, MapsOf};
pub use export::run_export_json;
pub use identify::run_identify;
pub use sweep::{run_sweep, SweepFlags};
pub use verify::{run_verify, verify_text};

use crate::cli::{console, OutputFormat};
use crate::config::general::MechanismConfig;
use crate::error::{Error, Result};
use crate::identify::general::{convention_rank, identifiability, Holds};
use crate::io;
use crate::mechanism::Mechanism;
use files::header;
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::path::Path;

/// `identifiability`: the rank over the errors the machine has at the
/// config's poses (the hexapod: 54, or 48 with one encoder a joint), the
/// convention and the combinations no reading sees.
pub fn run_identifiability<C: MechanismConfig>(cfg: &C, format: OutputFormat) -> Result<()> {
    console::text(identifiability_text(cfg, format)?);
    Ok(())
}

/// What `identifiability` prints, in `format`.
pub fn identifiability_text<C: MechanismConfig>(cfg: &C, format: OutputFormat) -> Result<String> {
    let m = cfg.machine();
    let per = m.reading_facts().len();
    let fail = |why: String| Error::config(cfg.source(), format!("poses: {why}"));
    let a = identifiability(m, cfg.poses(), cfg.rank_tolerance()).map_err(fail)?;
    let (rank_free, free) =
        convention_rank(m, cfg.poses(), cfg.rank_tolerance(), &Holds::default()).map_err(fail)?;
    // The errors the config holds at a value (identification.fix) leave the
    // free directions too, as identify takes them (a prior changes no rank).
    let fixed = Holds {
        fixed: cfg.holds().fixed.clone(),
        ..Holds::default()
    };
    let names = m.error_names();
    let held: Vec<&str> = fixed
        .fixed
        .iter()
        .map(|&(j, _)| names[j].as_str())
        .collect();
    let (rank_held, free_held) = match held.is_empty() {
        true => (rank_free, free),
        false => convention_rank(m, cfg.poses(), cfg.rank_tolerance(), &fixed).map_err(fail)?,
    };
    let poses = cfg.poses().len();
    match format {
        OutputFormat::Json => {
            let v = serde_json::json!({
                "mechanism": m.name(),
                "poses": poses,
                "readings_per_pose": per,
                "rank": a.rank,
                "parameters": a.parameters,
                "convention": m.convention(),
                "free_after_convention": free,
                "rank_after_convention": rank_free,
                "held": held,
                "free_after_held": free_held,
                "rank_after_held": rank_held,
                "condition_number_identifiable": finite_or_null(a.condition_number_identifiable),
                "singular_values": a.singular_values,
                "null_directions": a.unidentifiable_combinations,
            });
            let text = serde_json::to_string_pretty(&v)
                .map_err(|e| Error::Argument(format!("json: {e}")))?;
            Ok(format!("{text}\n"))
        }
        OutputFormat::Text => {
            let mut out = format!(
                "{}, {poses} poses, {per} readings each: rank {} of {} errors\n",
                m.name(),
                a.rank,
                a.parameters
            );
            // What no internal sensor sees at any poses (the hexapod's
            // nine); the rest of a deficiency is these poses'.
            let hidden = a.parameters - free;
            let short = (a.parameters - a.rank).saturating_sub(hidden);
            if hidden > 0 {
                out += &format!(
                    "{hidden} combinations no internal sensor sees at any poses; the convention fixes them: {}\n",
                    m.convention()
                );
            }
            if short > 0 {
                out += &format!(
                    "{short} more these poses leave undetermined ({} readings for {free} free errors): add poses, or hold at a value an error no pose can see (identification.fix)\n",
                    poses * per
                );
                // Which errors these poses leave, where no convention's
                // combinations are among them and the readings are enough
                // in number (else more poses is the answer).
                if hidden == 0 && poses * per >= free && !a.unidentifiable.is_empty() {
                    let it = if a.unidentifiable.len() == 1 {
                        "it"
                    } else {
                        "them"
                    };
                    out += &format!(
                        "not identified at these poses: {}; if more poses do not identify {it}, hold {it} at a value (identification.fix) or take a layout that sees {it}\n",
                        a.unidentifiable.join(", "),
                    );
                }
            }
            let whole = |rank: usize, free: usize| match rank == free {
                true => " (every free error identified)",
                false => ": these poses leave some undetermined",
            };
            out += &format!(
                "after the convention: rank {rank_free} of {free} free errors{}\n",
                whole(rank_free, free)
            );
            if !held.is_empty() {
                out += &format!(
                    "and with the {} held at a value (identification.fix: {}): rank {rank_held} of {free_held} free errors{}\n",
                    match held.len() {
                        1 => "one error".to_string(),
                        n => format!("{n} errors"),
                    },
                    held.join(", "),
                    whole(rank_held, free_held)
                );
            }
            if a.condition_number_identifiable.is_finite() {
                out += &format!(
                    "condition number over the identifiable errors: {:.3e}\n",
                    a.condition_number_identifiable
                );
            }
            Ok(out)
        }
    }
}

fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// `simulate`: the readings of the machine with the config's [errors] at
/// its poses, from exact forward kinematics, with white reading noise of
/// the stated σ unless `noise_free`.
pub fn run_simulate<C: MechanismConfig>(
    cfg: &C,
    seed: u64,
    noise_free: bool,
    out: &Path,
) -> Result<()> {
    let m = cfg.machine();
    let errors = cfg.simulated().ok_or_else(|| {
        Error::config(
            cfg.source(),
            "errors: simulate needs an [errors] table (the simulated machine's errors)",
        )
    })?;
    // Each reading's σ (file unit; none noise-free or unstated).
    let stated = if noise_free {
        Vec::new()
    } else {
        cfg.reading_sigma().0
    };
    let per_pose = m.reading_facts().len();
    let normal: Vec<Normal<f64>> = (0..per_pose)
        .map(|k| {
            let s = stated
                .get(if stated.len() == 1 { 0 } else { k })
                .copied()
                .unwrap_or(0.0);
            Normal::new(0.0, s.max(f64::MIN_POSITIVE))
        })
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::Argument(format!("noise: {e}")))?;
    let noisy = stated.iter().any(|s| *s > 0.0);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut csv = header(m).join(",");
    csv.push('\n');
    for (j, (target, x)) in cfg.poses().iter().zip(cfg.pose_rows()).enumerate() {
        let r = m
            .readings(&errors, target)
            .map_err(|why| Error::config(cfg.source(), format!("poses.list[{}]: {why}", j + 1)))?;
        let cells: Vec<String> = x
            .iter()
            .copied()
            .chain(r.into_iter().enumerate().map(|(k, v)| {
                v + if noisy {
                    normal[k].sample(&mut rng)
                } else {
                    0.0
                }
            }))
            .map(|v| format!("{v}"))
            .collect();
        csv += &cells.join(",");
        csv.push('\n');
    }
    io::write_output(out, csv.as_bytes())?;
    // σ₀ as the first reading's sensor states it (″, µm).
    let (_, per, u) = files::sigma_unit(m);
    let message = format!(
        "wrote {} {} poses' readings ({}) to {}",
        cfg.poses().len(),
        m.name(),
        if noisy {
            format!(
                "σ {}{u}, seed {seed}",
                (stated[0] * per * 1e9).round() / 1e9
            )
        } else {
            "noise-free".into()
        },
        out.display()
    );
    console::wrote(out, message);
    Ok(())
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
