//! The files a sweep keeps while it runs: the temporary trials.csv (a
//! [`TrialSink`]), the block log of an unsharded run (`--resume`) and the
//! metadata of a shard's partial result.

use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::names::PARTIAL_JSON;
use crate::io;
use crate::montecarlo::TrialsFormat;
use crate::montecarlo::{fnv1a, Block, Checkpoint, Resume, TrialSink, BLOCK_TRIALS, FNV_START};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How to run a sweep.
#[derive(Debug, Clone, Default)]
pub struct SweepArgs {
    pub threads: usize,
    pub write_trials: bool,
    /// (K, N), 1 ≤ K ≤ N.
    pub shard: Option<(u64, u64)>,
    pub target_ci: Option<f64>,
    pub max_trials: Option<u64>,
    pub resume: bool,
    /// `--trials` overrode the config's `sweep.trials` (errors name the flag).
    pub trials_from_flag: bool,
    /// How trials.csv is stored (`--trials-format`).
    pub trials_format: TrialsFormat,
    /// Discard an interrupted sweep's state (`--restart`).
    pub restart: bool,
    /// Exit with status 3 when no combination meets the target.
    pub require_target: bool,
}

impl SweepArgs {
    /// Check the flags of `sweep` that go together.
    pub fn from_flags(
        threads: usize,
        write_trials: bool,
        shard: Option<&str>,
        target_ci: Option<f64>,
        max_trials: Option<u64>,
        resume: bool,
    ) -> Result<Self> {
        let shard = shard.map(parse_shard).transpose()?;
        if let Some(r) = target_ci {
            if !(r.is_finite() && r > 0.0 && r < 1.0) {
                return Err(Error::Argument(format!(
                    "--target-ci must be a fraction in (0, 1) (got {r})"
                )));
            }
            if shard.is_some() {
                return Err(Error::Argument(
                    "--target-ci cannot be combined with --shard".into(),
                ));
            }
        }
        if max_trials == Some(0) {
            return Err(Error::Argument("--max-trials must be at least 1".into()));
        }
        if max_trials.is_some() && target_ci.is_none() {
            return Err(Error::Argument("--max-trials goes with --target-ci".into()));
        }
        Ok(SweepArgs {
            threads,
            write_trials,
            shard,
            target_ci,
            max_trials,
            resume,
            trials_format: TrialsFormat::Csv,
            trials_from_flag: false,
            restart: false,
            require_target: false,
        })
    }
}

/// Most shards of one study.
pub const MAX_SHARDS: u64 = 100_000;

