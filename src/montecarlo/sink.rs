//! Where the per-calibration rows of `trials.csv` go: the runner formats
//! them (in parallel, merged in trial order) and hands them to a
//! [`TrialSink`] — a file, nothing (`--no-trials`), or memory (tests).

use super::outcome::{Failure, Outcome};
use super::trial::SweepContext;
use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How the per-calibration rows are stored: plain CSV, or the same CSV
/// gzip-compressed (`trials.csv.gz`), which pandas, polars and DuckDB read
/// directly. Each run of 256 trials' rows (and the header) is one gzip
/// member, compressed in parallel with the rows' formatting; a file of
/// members is one gzip stream to every reader, so shards concatenate and a
/// resumed run truncates at a block boundary exactly as with CSV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TrialsFormat {
    #[default]
    Csv,
    Gzip,
}

impl TrialsFormat {
    /// The names `--trials-format` takes.
    pub const NAMES: &'static str = "csv or gz";

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "csv" => Some(TrialsFormat::Csv),
            "gz" | "csv.gz" => Some(TrialsFormat::Gzip),
            _ => None,
        }
    }

    /// Its name in a manifest and a shard's metadata.
    pub fn name(&self) -> &'static str {
        match self {
            TrialsFormat::Csv => "csv",
            TrialsFormat::Gzip => "gz",
        }
    }

    /// The output file's name.
    pub fn file_name(&self) -> &'static str {
        match self {
            TrialsFormat::Csv => "trials.csv",
            TrialsFormat::Gzip => "trials.csv.gz",
        }
    }

    /// The bytes to store for `text` (CSV rows or the header): itself, or
    /// one gzip member of it (deterministic: the same text, the same bytes).
    pub fn encode(&self, text: Vec<u8>) -> Vec<u8> {
        match self {
            TrialsFormat::Csv => text,
            TrialsFormat::Gzip => {
                let mut z = flate2::write::GzEncoder::new(
                    Vec::with_capacity(text.len() / 4 + 64),
                    flate2::Compression::new(GZIP_LEVEL),
                );
                // Writing into memory cannot fail.
                let _ = z.write_all(&text);
                z.finish().unwrap_or_default()
            }
        }
    }
}

/// zlib level of trials.csv.gz. Measured on the shipped catalogue study
/// (2.8 GB of rows, 2 threads): level 1 stores them in 1.0 GB for 17 s of
/// writing (plain CSV: 12 s), level 6 in 0.88 GB for 73 s; see README
/// "Large outputs".
const GZIP_LEVEL: u32 = 1;

/// The destination of trials.csv rows.
/// Send: the runner writes one block while the pool computes the next.
pub trait TrialSink: Send {
    /// False: rows are not even formatted (`--no-trials`).
    fn wants_rows(&self) -> bool {
        true
    }
    /// How the rows are stored (plain CSV unless the sink says otherwise).
    fn format(&self) -> TrialsFormat {
        TrialsFormat::Csv
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
