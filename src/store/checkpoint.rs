//! The block log of an unsharded sweep: after every block the rows of
//! trials.csv are synced, then one record is appended and synced — the
//! length and FNV-1a hash of trials.csv so far, the block's [`Partial`], and
//! a hash of the record. A resumed run trusts a block only when its record
//! is whole, its hash matches and the trials.csv prefix it names hashes to
//! the recorded value; it continues after the last such block (same bytes
//! as an uninterrupted run) and recomputes the rest.

use super::partial::{decode, encode};
use crate::error::{Error, Result};
use crate::montecarlo::Partial;
use std::io::Write;
use std::path::{Path, PathBuf};

pub use crate::digest::{fnv1a, FNV_START};

/// What a previous run left, verified.
#[derive(Debug, Clone, PartialEq)]
pub struct Resume {
    pub partial: Partial,
    /// trials.csv length and hash after the last trusted block.
    pub trials_bytes: u64,
    pub trials_hash: u64,
}

/// An open block log, appended to after every block.
pub struct BlockLog {
    file: std::fs::File,
    path: PathBuf,
}

impl BlockLog {
    /// A new, empty log.
    pub fn create(path: &Path) -> Result<Self> {
        let file = std::fs::File::create(path).map_err(|e| Error::io("create", path, e))?;
        Ok(BlockLog {
            file,
            path: path.to_path_buf(),
        })
    }

    /// An existing log, continued after its first `len` bytes.
    pub fn reopen(path: &Path, len: u64) -> Result<Self> {
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| Error::io("reopen", path, e))?;
        file.set_len(len)
            .and_then(|_| std::io::Seek::seek(&mut file, std::io::SeekFrom::End(0)))
            .map_err(|e| Error::io("reopen", path, e))?;
        Ok(BlockLog {
            file,
            path: path.to_path_buf(),
        })
    }

    /// Append one block's record and make it durable.
    pub fn append(&mut self, trials_bytes: u64, trials_hash: u64, part: &Partial) -> Result<()> {
        let buf = record(trials_bytes, trials_hash, part);
        self.file
            .write_all(&buf)
            .and_then(|_| self.file.sync_data())
            .map_err(|e| Error::io("write", &self.path, e))
    }
}

/// One intact record of a block log.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub partial: Partial,
    pub trials_bytes: u64,
    pub trials_hash: u64,
    /// Length of the log up to the end of this record.
    pub log_len: u64,
}

/// The bytes appended to the log after a block.
pub fn record(trials_bytes: u64, trials_hash: u64, part: &Partial) -> Vec<u8> {
    let rec = encode(part);
    let mut buf = Vec::with_capacity(rec.len() + 32);
    buf.extend_from_slice(&trials_bytes.to_le_bytes());
    buf.extend_from_slice(&trials_hash.to_le_bytes());
    buf.extend_from_slice(&(rec.len() as u64).to_le_bytes());
    buf.extend_from_slice(&rec);
    let h = fnv1a(FNV_START, &buf);
    buf.extend_from_slice(&h.to_le_bytes());
    buf
}

/// The intact records of a block log, in order: reading stops at the
/// first incomplete or damaged record, or one that does not continue
/// the trials before it (the first must start at trial 0, and every
/// record must have `grades` grades and the same volumetric flag, and
/// the errors and orientation flag of the records before it).
pub fn read(bytes: &[u8], grades: usize, volumetric: bool) -> Vec<Block> {
    let mut out: Vec<Block> = Vec::new();
    let mut pos = 0usize;
    let u64_at = |p: usize| -> Option<u64> {
        Some(u64::from_le_bytes(bytes.get(p..p + 8)?.try_into().ok()?))
    };
    while let (Some(tb), Some(th), Some(len)) = (u64_at(pos), u64_at(pos + 8), u64_at(pos + 16)) {
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| (pos + 24).checked_add(l))
            .filter(|e| e.checked_add(8).is_some_and(|x| x <= bytes.len()))
        else {
            break;
        };
        let (Some(rec), Some(h)) = (bytes.get(pos + 24..end), u64_at(end)) else {
            break;
        };
        if fnv1a(FNV_START, &bytes[pos..end]) != h {
            break;
        }
        let Some(part) = decode(rec) else {
            break;
        };
        let follows = part.grades == grades
            && part.volumetric == volumetric
            && out.last().is_none_or(|b| {
                (b.partial.errors, b.partial.oriented) == (part.errors, part.oriented)
            })
            && match out.last() {
                Some(b) => b.partial.first_trial + b.partial.trials == part.first_trial,
                None => part.first_trial == 0,
            };
        if !follows {
            break;
        }
        pos = end + 8;
        out.push(Block {
            partial: part,
            trials_bytes: tb,
            trials_hash: th,
            log_len: pos as u64,
        });
    }
    out
}

