//! The flags of `sweep` that go together, and the shards of a study.

use crate::error::{Error, Result};
use crate::montecarlo::BLOCK_TRIALS;
use crate::store::{RunMode, TrialsFormat};

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
    /// Print the verdict as JSON on stdout (`--json`).
    pub json: bool,
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
            json: false,
        })
    }

    /// What the run's state records of these flags.
    pub fn mode(&self) -> RunMode {
        RunMode {
            target_ci: self.target_ci,
            max_trials: self.max_trials,
            write_trials: self.write_trials,
            trials_format: self.trials_format,
        }
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

/// Trials [first, first + count) of shard K of N.
pub fn shard_range(trials: u64, k: u64, n: u64) -> (u64, u64) {
    let blocks = trials.div_ceil(BLOCK_TRIALS as u64);
    let b0 = (k - 1) * blocks / n;
    let b1 = k * blocks / n;
    let first = (b0 * BLOCK_TRIALS as u64).min(trials);
    let end = (b1 * BLOCK_TRIALS as u64).min(trials);
    (first, end - first)
}
