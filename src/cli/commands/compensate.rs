//! `compensate`: maps before/after for the config's true errors; commands
//! for targets.

use crate::calibration;
use crate::cli::console;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::rows::commands_csv;
use crate::export::{correction_files, map_files, workspace_files};
use crate::io::{self, Outputs, Source};
use crate::store;
use crate::store::names::{COMMANDS_CSV, COMPENSATE_FILES};
use std::path::Path;

/// `threads` worker threads compute the maps (their values do not depend
/// on it).
pub fn run(
    cfg: &Config,
    identified_path: &Path,
    out: &Path,
    targets: Option<&Path>,
    threads: usize,
    accept_rejected_fit: bool,
) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start {threads} worker threads: {e}")))?;
    pool.install(|| compensate(cfg, identified_path, out, targets, accept_rejected_fit))
}

/// Refuse identified.csv where identify's identifiability.json beside it
/// records another nominal machine than `cfg`'s
/// ([`store::nominal::check_beside`]); a note where it records none.
pub fn check_nominal(cfg: &Config, identified_path: &Path) -> Result<()> {
    let here = cfg.nominal_keys();
    if let Some(note) = store::nominal::check_beside(identified_path, &here, &cfg.source)? {
        console::note(note);
    }
    Ok(())
}

/// Refuse a fit identify's own checks rejected (its identifiability.json
/// beside identified.csv), unless the user accepts it.
pub fn gate_rejected_fit(identified_path: &Path, accept_rejected_fit: bool) -> Result<()> {
    if let Some(why) = store::inputs::rejected_fit(identified_path) {
        if accept_rejected_fit {
            console::note(format_args!(
                "warning: applying a fit its own checks rejected ({why}), as --accept-rejected-fit asks"
            ));
        } else {
            return Err(Error::csv(
                identified_path.display().to_string(),
                format!("identify's checks rejected this fit ({why}): compensating with it can make the machine worse; find the cause (identify's warning names the likely one) and identify again, or pass --accept-rejected-fit to apply it anyway"),
            ));
        }
    }
    Ok(())
}

fn compensate(
    cfg: &Config,
    identified_path: &Path,
    out: &Path,
    targets: Option<&Path>,
    accept_rejected_fit: bool,
) -> Result<()> {
    let size = cfg.resolved().geometry.a.min(cfg.resolved().geometry.b);
    let bound = store::inputs::identified_bound_mm(size);
    let identified = store::inputs::read_identified(identified_path, bound, cfg.unknowns())?
        .machine(&cfg.homed());
    check_nominal(cfg, identified_path)?;
    gate_rejected_fit(identified_path, accept_rejected_fit)?;
    let commands = match targets {
        Some(tp) => {
            let (list, lines) = store::inputs::read_targets(tp)?;
            let name = tp.display().to_string();
            let q = calibration::commands(
                &cfg.reach(),
                &identified,
                &list,
                Source::new(&name, &lines),
            )?;
            // Only once every target is known good: bad input stays one sentence.
            warn_outside_workspace(cfg, &list, Source::new(&name, &lines));
            Some((list, q))
        }
        None => None,
    };
    // A simulation has a truth to judge the compensation by; a real machine
    // has only its identified model.
    let mut workspace = None;
    let (map, files) = if cfg.has_truth {
        let map = calibration::map(cfg, &identified)?;
        let ws = calibration::workspace_map(cfg, &identified)?;
        let iso = calibration::iso9283_map(cfg, &identified)?;
        let mut files = map_files(cfg, &map)?;
        files.extend(workspace_files(cfg, &ws, &iso)?);
        workspace = Some((ws, iso));
        (map, files)
    } else {
        let map = calibration::correction_map(cfg, &identified)?;
        let vectors =
            calibration::correction_vectors(&cfg.homed(), &identified, &map, &cfg.source)?;
        let files = correction_files(cfg, &map, &vectors)?;
        (map, files)
    };
    // Said once every input is known good (bad input stays one sentence).
    if store::inputs::checks_beside(identified_path).is_none() {
        console::note(format_args!(
            "note: no identifiability.json beside {}: identify's checks of this fit cannot be read, so it is applied as it is",
            identified_path.display()
        ));
    }
    let _lock = io::claim_dir(out)?;
    let mut outputs = Outputs::default();
    outputs.replace_all(out, &COMPENSATE_FILES);
    let names: Vec<&str> = files.iter().map(|(n, _)| *n).collect();
    for (name, bytes) in files {
        outputs.add(out.join(name), bytes);
    }
    if let Some((list, q)) = &commands {
        outputs.add(out.join(COMMANDS_CSV), commands_csv(list, q)?);
    }
    outputs.write()?;
    if let Some((ws, iso)) = &workspace {
        console::print_map(&map, cfg.plane_z_mm);
        console::print_workspace(ws, iso, cfg.layers);
    } else {
        console::print_correction(&map, cfg.plane_z_mm);
    }
    if let Some((list, _)) = commands {
        console::line(format_args!(
            "wrote {} leg commands to {}",
            list.len(),
            out.join(COMMANDS_CSV).display()
        ));
    }
    console::line(format_args!(
        "wrote {} to {}",
        names.join(", "),
        out.display()
    ));
    Ok(())
}

/// Targets outside the workspace cylinder the calibration was judged on:
/// reachable, so commanded, but the identified model was not checked there.
fn warn_outside_workspace(cfg: &Config, targets: &[nalgebra::Vector3<f64>], file: Source) {
    let ws = &cfg.workspace;
    let tol = 1e-6;
    let outside: Vec<u64> = targets
        .iter()
        .enumerate()
        .filter(|(_, r)| {
            (r.x * r.x + r.y * r.y).sqrt() > ws.radius_mm + tol
                || r.z < ws.top_mm - tol
                || r.z > ws.top_mm + ws.height_mm + tol
        })
        .map(|(k, _)| file.line(k))
        .collect();
    if let Some(first) = outside.first() {
        console::note(format_args!(
            "warning: {}: {} target(s) lie outside the workspace (radius {} mm, z from {} to {} mm), the first at line {first}: their commands are computed, but the calibration was judged only inside it",
            file.name,
            outside.len(),
            ws.radius_mm,
            ws.top_mm,
            ws.top_mm + ws.height_mm
        ));
    }
}
