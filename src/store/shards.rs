//! The files of a sharded sweep as `merge` reads them: each shard's
//! `partial.bin` and trials file, checked against its `partial.json`, and
//! the trials files joined under one header.

use super::names::PARTIAL_BIN;
use super::partial;
use super::state::ShardInfo;
use super::trials::TrialsFormat;
use super::trials_file::TrialsFile;
use crate::error::{Error, Result};
use crate::montecarlo::{Partial, TrialSink, BLOCK_TRIALS};
use std::path::{Path, PathBuf};

/// Shard `info.shard`/`n`'s `partial.bin` in `dir`: refused unless it has
/// exactly the length and dimensions its partial.json and this study give
/// (`errors` a calibration).
pub fn read_partial(
    dir: &Path,
    info: &ShardInfo,
    n: u64,
    (grades, errors): (usize, usize),
    judged: (bool, bool),
) -> Result<Partial> {
    let p = dir.join(PARTIAL_BIN);
    let blocks = info.trial_count.div_ceil(BLOCK_TRIALS as u64);
    let expected = partial::encoded_len(
        info.trial_count,
        grades as u64,
        judged,
        blocks,
        errors as u64,
    );
    let len = std::fs::metadata(&p)
        .map_err(|e| Error::io("read", &p, e))?
        .len();
    let mut head = [0u8; 8];
    if std::fs::File::open(&p)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
        .is_ok()
        && partial::other_version(&head)
    {
        return Err(Error::Argument(format!(
            "{}: written by another build of tricept-calib (format {}): rerun shard {}/{n} with this one",
            p.display(),
            String::from_utf8_lossy(&head),
            info.shard
        )));
    }
    if len as u128 != expected {
        return Err(Error::Argument(format!(
            "{}: {len} bytes where shard {}/{n} of this study holds {expected}: truncated or not this study's",
            p.display(),
            info.shard
        )));
    }
    let bytes = std::fs::read(&p).map_err(|e| Error::io("read", &p, e))?;
    partial::decode(&bytes)
        .filter(|x| {
            x.first_trial == info.first_trial
                && x.trials == info.trial_count
                && x.grades == grades
                && (x.volumetric, x.oriented) == judged
                && x.errors == errors
                && x.blocks() as u64 == blocks
        })
        .ok_or_else(|| {
            Error::Argument(format!(
                "{}: truncated or does not match partial.json",
                p.display()
            ))
        })
}

/// Lines of a shard's trials.csv: header + one per calibration, each ended
/// by a newline (a truncated file is refused before anything is written).
pub fn check_trials_file(
    path: &Path,
    info: &ShardInfo,
    grades: u64,
    format: TrialsFormat,
) -> Result<()> {
    let expected_rows = info.trial_count * grades;
    let f = std::fs::File::open(path).map_err(|e| Error::io("read", path, e))?;
    // trials.csv.gz is read through its decompression: its rows are checked
    // as trials.csv's are, and a damaged stream is an error here.
    let raw: Box<dyn std::io::Read> = match format {
        TrialsFormat::Csv => Box::new(f),
        TrialsFormat::Gzip => Box::new(flate2::read::MultiGzDecoder::new(
            std::io::BufReader::with_capacity(1 << 20, f),
        )),
    };
    let mut r = std::io::BufReader::with_capacity(1 << 20, raw);
    let (mut lines, mut last) = (0u64, b'\n');
    // The trial column of the first and the last row.
    let mut first_row: Vec<u8> = Vec::new();
    let mut tail: Vec<u8> = Vec::new();
    loop {
        let buf = std::io::BufRead::fill_buf(&mut r).map_err(|e| match format {
            // A damaged stream is the shard's fault (bad input), not the disk's.
            TrialsFormat::Gzip => Error::Argument(format!(
                "{}: damaged gzip stream ({e}): the file is truncated or does not belong to this shard",
                path.display()
            )),
            TrialsFormat::Csv => Error::io("read", path, e),
        })?;
        if buf.is_empty() {
            break;
        }
        for &b in buf {
            if lines == 1 && b != b'\n' {
                first_row.push(b);
            }
            if b == b'\n' {
                lines += 1;
                if lines < expected_rows + 1 {
                    tail.clear();
                }
            } else if lines >= 1 {
                tail.push(b);
            }
        }
        last = buf[buf.len() - 1];
        let n = buf.len();
        std::io::BufRead::consume(&mut r, n);
    }
    let trial = |row: &[u8]| {
        std::str::from_utf8(row)
            .ok()
            .and_then(|r| r.split(',').nth(3))
            .and_then(|t| t.parse::<u64>().ok())
    };
    let ends = (trial(&first_row), trial(&tail));
    let want = (
        Some(info.first_trial),
        Some(info.first_trial + info.trial_count.saturating_sub(1)),
    );
    if last != b'\n' || lines != expected_rows + 1 || (expected_rows > 0 && ends != want) {
        return Err(Error::Argument(format!(
            "{}: {} complete lines where the shard holds {} calibrations (+1 header): the file is truncated or does not belong to this shard",
            path.display(),
            lines,
            expected_rows
        )));
    }
    Ok(())
}

/// The trials files of the shards, in order, under one header. A gzip
/// file's header is its first member, the same bytes in every shard: the
/// rest of each file is copied as it is.
pub fn concat_trials(dirs: &[&PathBuf], trials: &mut TrialsFile) -> Result<()> {
    if trials.rows().is_none() {
        return Ok(());
    }
    let format = trials.format();
    let header = format.header();
    trials.write(&header)?;
    for d in dirs {
        let p = d.join(format.file_name());
        let f = std::fs::File::open(&p).map_err(|e| Error::io("read", &p, e))?;
        let mut r = std::io::BufReader::new(f);
        let mut first = vec![0u8; header.len()];
        let whole = std::io::Read::read_exact(&mut r, &mut first).is_ok();
        if !whole || first != header {
            return Err(Error::Argument(format!(
                "{}: unexpected header",
                p.display()
            )));
        }
        let mut buf = vec![0u8; 1 << 20];
        loop {
            let n = std::io::Read::read(&mut r, &mut buf).map_err(|e| Error::io("read", &p, e))?;
            if n == 0 {
                break;
            }
            trials.write(&buf[..n])?;
        }
    }
    Ok(())
}
