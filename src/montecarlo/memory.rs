//! How much memory a study needs, known before it starts. What a run keeps
//! is bounded by design: per calibration μ and a failure byte (and 24 bytes
//! of dV with `volumetric`), per trial μ0, per block and grade four error
//! sums (the estimate's and the linearisation's); the summary sorts one grade at a time; the solvers hold two
//! errors × rows matrices per grade. Everything else is per block (8192
//! trials) or per worker. A study that would not fit is refused before any
//! work.

use super::outcome::Outcome;
use super::partial::{BUDGET_TERMS, DV_PER_CALIBRATION};
use super::runner::BLOCK_TRIALS;
use crate::error::{Error, Result};

/// The dimensions that set a run's memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Footprint {
    pub trials: u64,
    /// Calibrations per trial (sensor grades × estimators).
    pub grades: u64,
    /// Errors a calibration estimates.
    pub errors: u64,
    /// Rows of the observation, 3 per pose after the reference.
    pub rows: u64,
    pub volumetric: bool,
    /// trials.csv rows are formatted per block.
    pub rows_csv: bool,
    /// Copies of the per-calibration records held at once: 1 for a run,
    /// 2 for a merge (the shards' records and their copy being read), 3 for
    /// a resume (the block log, its parsed blocks and the joined records).
    pub copies: u32,
    /// Worker threads, each with its own draw buffers.
    pub workers: u64,
    /// Jitter draws of one machine (every sample of every quantised,
    /// noisy reading: [`crate::config::Config::jitter_draws`]); a worker
    /// holds them twice (the draws and their copy in resolution units).
    pub jitter_draws: u64,
    /// Numbers a solver's weighting keeps per observation row: 1 for row
    /// weights, the factored Σ's columns for GLS
    /// ([`crate::config::Study::weight_columns`]).
    pub weight_columns: u64,
    /// Grades whose trials record their linearisation error
    /// ([`crate::config::Study::recorded_grades`]): two blocks of one
    /// error vector a trial each.
    pub recorded: u64,
}

impl Footprint {
    /// Peak bytes of a run, rounded up (a small fixed part included).
    pub fn bytes(&self) -> u128 {
        let t = self.trials as u128;
        let g = self.grades as u128;
        let errors = self.errors as u128;
        let dv = if self.volumetric {
            8 * DV_PER_CALIBRATION as u128
        } else {
            0
        };
        let per_calibration = 9 + dv;
        let blocks = t.div_ceil(BLOCK_TRIALS as u128);
        let records = t * 8
            + t * g * per_calibration
            + blocks * g * (4 * errors + BUDGET_TERMS as u128 + 2) * 8;
        let summary = t * (16 + dv);
        // An operator is stored row-major and by row (16 lanes), with its
        // design matrix and its weighting.
        let solvers =
            g * (2 * errors + 16 + self.weight_columns.max(1) as u128) * self.rows as u128 * 8;
        // Two blocks of outcomes and their estimates − truth: one
        // computing, one being written.
        let outcome = std::mem::size_of::<Outcome>() as u128 + 8 * errors;
        // With trials.csv, both blocks' rows as text too (up to 205 bytes a
        // row with the workspace columns; measured on the catalogue study:
        // 1.5 GB more resident than without).
        let text = if self.rows_csv { 2 * 210 } else { 0 };
        let block = BLOCK_TRIALS as u128
            * (g * (2 * outcome + text) + 2 * self.recorded.max(1) as u128 * errors * 8);
        let workers = self.workers.max(1) as u128 * 2 * 8 * self.jitter_draws as u128;
        records * self.copies.max(1) as u128 + summary + solvers + block + workers + (64 << 20)
    }
}

/// Peak bytes of identifying from a log of `poses` poses read from a file
/// of `file_bytes` bytes, with a GLS weighting of `weight_columns` columns
/// (0 for row weights): the file read whole and parsed row by row (3× its
/// size, a bound), and
/// per observation row the design, its weighted and scaled copies, the
/// SVD's factor, the operator twice, the fold solvers of the held-out
/// check and the factored Σ — 340 numbers plus 2 per weighting column,
/// measured: 100,000 poses with 13-column GLS peak at 0.82 GB, this says
/// 0.91 GB (docs/method.md §13).
pub fn identify_bytes(poses: u64, file_bytes: u64, weight_columns: u64) -> u128 {
    let rows = 3 * poses.saturating_sub(1) as u128;
    rows * 8 * (340 + 2 * weight_columns as u128) + 3 * file_bytes as u128 + (32 << 20)
}

/// Refuse (exit 2) identifying from a log that would need more than 80 %
/// of the available memory, before any work.
pub fn check_identify(poses: u64, file_bytes: u64, weight_columns: u64, file: &str) -> Result<()> {
    match available_bytes() {
        Some(avail) => check_identify_with(poses, file_bytes, weight_columns, file, avail),
        None => Ok(()),
    }
}

