//! The hexapod's own parts of the commands (`[mechanism] kind =
//! "hexapod"`): compensate's workspace maps, and `export --format
//! linuxcnc` (genhexkins' files; its geometry.json is any mechanism's,
//! `general::run_export_json`). identifiability,
//! simulate, identify, the sweep with its report, and compensate and verify
//! are any mechanism's (`super::general`, dispatched by
//! `cli/mechanism.rs`). The other commands refuse a hexapod config in one
//! sentence until they run it.

mod compensate;

pub use compensate::maps;

use crate::mechanism::hexapod::{Encoders, Hexapod, PHI_READINGS, PSI_READINGS, READINGS};
use crate::montecarlo::general::kernel::VariantRun;
use crate::montecarlo::general::Judged;

/// The hexapod's sizes in the study kernel: its geometry's 33
/// coordinates along the convention's free directions, and 12 readings
/// a pose with both encoders a joint, 6 with one.
pub fn sizes(v: &VariantRun<'_, Hexapod>) -> std::result::Result<Vec<Vec<Judged>>, String> {
    match v.m.encoders {
        Encoders::Both => v.run::<33, 12>(&READINGS),
        Encoders::First => v.run::<33, 6>(&PHI_READINGS),
        Encoders::Second => v.run::<33, 6>(&PSI_READINGS),
    }
}

use crate::cli::commands::general::files::{check_nominal, gate_rejected_fit, read_identified};
use crate::cli::console;
use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::hexapod::convention::CONVENTION;
use std::path::Path;

/// The hexapod's 54 errors of a vector read from `path` (identified.csv).
fn hexapod_errors(path: &Path, e: Vec<f64>) -> Result<crate::mechanism::hexapod::Errors> {
    crate::mechanism::hexapod::errors_of(&e)
        .map_err(|why| Error::csv(path.display().to_string(), why))
}

/// `export --format linuxcnc`: genhexkins.hal and joints.ini of the
/// identified geometry in `out`.
pub fn run_export(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    check_nominal(cfg, identified)?;
    gate_rejected_fit(identified, accept_rejected_fit)?;
    use crate::mechanism::hexapod::export::{genhexkins_hal, joints_ini};
    use crate::store::names::{GENHEXKINS_HAL, JOINTS_INI, LINUXCNC_FILES};
    let errors = hexapod_errors(identified, read_identified(&cfg.hexapod, identified)?)?;
    let header = vec![
        format!(
            "tricept-calib {}: the hexapod geometry identified in {}",
            env!("CARGO_PKG_VERSION"),
            identified.display()
        ),
        format!("config {}; mm; the convention: {CONVENTION}", cfg.source),
    ];
    let mut hal_header = header.clone();
    hal_header.push("after `loadrt genhexkins`: base joints in world coordinates, platform joints in platform coordinates".into());
    let mut ini_header = header;
    ini_header.push("each strut's length when its actuator reads 0 (the nominal home length plus the identified leg offset), mm".into());
    let _lock = io::claim_dir(out)?;
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &LINUXCNC_FILES);
    outputs.add(
        out.join(GENHEXKINS_HAL),
        genhexkins_hal(&cfg.hexapod, &errors, &hal_header).into_bytes(),
    );
    outputs.add(
        out.join(JOINTS_INI),
        joints_ini(&cfg.hexapod, &errors, &ini_header).into_bytes(),
    );
    outputs.write()?;
    console::line(format!(
        "wrote {} (36 genhexkins pins) and {} (6 joints' homes) to {}",
        GENHEXKINS_HAL,
        JOINTS_INI,
        out.display()
    ));
    Ok(())
}