/// Parse "K/N".
pub fn parse_shard(s: &str) -> Result<(u64, u64)> {
    let bad = || {
        Error::Argument(format!(
            "--shard must be K/N with 1 <= K <= N (got \"{s}\")"
        ))
    };
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let k: u64 = k.trim().parse().map_err(|_| bad())?;
    let n: u64 = n.trim().parse().map_err(|_| bad())?;
    if k == 0 || n == 0 || k > n || n > MAX_SHARDS {
        return Err(bad());
    }
    Ok((k, n))
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

/// Trials [first, first + count) of shard K of N.
pub fn shard_range(trials: u64, k: u64, n: u64) -> (u64, u64) {
    let blocks = trials.div_ceil(BLOCK_TRIALS as u64);
    let b0 = (k - 1) * blocks / n;
    let b1 = k * blocks / n;
    let first = (b0 * BLOCK_TRIALS as u64).min(trials);
    let end = (b1 * BLOCK_TRIALS as u64).min(trials);
    (first, end - first)
}

pub fn config_json(cfg: &Config) -> Result<String> {
    serde_json::to_string(cfg.resolved())
        .map_err(|e| Error::Internal(format!("cannot serialise the config: {e}")))
}

/// A temporary trials.csv that becomes `final_path` only on success.
pub struct TrialsFile {
    tmp: PathBuf,
    final_path: PathBuf,
    w: Option<std::io::BufWriter<std::fs::File>>,
    /// Keep the temporary file when dropped (resumable runs).
    keep: bool,
    format: TrialsFormat,
}

impl TrialsFile {
    pub fn new(out: &Path, enabled: bool, format: TrialsFormat) -> Result<Self> {
        let name = format.file_name();
        let tmp = out.join(format!(".{name}.tmp-{}", std::process::id()));
        Self::at(tmp, out.join(name), enabled, None, false, format)
    }

    /// The file's final name (trials.csv or trials.csv.gz).
    pub fn file_name(&self) -> &'static str {
        self.format.file_name()
    }

    /// At a given temporary path; `resume_len`: keep the first bytes of an
    /// existing file and append after them.
    fn at(
        tmp: PathBuf,
        final_path: PathBuf,
        enabled: bool,
        resume_len: Option<u64>,
        keep: bool,
        format: TrialsFormat,
    ) -> Result<Self> {
        let w = if enabled {
            let f = match resume_len {
                Some(len) => {
                    let f = std::fs::OpenOptions::new()
                        .write(true)
                        .open(&tmp)
                        .map_err(|e| Error::io("reopen", &tmp, e))?;
                    f.set_len(len).map_err(|e| Error::io("truncate", &tmp, e))?;
                    let mut f = f;
                    std::io::Seek::seek(&mut f, std::io::SeekFrom::End(0))
                        .map_err(|e| Error::io("reopen", &tmp, e))?;
                    f
                }
                None => std::fs::File::create(&tmp).map_err(|e| Error::io("create", &tmp, e))?,
            };
            Some(std::io::BufWriter::with_capacity(1 << 20, f))
        } else {
            None
        };
        Ok(TrialsFile {
            tmp,
            final_path,
            w,
            keep,
            format,
        })
    }
    /// Flush and sync; the rename happens in [`TrialsFile::commit`].
    pub fn finish(&mut self) -> Result<()> {
        if let Some(w) = self.w.take() {
            let f = w
                .into_inner()
                .map_err(|e| Error::io("write", &self.final_path, e.into_error()))?;
            f.sync_all()
                .map_err(|e| Error::io("write", &self.final_path, e))?;
        }
        Ok(())
    }
    pub fn commit(&self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.final_path)
            .map_err(|e| Error::io("write", &self.final_path, e))
    }

    /// Hand the finished file to a set of outputs, renamed with them.
    pub fn commit_with(&self, outputs: &mut io::Outputs) {
        outputs.add_ready(self.tmp.clone(), self.final_path.clone());
    }
}

impl TrialSink for TrialsFile {
    fn wants_rows(&self) -> bool {
        self.w.is_some()
    }
    fn format(&self) -> TrialsFormat {
        self.format
    }
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        match self.w.as_mut() {
            Some(w) => w
                .write_all(bytes)
                .map_err(|e| Error::io("write", &self.final_path, e)),
            None => Ok(()),
        }
    }
    fn flush(&mut self) -> Result<()> {
        match self.w.as_mut() {
            Some(w) => w
                .flush()
                .map_err(|e| Error::io("write", &self.final_path, e)),
            None => Ok(()),
        }
    }
    fn sync(&mut self) -> Result<()> {
        match self.w.as_mut() {
            Some(w) => w
                .flush()
                .and_then(|_| w.get_ref().sync_data())
                .map_err(|e| Error::io("write", &self.final_path, e)),
            None => Ok(()),
        }
    }
}

