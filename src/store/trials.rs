//! The rows of `trials.csv`: its header, one row per calibration, and how
//! they are stored (plain or gzip). The runner formats them in parallel
//! with the [`RowEncoder`] of the format and hands them, in trial order, to
//! a [`TrialSink`]: the trials file ([`super::trials_file`]) or any writer
//! ([`WriterSink`]).

use crate::error::{Error, Result};
use crate::montecarlo::{Grade, Outcome, RowEncoder, TrialSink};
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
            TrialsFormat::Csv => super::names::TRIALS_CSV,
            TrialsFormat::Gzip => super::names::TRIALS_CSV_GZ,
        }
    }

    /// The header as stored.
    pub fn header(&self) -> Vec<u8> {
        self.encode(TRIALS_HEADER.as_bytes().to_vec())
    }

    /// Format and store rows (the runner calls it in parallel).
    pub fn encoder(&self) -> RowEncoder {
        match self {
            TrialsFormat::Csv => csv_rows,
            TrialsFormat::Gzip => gzip_rows,
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
/// writing (plain CSV: 12 s), level 6 in 0.88 GB for 73 s; see
/// docs/outputs.md, "sweep and merge".
const GZIP_LEVEL: u32 = 1;

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

/// Plain CSV rows into any writer (benchmarks, tools).
impl<W: Write + Send> TrialSink for WriterSink<W> {
    fn rows(&self) -> Option<RowEncoder> {
        Some(csv_rows)
    }
    fn write_header(&mut self) -> Result<()> {
        self.write(TRIALS_HEADER.as_bytes())
    }
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        self.writer
            .write_all(bytes)
            .map_err(|e| Error::io("write", &self.path, e))
    }
}

/// Header of trials.csv.
pub const TRIALS_HEADER: &str =
    "encoder_arcsec,scale_um,method,trial,mu,mu0,ratio,rank,failure,dv_after_max_mm,dv_after_mean_mm,dv_before_max_mm,dv_after_p95_mm,ap_after_max_mm,pose_count,encoder,scale,truth_amplitude,truth_extra_harmonic,truth\n";

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

/// The rows of consecutive trials as plain CSV.
fn csv_rows(rows: (&[Grade], &[String]), start: u64, outcomes: &[Outcome]) -> Vec<u8> {
    let mut buf = Vec::with_capacity(outcomes.len() * 64);
    format_rows(rows, start, outcomes, &mut buf);
    buf
}

/// The rows of consecutive trials as one gzip member.
fn gzip_rows(rows: (&[Grade], &[String]), start: u64, outcomes: &[Outcome]) -> Vec<u8> {
    TrialsFormat::Gzip.encode(csv_rows(rows, start, outcomes))
}

/// Append the rows of consecutive trials (`start` first).
/// `grades` with each one's trailing cells ([`crate::montecarlo::SweepContext::grade_cells`]).
pub fn format_rows(
    (grades, grade_cells): (&[Grade], &[String]),
    start: u64,
    outcomes: &[Outcome],
    buf: &mut Vec<u8>,
) {
    let g = grades.len();
    for (i, trial) in outcomes.chunks(g).enumerate() {
        let k = start + i as u64;
        for ((grade, o), cells) in grades.iter().zip(trial).zip(grade_cells) {
            // A machine forward kinematics failed for carries NaN in μ and
            // dV: empty cells, as any undefined number.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    /// A machine forward kinematics failed for: μ0 and the failure label,
    /// every undefined number an empty cell, the row as long as the header.
    #[test]
    fn a_failed_machines_row_has_empty_cells_where_nothing_is_known() {
        let cfg = Config::paper().unwrap();
        let study = cfg.study().trials(1).build().unwrap();
        let ctx = crate::montecarlo::tricept::TriceptContext::new(&cfg, &study).unwrap();
        let g = ctx.grades().len();
        let failed = vec![Outcome::forward_kinematics_failed(0.25); g];
        let text =
            String::from_utf8(csv_rows((ctx.grades(), ctx.grade_cells()), 7, &failed)).unwrap();
        let header = TRIALS_HEADER.trim_end().split(',').count();
        for line in text.lines() {
            let cells: Vec<&str> = line.split(',').collect();
            assert_eq!(cells.len(), header, "{line}");
            // trial, μ, μ0, ratio, rank, failure, the five dV columns
            let known = ["7", "", "0.25", "", "0", "fk_failed", "", "", "", "", ""];
            assert_eq!(cells[3..14], known, "{line}");
        }
        assert_eq!(text.lines().count(), g);
    }
}
