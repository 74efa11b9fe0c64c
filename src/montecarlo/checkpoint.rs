//! The block log of an unsharded sweep: after every block, the bytes of
//! trials.csv written so far and the block's [`Partial`] record are appended,
//! so a killed run can continue from its last complete block and still
//! produce the same bytes.

use super::partial::Partial;

/// An open block log.
pub struct Checkpoint {
    pub file: std::fs::File,
    pub path: std::path::PathBuf,
    /// Records and trials.csv length recovered from a previous run.
    pub resume: Option<(Partial, u64)>,
}

impl Checkpoint {
    /// Read a block log: the concatenated records of its complete blocks, the
    /// trials.csv length after the last of them, and the log's length up to
    /// there (None if it has no complete block).
    pub fn read(bytes: &[u8]) -> Option<(Partial, u64, u64)> {
        let mut pos = 0usize;
        let mut acc: Option<Partial> = None;
        let mut trials_bytes = 0;
        while pos + 16 <= bytes.len() {
            let tb = u64::from_le_bytes(bytes[pos..pos + 8].try_into().ok()?);
            let len = u64::from_le_bytes(bytes[pos + 8..pos + 16].try_into().ok()?) as usize;
            let Some(rec) = bytes.get(pos + 16..pos + 16 + len) else {
                break;
            };
            let Some(part) = Partial::from_bytes(rec) else {
                break;
            };
            match acc.as_mut() {
                Some(a) if a.first_trial + a.trials == part.first_trial => a.append(&part),
                Some(_) => break,
                None => acc = Some(part),
            }
            trials_bytes = tb;
            pos += 16 + len;
        }
        acc.map(|a| (a, trials_bytes, pos as u64))
    }
}