impl Drop for TrialsFile {
    fn drop(&mut self) {
        // Left only when something failed before commit.
        if !self.keep {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
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

/// Set up the block log and trials file of an unsharded sweep in
/// `out/.sweep-state`; with `--resume`, continue what a killed run left.
/// What `state.json` of an unsharded sweep holds: a resumed run must match it.
pub fn state_json(cfg: &Config, args: &SweepArgs) -> Result<String> {
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
    let changed: Vec<&str> = words
        .iter()
        .filter(|(k, _)| a.get(k) != b.get(k))
        .map(|(_, w)| *w)
        .collect();
    match changed.is_empty() {
        true => "its record".into(),
        false => changed.join(", "),
    }
}

pub fn prepare_state(
    cfg: &Config,
    out: &Path,
    state_dir: &Path,
    args: &SweepArgs,
    study: (usize, bool),
) -> Result<(TrialsFile, Option<Checkpoint>, ResumeNote)> {
    let state = state_json(cfg, args)?;
    let state_path = state_dir.join("state.json");
    let log_path = state_dir.join("blocks.bin");
    let part_path = state_dir.join("trials.csv.part");
    let mut recovered = None;
    let mut note = ResumeNote::Fresh;
    if !args.resume && !args.restart && state_path.exists() {
        return Err(Error::Argument(format!(
            "{} holds an interrupted sweep: --resume continues it from its last complete block, --restart discards it and starts again",
            out.display()
        )));
    }
    if args.resume {
        match std::fs::read_to_string(&state_path) {
            Ok(text) if text == state => {
                let log = std::fs::read(&log_path).unwrap_or_default();
                let blocks = Checkpoint::read(&log, study.0, study.1);
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
    let (trials, log) = match recovered {
        Some((resume, log_len)) => {
            let trials = TrialsFile::at(
                part_path,
                out.join(args.trials_format.file_name()),
                args.write_trials,
                Some(resume.trials_bytes),
                true,
                args.trials_format,
            )?;
            let mut log = std::fs::OpenOptions::new()
                .write(true)
                .open(&log_path)
                .map_err(|e| Error::io("reopen", &log_path, e))?;
            log.set_len(log_len)
                .and_then(|_| std::io::Seek::seek(&mut log, std::io::SeekFrom::End(0)))
                .map_err(|e| Error::io("reopen", &log_path, e))?;
            (
                trials,
                Checkpoint {
                    file: log,
                    path: log_path,
                    resume: Some(resume),
                },
            )
        }
        None => {
            let _ = std::fs::remove_dir_all(state_dir);
            std::fs::create_dir_all(state_dir).map_err(|e| Error::io("create", state_dir, e))?;
            io::write_output(&state_path, state.as_bytes())?;
            let trials = TrialsFile::at(
                part_path,
                out.join(args.trials_format.file_name()),
                args.write_trials,
                None,
                true,
                args.trials_format,
            )?;
            let log =
                std::fs::File::create(&log_path).map_err(|e| Error::io("create", &log_path, e))?;
            (
                trials,
                Checkpoint {
                    file: log,
                    path: log_path,
                    resume: None,
                },
            )
        }
    };
    Ok((trials, Some(log), note))
}

/// How many of the intact blocks the trials.csv prefix confirms: each block
/// names the length and hash of trials.csv after it, and the part file must
/// hold exactly those bytes (a missing, truncated or altered file confirms
/// fewer, and those blocks are computed again).
fn trusted_blocks(blocks: &[Block], part: &Path, with_rows: bool) -> usize {
    if !with_rows {
        return blocks.len();
    }
    let Ok(f) = std::fs::File::open(part) else {
        return 0;
    };
    let mut r = std::io::BufReader::with_capacity(1 << 20, f);
    let (mut pos, mut hash) = (0u64, FNV_START);
    let mut trusted = 0;
    for b in blocks {
        let mut need = b.trials_bytes.saturating_sub(pos);
        while need > 0 {
            let Ok(buf) = std::io::BufRead::fill_buf(&mut r) else {
                return trusted;
            };
            if buf.is_empty() {
                return trusted;
            }
            let n = (buf.len() as u64).min(need) as usize;
            hash = fnv1a(hash, &buf[..n]);
            std::io::BufRead::consume(&mut r, n);
            need -= n as u64;
            pos += n as u64;
        }
        if pos != b.trials_bytes || hash != b.trials_hash {
            return trusted;
        }
        trusted += 1;
    }
    trusted
}

/// The trusted blocks as one partial, with where the log continues.
fn join_blocks(blocks: &[Block]) -> Option<(Resume, u64)> {
    let last = blocks.last()?;
    let mut partial = blocks[0].partial.clone();
    for b in &blocks[1..] {
        partial.append(&b.partial);
    }
    Some((
        Resume {
            partial,
            trials_bytes: last.trials_bytes,
            trials_hash: last.trials_hash,
        },
        last.log_len,
    ))
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
            "the tool's version, the config, whether trials.csv is written"
        );
        assert_eq!(what_changed(a, a), "its record");
        let old = r#"{"version":"0.1.0","config_json":"{}","trials_csv":true}"#;
        assert!(what_changed(old, a).contains("earlier build"));
    }
}