/// How many of the intact blocks the trials.csv prefix confirms: each block
/// names the length and hash of trials.csv after it, and the part file must
/// hold exactly those bytes (a missing, truncated or altered file confirms
/// fewer, and those blocks are computed again).
pub fn trusted_blocks(blocks: &[Block], part: &Path, with_rows: bool) -> usize {
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
pub fn join_blocks(blocks: &[Block]) -> Option<(Resume, u64)> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::Outcome;

    fn part(first: u64) -> Partial {
        let mut p = Partial {
            first_trial: first,
            grades: 1,
            errors: 2,
            rank: vec![14],
            ..Default::default()
        };
        let err = [1e-3, -2e-3, 1e-3, -2e-3];
        p.push_block(&[Outcome::default(), Outcome::default()], &err, &[], &[]);
        p
    }

    #[test]
    fn damaged_or_truncated_records_are_not_trusted() {
        let mut log = record(10, 77, &part(0));
        let one = log.len();
        log.extend(record(20, 88, &part(2)));
        assert!(read(&log, 2, false).is_empty(), "wrong grades");
        let blocks = read(&log, 1, false);
        assert_eq!(blocks.len(), 2);
        assert_eq!((blocks[1].trials_bytes, blocks[1].trials_hash), (20, 88));
        assert_eq!(blocks[1].log_len as usize, log.len());
        // Truncated anywhere in the second record: only the first is trusted.
        for cut in [one + 1, one + 30, log.len() - 1] {
            assert_eq!(read(&log[..cut], 1, false).len(), 1);
        }
        // One flipped bit in the second record's body.
        let mut flipped = log.clone();
        flipped[one + 40] ^= 0x10;
        assert_eq!(read(&flipped, 1, false).len(), 1);
        // Zero padding (a file extended by set_len) is not a record.
        let mut padded = log[..one].to_vec();
        padded.extend(vec![0u8; 64]);
        assert_eq!(read(&padded, 1, false).len(), 1);
        // A record that does not follow the one before.
        let mut gap = log[..one].to_vec();
        gap.extend(record(30, 99, &part(5)));
        assert_eq!(read(&gap, 1, false).len(), 1);
    }

    /// A resumable run's trials file and block log after two blocks, as
    /// the runner leaves them: (trials file, block log).
    fn logged_run(dir: &Path) -> (PathBuf, PathBuf) {
        use super::super::trials::TrialsFormat;
        use super::super::trials_file::TrialsFile;
        use crate::montecarlo::TrialSink;
        let (tmp, log) = (dir.join("trials.csv.part"), dir.join("blocks.bin"));
        let mut t = TrialsFile::at(
            tmp.clone(),
            dir.join("trials.csv"),
            true,
            None,
            true,
            TrialsFormat::Csv,
        )
        .unwrap();
        assert!(
            !t.logs_blocks(),
            "no log, no records: a shard's trials file"
        );
        t.log_to(BlockLog::create(&log).unwrap());
        assert!(t.logs_blocks());
        t.write_header().unwrap();
        t.write(b"0,a\n1,b\n").unwrap();
        t.log_block(&part(0)).unwrap();
        t.write(b"2,c\n3,d\n").unwrap();
        t.log_block(&part(2)).unwrap();
        t.finish().unwrap();
        (tmp, log)
    }

    #[test]
    fn the_trials_file_confirms_only_the_blocks_whose_rows_it_holds() {
        let d = tempfile::tempdir().unwrap();
        let (trials, log) = logged_run(d.path());
        let rows = std::fs::read(&trials).unwrap();
        let blocks = read(&std::fs::read(&log).unwrap(), 1, false);
        assert_eq!(blocks.len(), 2);
        // Each record names the length and hash of the rows up to its block.
        let after_first = rows.len() - 8;
        assert_eq!(blocks[0].trials_bytes as usize, after_first);
        assert_eq!(
            blocks[0].trials_hash,
            fnv1a(FNV_START, &rows[..after_first])
        );
        assert_eq!(blocks[1].trials_bytes as usize, rows.len());
        assert_eq!(blocks[1].trials_hash, fnv1a(FNV_START, &rows));
        assert_eq!(trusted_blocks(&blocks, &trials, true), 2);
        // Without rows only the log counts; without the file nothing does.
        assert_eq!(trusted_blocks(&blocks, &d.path().join("none"), false), 2);
        assert_eq!(trusted_blocks(&blocks, &d.path().join("none"), true), 0);
        // A file cut inside the second block, or altered in it.
        std::fs::write(&trials, &rows[..rows.len() - 1]).unwrap();
        assert_eq!(trusted_blocks(&blocks, &trials, true), 1);
        let mut altered = rows.clone();
        altered[after_first + 1] ^= 1;
        std::fs::write(&trials, &altered).unwrap();
        assert_eq!(trusted_blocks(&blocks, &trials, true), 1);
        // Longer than the log says: the blocks it names are still whole.
        let mut longer = rows.clone();
        longer.extend(b"4,e\n");
        std::fs::write(&trials, &longer).unwrap();
        assert_eq!(trusted_blocks(&blocks, &trials, true), 2);
        let (resume, log_len) = join_blocks(&blocks).unwrap();
        assert_eq!(log_len, blocks[1].log_len);
        assert_eq!(
            (resume.trials_bytes, resume.partial.trials),
            (rows.len() as u64, 4)
        );
        assert_eq!(resume.partial.first_trial, 0);
        assert!(join_blocks(&[]).is_none());
    }

    #[test]
    fn fnv1a_matches_the_reference_values() {
        assert_eq!(fnv1a(FNV_START, b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(FNV_START, b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(
            fnv1a(fnv1a(FNV_START, b"foo"), b"bar"),
            fnv1a(FNV_START, b"foobar")
        );
    }
}