/// [`check_identify`] against `avail` bytes.
pub fn check_identify_with(
    poses: u64,
    file_bytes: u64,
    weight_columns: u64,
    file: &str,
    avail: u128,
) -> Result<()> {
    let need = identify_bytes(poses, file_bytes, weight_columns);
    match avail {
        avail if need * 5 > avail * 4 => Err(Error::csv(
            file,
            format!(
                "{poses} poses would need about {:.1} GiB of memory to identify from, more than this machine has available ({:.1} GiB): thin the log to fewer poses spread over the workspace",
                gib(need),
                gib(avail)
            ),
        )),
        _ => Ok(()),
    }
}

/// Memory this process may use: MemAvailable, or a cgroup limit if lower.
pub fn available_bytes() -> Option<u128> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb: u128 = meminfo
        .lines()
        .find(|l| l.starts_with("MemAvailable:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    let mut avail = kb * 1024;
    // The limit of this process's own cgroup (v2), e.g. a Slurm job's.
    let own = std::fs::read_to_string("/proc/self/cgroup")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("0::").map(str::to_string))
        });
    let mut paths = vec!["/sys/fs/cgroup/memory.max".to_string()];
    if let Some(p) = own {
        paths.push(format!(
            "/sys/fs/cgroup{}/memory.max",
            p.trim_end_matches('/')
        ));
    }
    for p in paths {
        if let Ok(limit) = std::fs::read_to_string(&p) {
            if let Ok(l) = limit.trim().parse::<u128>() {
                avail = avail.min(l);
            }
        }
    }
    // `ulimit -v`: the address space this process may map (less what it has
    // mapped already, the binary and its threads' stacks).
    if let Some(limit) = address_space_limit() {
        let used = std::fs::read_to_string("/proc/self/statm")
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse::<u128>().ok())
            .map_or(0, |pages| pages * 4096);
        avail = avail.min(limit.saturating_sub(used));
    }
    Some(avail.max(1))
}

/// The soft limit on this process's address space (RLIMIT_AS), bytes; None
/// when unlimited or unknown.
fn address_space_limit() -> Option<u128> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    line.trim_start_matches("Max address space")
        .split_whitespace()
        .next()?
        .parse::<u128>()
        .ok()
}

fn gib(b: u128) -> f64 {
    b as f64 / (1u128 << 30) as f64
}

/// Refuse (exit 2) a run that needs more than 80 % of the available memory,
/// with the figure and what to do instead.
pub fn check(f: &Footprint, what: &str) -> Result<()> {
    match available_bytes() {
        Some(avail) => check_with(f, what, avail),
        None => Ok(()),
    }
}

