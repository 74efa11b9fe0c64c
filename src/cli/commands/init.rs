//! `init`: a commented template config for a new machine and an example
//! sensor catalogue, never over an existing file.

use crate::cli::console;
use crate::error::{Error, Result};
use crate::io::Outputs;
use std::path::Path;

/// The template of a new machine.
pub const TEMPLATE: &str = include_str!("../../../configs/template.toml");
/// The example catalogue.
pub const CATALOGUE: &str = include_str!("../../../configs/sensors.toml");

/// Write `machine.toml` and `sensors.toml` into `dir` (created if needed);
/// refused, writing nothing, when either exists.
pub fn run(dir: &Path) -> Result<()> {
    use crate::store::names::{INIT_CATALOGUE_TOML, INIT_CONFIG_TOML};
    let files = [
        (INIT_CONFIG_TOML, TEMPLATE),
        (INIT_CATALOGUE_TOML, CATALOGUE),
    ];
    for (name, _) in files {
        let p = dir.join(name);
        if p.symlink_metadata().is_ok() {
            return Err(Error::Argument(format!(
                "{} exists: init never overwrites a file (choose another --out, or remove it)",
                p.display()
            )));
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io("create", dir, e))?;
    let mut outputs = Outputs::default();
    for (name, text) in files {
        outputs.add(dir.join(name), text.as_bytes().to_vec());
    }
    outputs.write()?;
    console::line(format_args!(
        "wrote {0}/machine.toml (a commented template: put in your machine) and {0}/sensors.toml (an example catalogue: put in your quotes); then: tricept-calib identifiability --config {0}/machine.toml",
        dir.display()
    ));
    Ok(())
}
