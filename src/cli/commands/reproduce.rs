//! `reproduce`: the paper's case end to end (see [`crate::report`]).

use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use std::path::{Path, PathBuf};

pub fn run(cfg: &Config, out: &Path, threads: usize) -> Result<()> {
    if cfg.identification.second_class {
        return Err(crate::error::Error::config(
            &cfg.source,
            "identification.second_class: reproduce is the paper's method, 15 errors with ideal Hooke axes; identify the axes with simulate, identify and compensate (or in a sweep), or leave second_class out here",
        ));
    }
    let files = crate::report::reproduce(cfg, out, threads)?;
    console::line(format_args!(
        "wrote {} files to {}",
        files.len(),
        out.display()
    ));
    Ok(())
}

/// The config `reproduce` uses: the flag, else `configs/paper.toml` when it
/// exists here, else the built-in copy (None).
pub fn config_path(flag: Option<PathBuf>) -> Option<PathBuf> {
    flag.or_else(|| {
        let default = PathBuf::from("configs/paper.toml");
        if default.exists() {
            Some(default)
        } else {
            console::note("note: configs/paper.toml not found here; using the built-in copy");
            None
        }
    })
}
