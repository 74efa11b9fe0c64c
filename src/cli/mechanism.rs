//! Which machine a config describes (`[mechanism] kind`), and the config
//! of a command that runs either.

use crate::config::{self, Config};
use crate::error::{Error, Result};
use std::path::Path;

pub(super) fn hexapod_kind(text: &str) -> bool {
    crate::config::hexapod::kind_of(text).as_deref() == Some("hexapod")
}

/// A `[mechanism] kind` neither machine's: refused naming the key, before
/// either parser reads sections the other does not know.
pub(super) fn check_kind(text: &str, source: &str) -> Result<()> {
    match crate::config::hexapod::kind_of(text) {
        Some(k) if k != "tricept" && k != "hexapod" => Err(Error::config(
            source,
            format!("mechanism.kind must be \"tricept\" or \"hexapod\" (got \"{k}\")"),
        )),
        _ => Ok(()),
    }
}

/// The config at `path` for a command that runs either mechanism.
pub(super) enum Mechanism {
    Tricept(Box<Config>),
    Hexapod(Box<crate::config::hexapod::HexapodConfig>),
}

pub(super) fn load_mechanism(path: &Path) -> Result<Mechanism> {
    let (text, source) = config::load_text(path)?;
    check_kind(&text, &source)?;
    if hexapod_kind(&text) {
        let cfg = crate::config::hexapod::HexapodConfig::parse(&text, &source)?;
        return Ok(Mechanism::Hexapod(Box::new(cfg)));
    }
    let raw = config::parse_raw(&text, &source)?;
    Ok(Mechanism::Tricept(Box::new(Config::from_raw(
        raw, &source,
    )?)))
}
