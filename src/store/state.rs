//! The state of a run: `state.json` and the resume of an interrupted
//! unsharded sweep (`.sweep-state`: its block log and trials file), and the
//! metadata of a shard's partial result (`partial.json`).

use super::checkpoint::{join_blocks, read, trusted_blocks, BlockLog};
use super::names::PARTIAL_JSON;
use super::trials::TrialsFormat;
use super::trials_file::TrialsFile;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::io;
use crate::montecarlo::Partial;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How a sweep was asked to run, beyond its config: a resumed run must
/// have been asked the same.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunMode {
    pub target_ci: Option<f64>,
    pub max_trials: Option<u64>,
    pub write_trials: bool,
    pub trials_format: TrialsFormat,
}

/// Metadata of a shard's partial result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ShardInfo {
    pub tool: String,
    pub version: String,
    /// The resolved config as JSON text: merges compare it byte for byte.
    pub config_json: String,
    /// The catalogue's content digest (None without a catalogue).
    #[serde(default)]
    pub catalogue_digest: Option<String>,
    /// The config as the shard's command named it: the merged report names
    /// it as a single run's does.
    #[serde(default)]
    pub config_source: String,
    pub seed: u64,
    pub trials: u64,
    pub shard: u64,
    pub shards: u64,
    pub first_trial: u64,
    pub trial_count: u64,
    pub trials_csv: bool,
    /// How its trials file is stored (absent: csv).
    #[serde(default)]
    pub trials_format: Option<String>,
    pub wall_seconds: f64,
}

pub fn config_json(cfg: &Config) -> Result<String> {
    serde_json::to_string(cfg.resolved())
        .map_err(|e| Error::Internal(format!("cannot serialise the config: {e}")))
}

pub fn read_shard_info(dir: &Path) -> Result<ShardInfo> {
    let p = dir.join(PARTIAL_JSON);
    let text = std::fs::read_to_string(&p).map_err(|_| {
        Error::Argument(format!(
            "{}: not a complete shard (no partial.json)",
            dir.display()
        ))
    })?;
    serde_json::from_str(&text)
        .map_err(|e| Error::Argument(format!("{}: malformed shard metadata ({e})", p.display())))
}

/// What `--resume` found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResumeNote {
    /// A new run (no `--resume`).
    Fresh,
    /// Continuing after this many completed trials; `dropped` later blocks
    /// did not verify and are computed again.
    Resumed { trials: u64, dropped: usize },
    /// `--resume`, but no block verified: started from the beginning.
    StartedAgain,
    /// `--resume`, but nothing to continue: started from the beginning.
    NothingToResume,
}

/// What an interrupted unsharded sweep must match to be resumed.
#[derive(Serialize)]
struct SweepState<'a> {
    version: &'static str,
    config_json: &'a str,
    /// The catalogue's content digest (None without a catalogue).
    catalogue_digest: Option<&'a str>,
    target_ci: Option<f64>,
    max_trials: Option<u64>,
    trials_csv: bool,
    trials_format: &'static str,
}

/// What `state.json` of an unsharded sweep holds: a resumed run must match it.
pub fn state_json(cfg: &Config, args: &RunMode) -> Result<String> {
    let json = config_json(cfg)?;
    serde_json::to_string(&SweepState {
        version: env!("CARGO_PKG_VERSION"),
        config_json: &json,
        catalogue_digest: cfg.catalogue_digest(),
        target_ci: args.target_ci,
        max_trials: args.max_trials,
        trials_csv: args.write_trials,
        trials_format: args.trials_format.name(),
    })
    .map_err(|e| Error::Internal(e.to_string()))
}

