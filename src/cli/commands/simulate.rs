//! `simulate`: readings of the machine with the config's [errors].

use crate::calibration;
use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use crate::export::rows::readings_csv;
use crate::io;
use crate::mechanism::tricept::READINGS;
use crate::mechanism::Quantity;
use crate::sensors::ARCSEC_PER_RAD;
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
            sensors_text(cfg),
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

/// The sensors as the readings were made: each datasheet axis by its
/// grade ±a, the others by the paper's reading of their grade.
fn sensors_text(cfg: &Config) -> String {
    let s = &cfg.sensors;
    let Some(st) = &s.structured else {
        return format!("encoder {}″, scale {} µm", s.encoder_arcsec, s.scale_um);
    };
    // The grade in the datasheet's unit, without conversion noise.
    let clean = |x: f64| (x * 1e9).round() / 1e9;
    READINGS
        .iter()
        .zip(st.axes.iter().zip(st.from_section))
        .map(|(r, (axis, sheet))| {
            let (unit, sym, grade) = match r.quantity {
                Quantity::Angle => (ARCSEC_PER_RAD, "″", s.encoder_arcsec),
                Quantity::Length => (1e3, " µm", s.scale_um),
            };
            let name = r.sensor_ascii;
            match sheet {
                true => format!("{name} datasheet ±{}{sym}", clean(axis.accuracy * unit)),
                false => format!("{name} {grade}{sym}"),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}
