//! `compensate`: maps before/after for the config's true errors; commands
//! for targets.

use crate::calibration;
use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use crate::export::map_files;
use crate::export::names::{COMMANDS_CSV, FIG3_PNG, VOLUMETRIC_CSV, VOLUMETRIC_SUMMARY_CSV};
use crate::export::rows::commands_csv;
use crate::io::{self, Outputs};
use crate::model::Machine;
use std::path::Path;

pub fn run(cfg: &Config, identified_path: &Path, out: &Path, targets: Option<&Path>) -> Result<()> {
    let (est, _ident) = io::read_identified(identified_path)?;
    let identified = Machine::with_errors(&cfg.geometry, &est);
    let commands = match targets {
        Some(tp) => {
            let list = io::read_targets(tp)?;
            let q = calibration::commands(cfg, &identified, &list, &tp.display().to_string())?;
            Some((list, q))
        }
        None => None,
    };
    let map = calibration::map(cfg, &identified)?;
    io::ensure_dir(out)?;
    let mut outputs = Outputs::default();
    for (name, bytes) in map_files(cfg, &map)? {
        outputs.add(out.join(name), bytes);
    }
    if let Some((list, q)) = &commands {
        outputs.add(out.join(COMMANDS_CSV), commands_csv(list, q)?);
    }
    outputs.write()?;
    console::print_map(&map, cfg.plane_z_mm);
    if let Some((list, _)) = commands {
        console::line(format_args!(
            "wrote {} leg commands to {}",
            list.len(),
            out.join(COMMANDS_CSV).display()
        ));
    }
    console::line(format_args!(
        "wrote {VOLUMETRIC_CSV}, {VOLUMETRIC_SUMMARY_CSV}, {FIG3_PNG} to {}",
        out.display()
    ));
    Ok(())
}
