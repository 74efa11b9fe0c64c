//! Which machine a config describes (`[mechanism] kind`), the config of a
//! command that runs either, and the commands of any mechanism run on it
//! ([`OnAny`]).

use super::commands::general;
use super::{ExportFormat, OutputFormat};
use crate::config::general::MechanismConfig;
use crate::config::{self, Config};
use crate::error::{Error, Result};
use crate::mechanism::{Commanded, Mechanism as _};
use std::path::Path;

pub(super) fn hexapod_kind(text: &str) -> bool {
    crate::config::hexapod::kind_of(text).as_deref() == Some("hexapod")
}

/// Is a config's `text` the Tricept's (no `[mechanism] kind`, or
/// "tricept")?
pub(super) fn tricept_kind(text: &str) -> bool {
    crate::config::hexapod::kind_of(text).is_none_or(|k| k == "tricept")
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
    mechanism_of(&text, &source)
}

/// The config of `text` (read from `source`) for a command that runs
/// either mechanism.
pub(super) fn mechanism_of(text: &str, source: &str) -> Result<Mechanism> {
    let (text, source) = (text.to_string(), source.to_string());
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

/// A command of any mechanism (`commands::general`), to run on a config
/// whose mechanism implements the general traits: a third mechanism runs
/// every such command once [`Mechanism::on_any`] knows its config (and,
/// where it has them, its own parts: [`Parts`]).
pub(super) trait OnAny {
    fn run<C: MechanismConfig>(self, cfg: &C, parts: &Parts<C>) -> Result<()>
    where
        C::M: Commanded;
}

/// What a mechanism adds to the commands of any mechanism, if anything:
/// compensate's workspace maps of a simulated machine (its config, the
/// identified.csv read, the true and the identified errors).
pub(super) struct Parts<C: MechanismConfig> {
    pub maps: Option<MapsFn<C>>,
    pub linuxcnc: Option<ExportFn<C>>,
    /// Its sizes in the study kernel (sweep), instrumentation by
    /// instrumentation.
    pub sizes: Option<crate::montecarlo::general::kernel::KernelFn<C::M>>,
}

/// A mechanism's export to a controller: its config, identified.csv, the
/// folder to write, whether a fit identify's checks rejected is taken.
pub(super) type ExportFn<C> = fn(&C, &Path, &Path, bool) -> Result<()>;

/// A mechanism's workspace maps for compensate: its config, the
/// identified.csv read, the true and the identified errors.
pub(super) type MapsFn<C> = fn(&C, &Path, &[f64], &[f64]) -> Result<general::Maps>;

impl Mechanism {
    /// `cmd` on this config where its mechanism runs the commands of any
    /// mechanism (every one but the Tricept, whose commands are its own);
    /// the Tricept's config back otherwise.
    pub(super) fn on_any(self, cmd: impl OnAny) -> std::result::Result<Result<()>, Box<Config>> {
        match self {
            Mechanism::Tricept(cfg) => Err(cfg),
            Mechanism::Hexapod(cfg) => Ok(cmd.run(
                &*cfg,
                &Parts {
                    maps: Some(super::commands::hexapod::maps),
                    linuxcnc: Some(super::commands::hexapod::run_export),
                    sizes: Some(super::commands::hexapod::sizes),
                },
            )),
        }
    }
}

/// Refused in one sentence: what `verb` takes for the Tricept only.
fn not_yet<C: MechanismConfig>(cfg: &C, verb: &str, flags: &str) -> Error {
    let kind = cfg.machine().name();
    Error::config(
        cfg.source(),
        format!("mechanism.kind = \"{kind}\": {verb} takes no {flags} for the {kind} yet"),
    )
}

/// `simulate`.
pub(super) struct Simulate<'a> {
    pub seed: u64,
    pub noise_free: bool,
    pub out: &'a Path,
}

impl OnAny for Simulate<'_> {
    fn run<C: MechanismConfig>(self, cfg: &C, _: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        general::run_simulate(cfg, self.seed, self.noise_free, self.out)
    }
}

/// `identify`; `tricept_only` when a flag only the Tricept's takes is given.
pub(super) struct Identify<'a> {
    pub readings: &'a Path,
    pub out: &'a Path,
    pub tricept_only: bool,
}

impl OnAny for Identify<'_> {
    fn run<C: MechanismConfig>(self, cfg: &C, _: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        if self.tricept_only {
            return Err(not_yet(cfg, "identify", "--reference or --json"));
        }
        general::run_identify(cfg, self.readings, self.out)
    }
}

