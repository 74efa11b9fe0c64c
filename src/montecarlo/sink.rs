//! Where a run keeps its results as it goes: the runner hands the trials
//! file's rows and each block's records, in trial order, to a [`TrialSink`].
//! The files behind it (trials.csv, the block log of `--resume`) are
//! `store`'s; [`NoRows`] keeps nothing.

use super::context::Grade;
use super::outcome::Outcome;
use super::partial::Partial;
use crate::error::Result;

/// Formats the rows of consecutive trials (`start` first; outcomes
/// trial-major, grade-minor) of a study's grades, each with its trailing
/// cells ([`super::SweepContext::grade_cells`]), and encodes them as they
/// are stored. Called in parallel, on runs of [`ROWS_PER_RUN`] trials.
pub type RowEncoder = fn((&[Grade], &[String]), u64, &[Outcome]) -> Vec<u8>;

/// Trials whose rows are formatted and encoded together (one gzip member
/// of trials.csv.gz).
pub const ROWS_PER_RUN: usize = 256;

/// The destination of a run's rows and block records.
/// Send: the runner writes one block while the pool computes the next.
pub trait TrialSink: Send {
    /// How rows are encoded; None: they are not even formatted
    /// (`--no-trials`).
    fn rows(&self) -> Option<RowEncoder>;
    /// Write the header (a new run; a resumed one continues after its rows).
    fn write_header(&mut self) -> Result<()>;
    /// Append encoded rows: whole runs of trials, in trial order.
    fn write(&mut self, bytes: &[u8]) -> Result<()>;
    /// Is every block logged (a resumable run)? Then each block's records
    /// go to [`TrialSink::log_block`] after its rows.
    fn logs_blocks(&self) -> bool {
        false
    }
    /// Make the rows written so far durable, then log `block` durably.
    fn log_block(&mut self, _block: &Partial) -> Result<()> {
        Ok(())
    }
}

/// No trials file, no block log.
pub struct NoRows;

impl TrialSink for NoRows {
    fn rows(&self) -> Option<RowEncoder> {
        None
    }
    fn write_header(&mut self) -> Result<()> {
        Ok(())
    }
    fn write(&mut self, _: &[u8]) -> Result<()> {
        Ok(())
    }
}
