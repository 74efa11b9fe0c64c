//! Where the per-calibration rows of `trials.csv` go: the runner formats
//! them (in parallel, merged in trial order) and hands them to a
//! [`TrialSink`] — a file, nothing (`--no-trials`), or memory (tests).

use super::trial::{Failure, Outcome, SweepContext};
use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The destination of trials.csv rows.
/// Send: the runner writes one block while the pool computes the next.
pub trait TrialSink: Send {
    /// False: rows are not even formatted (`--no-trials`).
    fn wants_rows(&self) -> bool {
        true
    }
    /// Append bytes (the header, then whole blocks of rows in trial order).
    fn write(&mut self, bytes: &[u8]) -> Result<()>;
    /// Push what was written to the file.
    fn flush(&mut self) -> Result<()>;
    /// Flush and make what was written durable (before a block is logged
    /// as done); the default only flushes.
    fn sync(&mut self) -> Result<()> {
        self.flush()
    }
}

/// No trials.csv.
pub struct NoRows;

impl TrialSink for NoRows {
    fn wants_rows(&self) -> bool {
        false
    }
    fn write(&mut self, _: &[u8]) -> Result<()> {
        Ok(())
    }
    fn flush(&mut self) -> Result<()> {
        Ok(())
    }
}

/// Rows into any writer; errors name `path`.
pub struct WriterSink<W: Write> {
    pub writer: W,
    pub path: PathBuf,
}

impl<W: Write> WriterSink<W> {
    pub fn new(writer: W, path: &Path) -> Self {
        WriterSink {
            writer,
            path: path.to_path_buf(),
        }
    }
}

impl<W: Write + Send> TrialSink for WriterSink<W> {
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        self.writer
            .write_all(bytes)
            .map_err(|e| Error::io("write", &self.path, e))
    }
    fn flush(&mut self) -> Result<()> {
        self.writer
            .flush()
            .map_err(|e| Error::io("write", &self.path, e))
    }
}

/// Rows kept in memory.
#[derive(Default)]
pub struct MemorySink(pub Vec<u8>);

impl TrialSink for MemorySink {
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        self.0.extend_from_slice(bytes);
        Ok(())
    }
    fn flush(&mut self) -> Result<()> {
        Ok(())
    }
}

/// Header of trials.csv.
pub const TRIALS_HEADER: &str =
    "encoder_arcsec,scale_um,method,trial,mu,mu0,ratio,rank,failure,dv_after_max_mm,dv_after_mean_mm,dv_before_max_mm,dv_after_p95_mm,ap_after_max_mm,pose_count,encoder,scale,truth_amplitude,truth_extra_harmonic\n";

/// A finite number, or an empty cell.
struct Cell(f64);

impl std::fmt::Display for Cell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.0.is_finite() {
            Ok(())
        } else {
            write!(f, "{}", self.0)
        }
    }
}

pub fn format_rows(ctx: &SweepContext, start: u64, outcomes: &[Outcome], buf: &mut Vec<u8>) {
    let g = ctx.grades.len();
    for (i, trial) in outcomes.chunks(g).enumerate() {
        let k = start + i as u64;
        for ((grade, o), cells) in ctx.grades.iter().zip(trial).zip(&ctx.grade_cells) {
            if o.failure == Failure::ForwardKinematics {
                let _ = writeln!(
                    buf,
                    "{},{},{},{},,{},,{},{},,,,,{cells}",
                    grade.encoder_arcsec,
                    grade.scale_um,
                    grade.method.name(),
                    k,
                    Cell(o.mu0),
                    o.rank,
                    o.failure.label()
                );
            } else {
                let _ = writeln!(
                    buf,
                    "{},{},{},{},{},{},{},{},{},{},{},{},{},{}{cells}",
                    grade.encoder_arcsec,
                    grade.scale_um,
                    grade.method.name(),
                    k,
                    Cell(o.mu),
                    Cell(o.mu0),
                    Cell(o.mu / o.mu0),
                    o.rank,
                    o.failure.label(),
                    Cell(o.dv_after_max),
                    Cell(o.dv_after_mean),
                    Cell(o.dv_before_max),
                    Cell(o.dv_after_p95),
                    Cell(o.ap_after_max)
                );
            }
        }
    }
}