/// The keys that differ between two configs (as JSON), each as
/// "key old → new" ("sweep.seed 1 → 2"), at most eight.
pub fn config_differences(a: &serde_json::Value, b: &serde_json::Value) -> Vec<String> {
    fn walk(path: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
        use serde_json::Value::Object;
        match (a, b) {
            (Object(x), Object(y)) => {
                let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
                keys.sort();
                keys.dedup();
                for k in keys {
                    let null = serde_json::Value::Null;
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    walk(
                        &p,
                        x.get(k).unwrap_or(&null),
                        y.get(k).unwrap_or(&null),
                        out,
                    );
                }
            }
            _ if a != b => out.push(format!("{path} {a} → {b}")),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk("", a, b, &mut out);
    out.truncate(8);
    out
}

/// What differs between two study identities (state.json, partial.json or
/// manifest.json texts), in words: the fields that do not match.
pub fn what_changed(old: &str, new: &str) -> String {
    let parse = |t: &str| serde_json::from_str::<serde_json::Value>(t).unwrap_or_default();
    let (a, b) = (parse(old), parse(new));
    let words = [
        ("version", "the tool's version"),
        ("config_json", "the config"),
        ("catalogue_digest", "the catalogue's content"),
        ("target_ci", "the adaptive target"),
        ("max_trials", "the adaptive trial limit"),
        ("trials_csv", "whether trials.csv is written"),
        (
            "trials_format",
            "the trials file's format (--trials-format)",
        ),
    ];
    // A key the old record lacks was written by an earlier build: that,
    // not the key, is what changed.
    if words
        .iter()
        .any(|(k, _)| a.get(k).is_none() && b.get(k).is_some())
    {
        return "the tool's version (it was written by an earlier build)".into();
    }
    let changed: Vec<String> = words
        .iter()
        .filter(|(k, _)| a.get(k) != b.get(k))
        .map(|(k, w)| match (*k, a.get(k), b.get(k)) {
            ("config_json", Some(x), Some(y)) => {
                let keys = config_differences(
                    &serde_json::from_str(x.as_str().unwrap_or_default()).unwrap_or_default(),
                    &serde_json::from_str(y.as_str().unwrap_or_default()).unwrap_or_default(),
                );
                match keys.is_empty() {
                    true => w.to_string(),
                    false => format!("the config ({})", keys.join(", ")),
                }
            }
            _ => w.to_string(),
        })
        .collect();
    match changed.is_empty() {
        true => "its record".into(),
        false => changed.join(", "),
    }
}

/// Set up the block log and trials file of an unsharded sweep in
/// `out/.sweep-state`; with `--resume`, continue what a killed run left.
/// `resume`/`restart`: the flags `--resume` and `--restart`. Returns the
/// trials file (logging every block) and what it continues.
pub fn prepare_state(
    cfg: &Config,
    out: &Path,
    state_dir: &Path,
    args: &RunMode,
    (resume, restart): (bool, bool),
    study: (usize, bool),
) -> Result<(TrialsFile, Option<Partial>, ResumeNote)> {
    let state = state_json(cfg, args)?;
    let state_path = state_dir.join(super::names::STATE_JSON);
    let log_path = state_dir.join(super::names::BLOCKS_BIN);
    let part_path = state_dir.join(super::names::TRIALS_CSV_PART);
    let mut recovered = None;
    let mut note = ResumeNote::Fresh;
    if !resume && !restart && state_path.exists() {
        return Err(Error::Argument(format!(
            "{} holds an interrupted sweep: --resume continues it from its last complete block, --restart discards it and starts again",
            out.display()
        )));
    }
    if resume {
        match std::fs::read_to_string(&state_path) {
            Ok(text) if text == state => {
                let log = std::fs::read(&log_path).unwrap_or_default();
                let blocks = read(&log, study.0, study.1);
                let trusted = trusted_blocks(&blocks, &part_path, args.write_trials);
                note = if trusted > 0 {
                    ResumeNote::Resumed {
                        trials: blocks[..trusted].iter().map(|b| b.partial.trials).sum(),
                        dropped: blocks.len() - trusted,
                    }
                } else {
                    ResumeNote::StartedAgain
                };
                recovered = join_blocks(&blocks[..trusted]);
            }
            Ok(old) => {
                return Err(Error::Argument(format!(
                    "{} holds an interrupted sweep of another study ({} changed): --restart discards it and starts again, or choose another --out",
                    state_dir.display(),
                    what_changed(&old, &state)
                )))
            }
            Err(_) => note = ResumeNote::NothingToResume,
        }
    }
    let trials_path = out.join(args.trials_format.file_name());
    let (mut trials, log) = match &recovered {
        Some((resume, log_len)) => {
            let trials = TrialsFile::at(
                part_path,
                trials_path,
                args.write_trials,
                Some(resume),
                true,
                args.trials_format,
            )?;
            (trials, BlockLog::reopen(&log_path, *log_len)?)
        }
        None => {
            let _ = std::fs::remove_dir_all(state_dir);
            std::fs::create_dir_all(state_dir).map_err(|e| Error::io("create", state_dir, e))?;
            io::write_output(&state_path, state.as_bytes())?;
            let trials = TrialsFile::at(
                part_path,
                trials_path,
                args.write_trials,
                None,
                true,
                args.trials_format,
            )?;
            (trials, BlockLog::create(&log_path)?)
        }
    };
    trials.log_to(log);
    Ok((trials, recovered.map(|(r, _)| r.partial), note))
}

/// What adaptive stopping did (manifest.json).
#[derive(Serialize, Clone, Copy)]
pub struct Adaptive {
    pub target_rel_half_width: f64,
    pub max_trials: u64,
    pub trials_used: u64,
    pub target_met: bool,
}

#[cfg(test)]
mod tests {
    use super::what_changed;

    #[test]
    fn what_changed_names_each_differing_part_of_the_identity() {
        let a =
            r#"{"version":"0.1.0","config_json":"{}","catalogue_digest":"aa","trials_csv":true}"#;
        let b =
            r#"{"version":"0.1.0","config_json":"{}","catalogue_digest":"bb","trials_csv":true}"#;
        assert_eq!(what_changed(a, b), "the catalogue's content");
        let c = r#"{"version":"0.2.0","config_json":"{\"x\":1}","catalogue_digest":"aa","trials_csv":false}"#;
        assert_eq!(
            what_changed(a, c),
            "the tool's version, the config (x null → 1), whether trials.csv is written"
        );
        // The keys of a changed config, old → new, nested by dots.
        let s1 = r#"{"config_json":"{\"sweep\":{\"seed\":1,\"trials\":5}}"}"#;
        let s7 = r#"{"config_json":"{\"sweep\":{\"seed\":7,\"trials\":5}}"}"#;
        assert_eq!(what_changed(s1, s7), "the config (sweep.seed 1 → 7)");
        assert_eq!(what_changed(a, a), "its record");
        let old = r#"{"version":"0.1.0","config_json":"{}","trials_csv":true}"#;
        assert!(what_changed(old, a).contains("earlier build"));
    }
}
