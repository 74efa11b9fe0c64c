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
            "encoder {}\", scale {} um, mean of {} samples, seed {seed}",
            cfg.sensors.encoder_arcsec, cfg.sensors.scale_um, cfg.sensors.samples
        )
    };
    let message = format!(
        "wrote {} readings ({noise}) to {}",
        readings.len(),
        out.display()
    );
    // With `--out -` the readings are stdout; the message goes aside.
    if io::is_stdout(out) {
        console::note(message);
    } else {
        console::line(message);
    }
    Ok(())
}