/// [`check`] against `avail` bytes.
pub fn check_with(f: &Footprint, what: &str, avail: u128) -> Result<()> {
    let need = f.bytes();
    if need * 5 > avail * 4 {
        let draws = Footprint {
            jitter_draws: 0,
            ..*f
        };
        if (need - draws.bytes()) * 2 > need {
            // The workers' draw buffers, not the records: shards would not help.
            return Err(Error::Argument(format!(
                "{what} needs about {:.1} GiB of memory, most of it each worker's draw buffers ({} worker threads × {} jitter draws a machine), more than this machine has available ({:.1} GiB): use fewer --threads or fewer sensors.samples",
                gib(need),
                f.workers,
                f.jitter_draws,
                gib(avail)
            )));
        }
        let shards = (need * 5).div_ceil(avail * 4).max(2);
        return Err(Error::Argument(format!(
            "{what} needs about {:.1} GiB of memory ({} trials × {} calibrations each), more than this machine has available ({:.1} GiB): run it as {shards} or more shards (--shard K/N, then merge on a machine with the memory) or with fewer trials or grades",
            gib(need),
            f.trials,
            f.grades,
            gib(avail)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Identifying costs O(poses): per row 340 numbers and 2 per GLS
    /// column, and a log that would not fit is refused in a sentence naming
    /// the file.
    #[test]
    fn identifying_a_log_is_linear_in_its_poses_and_refused_beyond_memory() {
        let b = |p: u64, w: u64| identify_bytes(p, 0, w);
        assert_eq!(b(1001, 0) - b(1, 0), 3000 * 8 * 340);
        assert_eq!(b(1001, 13) - b(1001, 0), 3000 * 8 * 26);
        assert_eq!(identify_bytes(1, 1000, 0) - b(1, 0), 3000);
        // The measured peak of 100,000 poses with 13-column GLS (0.82 GB)
        // is under the estimate, and not by more than a third.
        let est = b(100_000, 13) as f64;
        assert!(est > 0.82e9 && est < 1.1e9, "{est}");
        let err = check_identify_with(100_000, 0, 13, "r.csv", 1 << 30)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("r.csv") && err.contains("GiB") && err.contains("thin the log"),
            "{err}"
        );
        check_identify_with(100_000, 0, 13, "r.csv", 2 << 30).unwrap();
    }

    #[test]
    fn footprint_grows_with_trials_and_grades() {
        let f = Footprint {
            trials: 1_000_000,
            grades: 7,
            errors: 15,
            rows: 150,
            volumetric: false,
            rows_csv: false,
            copies: 1,
            workers: 2,
            jitter_draws: 0,
            weight_columns: 1,
            recorded: 0,
        };
        // About 9 bytes × trials × grades plus the per-trial and summary parts.
        let b = f.bytes();
        assert!(b > 1_000_000 * 7 * 9 && b < 200 << 20, "{b}");
        let big = Footprint {
            trials: 1_000_000_000,
            ..f
        };
        assert!(big.bytes() > 60 * (1u128 << 30));
        let err = check(&big, "this study").unwrap_err();
        assert!(err.is_input() && err.to_string().contains("GiB"), "{err}");
        check(&f, "this study").unwrap();
        // The marginal cost of each dimension, as the module says: per trial
        // 8 bytes of μ0, 9 per calibration, 16 of summary samples, and per
        // block of trials each grade's error sums and budget terms.
        let more = |g: Footprint| g.bytes() - f.bytes();
        let b = BLOCK_TRIALS as u128;
        assert_eq!(
            more(Footprint {
                trials: f.trials + BLOCK_TRIALS as u64,
                ..f
            }),
            b * 8 + b * 7 * 9 + 7 * (4 * 15 + 5 + 2) * 8 + b * 16
        );
        // The workspace adds 5 numbers a calibration and to the summary.
        assert_eq!(
            more(Footprint {
                volumetric: true,
                ..f
            }),
            1_000_000 * 7 * 40 + 1_000_000 * 40
        );
        // Copies hold the records again; a row of the observation costs
        // each grade's operator a column; trials.csv text two blocks.
        let records = 1_000_000 * 8 + 1_000_000 * 7 * 9 + 123 * 7 * (4 * 15 + 5 + 2) * 8;
        assert_eq!(more(Footprint { copies: 3, ..f }), 2 * records);
        assert_eq!(more(Footprint { rows: 151, ..f }), 7 * (30 + 16 + 1) * 8);
        // GLS's factored whitening: its columns per row and grade.
        assert_eq!(
            more(Footprint {
                weight_columns: 13,
                ..f
            }),
            7 * 12 * 150 * 8
        );
        assert_eq!(
            more(Footprint {
                rows_csv: true,
                ..f
            }),
            b * 7 * 420
        );
        // A grade more: its records, block sums, operator and two blocks of
        // outcomes.
        let outcome = std::mem::size_of::<Outcome>() as u128 + 15 * 8;
        assert_eq!(
            more(Footprint { grades: 8, ..f }),
            1_000_000 * 9 + 123 * (4 * 15 + 5 + 2) * 8 + (30 + 16 + 1) * 150 * 8 + b * 2 * outcome
        );
        // A grade recording its linearisation: two blocks of 15 numbers a
        // trial (one such slot is kept when none records).
        assert_eq!(more(Footprint { recorded: 3, ..f }), b * 2 * 2 * 15 * 8);
        // 39 errors more (a hexapod's 54): four block sums, two operator
        // rows a row of the observation, and two blocks of estimates and of
        // the linearisation's slot.
        assert_eq!(
            more(Footprint { errors: 54, ..f }),
            123 * 7 * 4 * 39 * 8 + 7 * 2 * 39 * 150 * 8 + b * (7 * 2 * 39 * 8 + 2 * 39 * 8)
        );
        // Nothing at all is the fixed 64 MiB (and the one slot).
        let none = Footprint {
            trials: 0,
            grades: 0,
            rows: 0,
            workers: 0,
            ..f
        };
        assert_eq!(none.bytes(), (64 << 20) + b * 2 * 15 * 8);
        // Each worker's draw buffers: a million samples of three noisy
        // quantised readings at 51 poses are 2.4 GB a worker.
        let draws = Footprint {
            jitter_draws: 1_000_000 * 3 * 51,
            workers: 64,
            ..f
        };
        let extra = draws.bytes() - f.bytes();
        assert_eq!(extra, 64 * 2 * 8 * 153_000_000);
        let avail = 16u128 << 30;
        let err = check_with(&draws, "this study", avail)
            .unwrap_err()
            .to_string();
        assert!(err.contains("fewer --threads"), "{err}");
        // Records, not draws: shards are the advice.
        let err = check_with(&big, "this study", avail)
            .unwrap_err()
            .to_string();
        assert!(err.contains("--shard"), "{err}");
        check_with(&f, "this study", avail).unwrap();
    }
}
