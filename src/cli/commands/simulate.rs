//! `simulate`: readings of the machine with the config's [errors].

use crate::calibration;
use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use crate::export::rows::readings_csv;
use crate::io;
use std::path::Path;

pub fn run(cfg: &Config, seed: u64, noise_free: bool, out: &Path) -> Result<()> {
    let poses = cfg.nominal_poses()?;
    let readings = calibration::simulate(cfg, &poses, seed, noise_free)?;
    io::write_output(out, &readings_csv(&readings)?)?;
    let noise = if noise_free {
        "noise-free".to_string()
    } else {
        format!(
            "{}, mean of {} samples, seed {seed}",
            cfg.sensors.in_words(),
            cfg.sensors.samples
        )
    };
    let message = format!(
        "wrote {} readings ({noise}) to {}",
        readings.len(),
        out.display()
    );
    console::wrote(out, message);
    Ok(())
}
