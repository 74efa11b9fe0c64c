//! The trials file of a run: written under a temporary name (in a
//! resumable run, inside its state folder) and renamed with the other
//! outputs only on success. It is the runner's [`TrialSink`]; in a
//! resumable run it also keeps the length and hash of its rows for the
//! block log.

use super::checkpoint::{fnv1a, BlockLog, Resume, FNV_START};
use super::trials::TrialsFormat;
use crate::error::{Error, Result};
use crate::io;
use crate::montecarlo::{Partial, RowEncoder, TrialSink};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A temporary trials.csv that becomes `final_path` only on success.
pub struct TrialsFile {
    tmp: PathBuf,
    final_path: PathBuf,
    w: Option<std::io::BufWriter<std::fs::File>>,
    /// Keep the temporary file when dropped (resumable runs).
    keep: bool,
    format: TrialsFormat,
    /// The block log of a resumable run, and the length and FNV-1a hash of
    /// the rows written so far, which each of its records names.
    log: Option<BlockLog>,
    bytes: u64,
    hash: u64,
}

impl TrialsFile {
    pub fn new(out: &Path, enabled: bool, format: TrialsFormat) -> Result<Self> {
        let name = format.file_name();
        let tmp = out.join(format!(".{name}.tmp-{}", std::process::id()));
        Self::at(tmp, out.join(name), enabled, None, false, format)
    }

    /// The file's final name (trials.csv or trials.csv.gz).
    pub fn file_name(&self) -> &'static str {
        self.format.file_name()
    }

    /// The file's format.
    pub fn format(&self) -> TrialsFormat {
        self.format
    }

    /// At a given temporary path; `resume`: keep the bytes of an existing
    /// file that a previous run's block log confirms and append after them.
    pub(super) fn at(
        tmp: PathBuf,
        final_path: PathBuf,
        enabled: bool,
        resume: Option<&Resume>,
        keep: bool,
        format: TrialsFormat,
    ) -> Result<Self> {
        let w = if enabled {
            let f = match resume.map(|r| r.trials_bytes) {
                Some(len) => {
                    let f = std::fs::OpenOptions::new()
                        .write(true)
                        .open(&tmp)
                        .map_err(|e| Error::io("reopen", &tmp, e))?;
                    f.set_len(len).map_err(|e| Error::io("truncate", &tmp, e))?;
                    let mut f = f;
                    std::io::Seek::seek(&mut f, std::io::SeekFrom::End(0))
                        .map_err(|e| Error::io("reopen", &tmp, e))?;
                    f
                }
                None => std::fs::File::create(&tmp).map_err(|e| Error::io("create", &tmp, e))?,
            };
            Some(std::io::BufWriter::with_capacity(1 << 20, f))
        } else {
            None
        };
        let (bytes, hash) = resume.map_or((0, FNV_START), |r| (r.trials_bytes, r.trials_hash));
        Ok(TrialsFile {
            tmp,
            final_path,
            w,
            keep,
            format,
            log: None,
            bytes,
            hash,
        })
    }

    /// Log every block to `log` (a resumable run).
    pub(super) fn log_to(&mut self, log: BlockLog) {
        self.log = Some(log);
    }
    /// Flush and sync, and close the block log; the rename happens in
    /// [`TrialsFile::commit`].
    pub fn finish(&mut self) -> Result<()> {
        self.log = None;
        if let Some(w) = self.w.take() {
            let f = w
                .into_inner()
                .map_err(|e| Error::io("write", &self.final_path, e.into_error()))?;
            f.sync_all()
                .map_err(|e| Error::io("write", &self.final_path, e))?;
        }
        Ok(())
    }
    pub fn commit(&self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.final_path)
            .map_err(|e| Error::io("write", &self.final_path, e))
    }

    /// Hand the finished file to a set of outputs, renamed with them.
    pub fn commit_with(&self, outputs: &mut io::Outputs) {
        outputs.add_ready(self.tmp.clone(), self.final_path.clone());
    }
}

impl TrialSink for TrialsFile {
    fn rows(&self) -> Option<RowEncoder> {
        self.w.as_ref().map(|_| self.format.encoder())
    }
    fn write_header(&mut self) -> Result<()> {
        match self.w {
            Some(_) => self.write(&self.format.header()),
            None => Ok(()),
        }
    }
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        let Some(w) = self.w.as_mut() else {
            return Ok(());
        };
        w.write_all(bytes)
            .map_err(|e| Error::io("write", &self.final_path, e))?;
        self.bytes += bytes.len() as u64;
        if self.log.is_some() {
            self.hash = fnv1a(self.hash, bytes);
        }
        Ok(())
    }
    fn logs_blocks(&self) -> bool {
        self.log.is_some()
    }
    /// Rows first (on disk), then the block's record (on disk).
    fn log_block(&mut self, block: &Partial) -> Result<()> {
        self.sync()?;
        let (bytes, hash) = (self.bytes, self.hash);
        match self.log.as_mut() {
            Some(log) => log.append(bytes, hash, block)?,
            None => return Ok(()),
        }
        self.pause_for_tests();
        Ok(())
    }
}

impl TrialsFile {
    /// The test hook of the kill/resume tests: with
    /// `TRICEPT_CALIB_TEST_PAUSE_AFTER_BLOCKS=N` in the environment, once N
    /// blocks are durable in the block log the run writes `paused` beside
    /// it and waits to be killed — so a test kills it at a known block,
    /// never in a race with the run finishing first.
    fn pause_for_tests(&self) {
        use std::sync::atomic::{AtomicU64, Ordering};
        static LOGGED: AtomicU64 = AtomicU64::new(0);
        let Some(n) = std::env::var("TRICEPT_CALIB_TEST_PAUSE_AFTER_BLOCKS")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
        else {
            return;
        };
        if LOGGED.fetch_add(1, Ordering::SeqCst) + 1 < n {
            return;
        }
        if let Some(dir) = self.tmp.parent() {
            let _ = std::fs::write(dir.join(super::names::PAUSED_MARKER), b"");
        }
        loop {
            std::thread::sleep(std::time::Duration::from_secs(3600));
        }
    }

    /// Flush and make the rows durable.
    fn sync(&mut self) -> Result<()> {
        match self.w.as_mut() {
            Some(w) => w
                .flush()
                .and_then(|_| w.get_ref().sync_data())
                .map_err(|e| Error::io("write", &self.final_path, e)),
            None => Ok(()),
        }
    }
}

impl Drop for TrialsFile {
    fn drop(&mut self) {
        // Left only when something failed before commit.
        if !self.keep {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}
