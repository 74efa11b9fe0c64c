//! The hexapod's commands (`[mechanism] kind = "hexapod"`): identifiability
//! and simulate here; identify, compensate and verify, and export in files
//! of their own; the files they read and write in files.rs. The other
//! commands refuse a hexapod config in one sentence until they run it.

mod compensate;
mod export;
mod files;
mod identify;
mod report;
mod sweep;

pub use compensate::{run_compensate, run_verify};
pub use export::{run_export, run_export_json};
pub use identify::run_identify;
pub use sweep::sweep_from_flags;

use crate::cli::{console, OutputFormat};
use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use crate::identify::general::{convention_rank, identifiability, Holds};
use crate::io;
use crate::mechanism::hexapod::convention::CONVENTION;
use files::header;
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::path::Path;

/// `identifiability`: the rank over the 54 (or 48) errors at the config's
/// poses, the convention and the combinations no reading sees.
pub fn run_identifiability(cfg: &HexapodConfig, format: OutputFormat) -> Result<()> {
    let fail = |why: String| Error::config(&cfg.source, format!("poses: {why}"));
    let a = identifiability(&cfg.hexapod, &cfg.poses, cfg.rank_tolerance).map_err(fail)?;
    let (rank_free, free) = convention_rank(
        &cfg.hexapod,
        &cfg.poses,
        cfg.rank_tolerance,
        &Holds::default(),
    )
    .map_err(fail)?;
    match format {
        OutputFormat::Json => {
            let v = serde_json::json!({
                "mechanism": "hexapod",
                "poses": cfg.poses.len(),
                "readings_per_pose": cfg.hexapod.readings_per_pose(),
                "rank": a.rank,
                "parameters": a.parameters,
                "convention": CONVENTION,
                "free_after_convention": free,
                "rank_after_convention": rank_free,
                "condition_number_identifiable": finite_or_null(a.condition_number_identifiable),
                "singular_values": a.singular_values,
                "null_directions": a.unidentifiable_combinations,
            });
            let text = serde_json::to_string_pretty(&v)
                .map_err(|e| Error::Argument(format!("json: {e}")))?;
            console::text(format!("{text}\n"));
        }
        OutputFormat::Text => {
            let mut out = format!(
                "hexapod, {} poses, {} readings each: rank {} of {} errors\n",
                cfg.poses.len(),
                cfg.hexapod.readings_per_pose(),
                a.rank,
                a.parameters
            );
            // Nine are what no internal sensor sees at any poses; the
            // rest of a deficiency is these poses'.
            let hidden = a.parameters - free;
            let short = (a.parameters - a.rank).saturating_sub(hidden);
            out += &format!(
                "{hidden} combinations no internal sensor sees at any poses; the convention fixes them: {CONVENTION}\n"
            );
            if short > 0 {
                out += &format!(
                    "{short} more these poses leave undetermined ({} readings for {free} free errors): add poses\n",
                    cfg.poses.len() * cfg.hexapod.readings_per_pose()
                );
            }
            out += &format!(
                "after the convention: rank {rank_free} of {free} free errors{}\n",
                if rank_free == free {
                    " (every free error identified)"
                } else {
                    ": these poses leave some undetermined; add poses"
                }
            );
            if a.condition_number_identifiable.is_finite() {
                out += &format!(
                    "condition number over the identifiable errors: {:.3e}\n",
                    a.condition_number_identifiable
                );
            }
            console::text(out);
        }
    }
    Ok(())
}

fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// `simulate`: the encoders' readings of the machine with the config's
/// [errors] at its poses, from exact forward kinematics, with white
/// reading noise of `sensors.encoder_noise_arcsec` unless `noise_free`.
pub fn run_simulate(cfg: &HexapodConfig, seed: u64, noise_free: bool, out: &Path) -> Result<()> {
    let errors = cfg.errors.ok_or_else(|| {
        Error::config(
            &cfg.source,
            "errors: simulate needs an [errors] table (the simulated machine's errors)",
        )
    })?;
    let sigma_deg = if noise_free {
        0.0
    } else {
        cfg.encoder_noise_arcsec / 3600.0
    };
    let normal = Normal::new(0.0, sigma_deg.max(f64::MIN_POSITIVE))
        .map_err(|e| Error::Argument(format!("noise: {e}")))?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut csv = header(cfg).join(",");
    csv.push('\n');
    for (j, (target, x)) in cfg.poses.iter().zip(&cfg.pose_list).enumerate() {
        let r = cfg
            .hexapod
            .readings(&errors, target)
            .map_err(|why| Error::config(&cfg.source, format!("poses.list[{}]: {why}", j + 1)))?;
        let cells: Vec<String> = x
            .iter()
            .copied()
            .chain(r.into_iter().map(|v| {
                v + if sigma_deg > 0.0 {
                    normal.sample(&mut rng)
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
    let message = format!(
        "wrote {} hexapod poses' readings ({}) to {}",
        cfg.poses.len(),
        if sigma_deg > 0.0 {
            format!("σ {}″, seed {seed}", cfg.encoder_noise_arcsec)
        } else {
            "noise-free".into()
        },
        out.display()
    );
    if io::is_stdout(out) {
        console::note(message);
    } else {
        console::line(message);
    }
    Ok(())
}
