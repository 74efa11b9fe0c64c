//! The block log of an unsharded sweep: after every block the rows of
//! trials.csv are synced, then one record is appended and synced — the
//! length and FNV-1a hash of trials.csv so far, the block's [`Partial`], and
//! a hash of the record. A resumed run trusts a block only when its record
//! is whole, its hash matches and the trials.csv prefix it names hashes to
//! the recorded value; it continues after the last such block (same bytes
//! as an uninterrupted run) and recomputes the rest.

use super::partial::Partial;

pub use crate::digest::{fnv1a, FNV_START};

/// What a previous run left, verified.
#[derive(Debug, Clone, PartialEq)]
pub struct Resume {
    pub partial: Partial,
    /// trials.csv length and hash after the last trusted block.
    pub trials_bytes: u64,
    pub trials_hash: u64,
}

/// An open block log.
pub struct Checkpoint {
    pub file: std::fs::File,
    pub path: std::path::PathBuf,
    pub resume: Option<Resume>,
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

impl Checkpoint {
    /// The bytes appended to the log after a block.
    pub fn record(trials_bytes: u64, trials_hash: u64, part: &Partial) -> Vec<u8> {
        let rec = part.to_bytes();
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
    /// record must have `grades` grades and the same volumetric flag).
    pub fn read(bytes: &[u8], grades: usize, volumetric: bool) -> Vec<Block> {
        let mut out: Vec<Block> = Vec::new();
        let mut pos = 0usize;
        let u64_at = |p: usize| -> Option<u64> {
            Some(u64::from_le_bytes(bytes.get(p..p + 8)?.try_into().ok()?))
        };
        while let (Some(tb), Some(th), Some(len)) = (u64_at(pos), u64_at(pos + 8), u64_at(pos + 16))
        {
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
            let Some(part) = Partial::from_bytes(rec) else {
                break;
            };
            let follows = part.grades == grades
                && part.volumetric == volumetric
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::trial::Outcome;

    fn part(first: u64) -> Partial {
        let mut p = Partial {
            first_trial: first,
            grades: 1,
            rank: vec![14],
            ..Default::default()
        };
        p.push_block(&[Outcome::default(), Outcome::default()]);
        p
    }

    #[test]
    fn damaged_or_truncated_records_are_not_trusted() {
        let mut log = Checkpoint::record(10, 77, &part(0));
        let one = log.len();
        log.extend(Checkpoint::record(20, 88, &part(2)));
        assert!(Checkpoint::read(&log, 2, false).is_empty(), "wrong grades");
        let blocks = Checkpoint::read(&log, 1, false);
        assert_eq!(blocks.len(), 2);
        assert_eq!((blocks[1].trials_bytes, blocks[1].trials_hash), (20, 88));
        assert_eq!(blocks[1].log_len as usize, log.len());
        // Truncated anywhere in the second record: only the first is trusted.
        for cut in [one + 1, one + 30, log.len() - 1] {
            assert_eq!(Checkpoint::read(&log[..cut], 1, false).len(), 1);
        }
        // One flipped bit in the second record's body.
        let mut flipped = log.clone();
        flipped[one + 40] ^= 0x10;
        assert_eq!(Checkpoint::read(&flipped, 1, false).len(), 1);
        // Zero padding (a file extended by set_len) is not a record.
        let mut padded = log[..one].to_vec();
        padded.extend(vec![0u8; 64]);
        assert_eq!(Checkpoint::read(&padded, 1, false).len(), 1);
        // A record that does not follow the one before.
        let mut gap = log[..one].to_vec();
        gap.extend(Checkpoint::record(30, 99, &part(5)));
        assert_eq!(Checkpoint::read(&gap, 1, false).len(), 1);
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