/// `verify`; `tricept_only` as [`Identify`]'s.
pub(super) struct Verify<'a> {
    pub identified: &'a Path,
    pub readings: &'a Path,
    pub threshold_mm: f64,
    pub nominal_commands: bool,
    pub tricept_only: bool,
}

impl OnAny for Verify<'_> {
    fn run<C: MechanismConfig>(self, cfg: &C, _: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        if self.tricept_only {
            return Err(not_yet(cfg, "verify", "--reference, --out or --json"));
        }
        general::run_verify(
            cfg,
            self.identified,
            self.readings,
            self.threshold_mm,
            self.nominal_commands,
        )
    }
}

/// `identifiability`.
pub(super) struct Identifiability(pub OutputFormat);

impl OnAny for Identifiability {
    fn run<C: MechanismConfig>(self, cfg: &C, _: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        general::run_identifiability(cfg, self.0)
    }
}

/// `compensate`, with the mechanism's workspace maps where it has them.
pub(super) struct Compensate<'a> {
    pub identified: &'a Path,
    pub out: &'a Path,
    pub targets: Option<&'a Path>,
    pub accept_rejected_fit: bool,
}

impl OnAny for Compensate<'_> {
    fn run<C: MechanismConfig>(self, cfg: &C, parts: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        let maps = parts
            .maps
            .map(|f| move |truth: &[f64], model: &[f64]| f(cfg, self.identified, truth, model));
        general::run_compensate(
            cfg,
            self.identified,
            self.out,
            self.targets,
            self.accept_rejected_fit,
            maps.as_ref().map(|m| m as general::MapsOf),
        )
    }
}

/// `export`: geometry.json of any mechanism; `--format linuxcnc` where
/// the mechanism exports to LinuxCNC ([`Parts::linuxcnc`]).
pub(super) struct Export<'a> {
    pub format: ExportFormat,
    pub identified: &'a Path,
    pub out: &'a Path,
    pub accept_rejected_fit: bool,
}

impl OnAny for Export<'_> {
    fn run<C: MechanismConfig>(self, cfg: &C, parts: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        let (identified, out, accept) = (self.identified, self.out, self.accept_rejected_fit);
        match (self.format, parts.linuxcnc) {
            (ExportFormat::Json, _) => general::run_export_json(cfg, identified, out, accept),
            (ExportFormat::Linuxcnc, Some(export)) => export(cfg, identified, out, accept),
            (ExportFormat::Linuxcnc, None) => {
                let kind = cfg.machine().name();
                Err(Error::config(
                    cfg.source(),
                    format!("mechanism.kind = \"{kind}\": --format linuxcnc writes the files of a LinuxCNC kinematics module, and the {kind} has none to load: use --format json (geometry.json)"),
                ))
            }
        }
    }
}

/// `sweep`: the study of any mechanism, which takes `--config`, `--out`,
/// `--trials`, `--seed` and `--threads`; `tricept_only` names the flags
/// only the Tricept's study takes, each with whether it was given.
pub(super) struct Sweep<'a> {
    pub out: &'a Path,
    pub threads: usize,
    pub flags: general::SweepFlags,
    pub tricept_only: &'a [(&'static str, bool)],
}

impl OnAny for Sweep<'_> {
    fn run<C: MechanismConfig>(self, cfg: &C, parts: &Parts<C>) -> Result<()>
    where
        C::M: Commanded,
    {
        let kind = cfg.machine().name();
        if let Some((flag, _)) = self.tricept_only.iter().find(|(_, set)| *set) {
            return Err(Error::Argument(format!(
                "a {kind} sweep does not take {flag} (the Tricept's study does): it takes --config, --out, --trials, --seed, --threads, --no-trials, --trials-format, --max-trials, --require-target and --json"
            )));
        }
        let most = crate::config::general::MAX_STUDY_TRIALS;
        if let Some(n) = self.flags.trials.filter(|&n| n > most) {
            return Err(Error::Argument(format!(
                "--trials must be at most {most} for a {kind} sweep, as sweep.trials must (got {n})"
            )));
        }
        let Some(sizes) = parts.sizes else {
            return Err(Error::config(
                cfg.source(),
                format!(
                    "the study kernel is not given the {}'s sizes yet: sweep runs it once they are",
                    cfg.machine().name()
                ),
            ));
        };
        general::run_sweep(cfg, self.out, (self.threads, sizes), self.flags)
    }
}
