//! Writing outputs. Regular files are written to a temporary name and
//! renamed into place, so a half-written file never carries a final name.
//! A special file is never replaced: character and block devices, pipes and
//! sockets are written through, a symlink's target is written (atomically
//! when it is a regular file), and `-` is stdout. A command's output
//! directory is held with an advisory lock for the whole run, and a run
//! removes the outputs of an earlier run that it does not write again, so
//! the directory holds one run's files.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How one output path is written.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Target {
    /// Temporary file beside it, then rename (regular file or new name).
    Atomic(PathBuf),
    /// Open and write (device, pipe, socket, a special symlink target).
    Through(PathBuf),
    /// `-`.
    Stdout,
}

fn classify(path: &Path) -> Result<Target> {
    if path.as_os_str() == "-" {
        return Ok(Target::Stdout);
    }
    // /dev/stdout, /proc/self/fd/N and the like: never rename over them.
    if path.starts_with("/dev") || path.starts_with("/proc") {
        return match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => Err(Error::Argument(format!(
                "{} is a directory; give a file name for this output",
                path.display()
            ))),
            _ => Ok(Target::Through(path.to_path_buf())),
        };
    }
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(Target::Atomic(path.to_path_buf()))
        }
        Err(e) => return Err(Error::io("inspect", path, e)),
    };
    let ft = meta.file_type();
    if ft.is_dir() {
        return Err(Error::Argument(format!(
            "{} is a directory; give a file name for this output",
            path.display()
        )));
    }
    if ft.is_file() {
        return Ok(Target::Atomic(path.to_path_buf()));
    }
    if ft.is_symlink() {
        // Write the target, never the link. A regular target is replaced
        // atomically at its real path, unless it lives under /proc or /dev
        // (/dev/stdout and friends), which are written through.
        return match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => Err(Error::Argument(format!(
                "{} points to a directory; give a file name for this output",
                path.display()
            ))),
            Ok(m) if m.is_file() => match std::fs::canonicalize(path) {
                Ok(real) if !real.starts_with("/proc") && !real.starts_with("/dev") => {
                    Ok(Target::Atomic(real))
                }
                _ => Ok(Target::Through(path.to_path_buf())),
            },
            Ok(_) => Ok(Target::Through(path.to_path_buf())),
            // A dangling link: create its target (a loop is an error).
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => match std::fs::read_link(path) {
                Ok(t) => {
                    let t = path.parent().map(|p| p.join(&t)).unwrap_or(t);
                    Ok(Target::Atomic(t))
                }
                Err(e) => Err(Error::io("inspect", path, e)),
            },
            Err(e) => Err(Error::io("follow the link", path, e)),
        };
    }
    Ok(Target::Through(path.to_path_buf()))
}

fn tmp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Write and sync a temporary file beside `path`; returns its name.
fn write_tmp(path: &Path, bytes: &[u8]) -> std::io::Result<PathBuf> {
    let tmp = tmp_name(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })();
    match result {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

fn write_through(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .truncate(true)
        .open(path)
        .map_err(|e| Error::io("open", path, e))?;
    f.write_all(bytes)
        .and_then(|_| f.flush())
        .map_err(|e| Error::io("write", path, e))
}

fn write_stdout(bytes: &[u8]) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)
        .and_then(|_| out.flush())
        .map_err(|e| Error::io("write", "<stdout>", e))
}

/// Does writing `path` write this process's stdout (`-`, /dev/stdout,
/// /dev/fd/1, /proc/self/fd/1)? Messages then go to stderr.
pub fn is_stdout(path: &Path) -> bool {
    ["-", "/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]
        .iter()
        .any(|p| path.as_os_str() == *p)
}

/// Write one output file: atomically when it is (or will be) a regular file,
/// through when it is a device, pipe or socket, to stdout for `-`.
pub fn write_output(path: &Path, bytes: &[u8]) -> Result<()> {
    match classify(path)? {
        Target::Atomic(p) => {
            let tmp = write_tmp(&p, bytes).map_err(|e| Error::io("write", path, e))?;
            std::fs::rename(&tmp, &p).map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                Error::io("write", path, e)
            })
        }
        Target::Through(p) => write_through(&p, bytes),
        Target::Stdout => write_stdout(bytes),
    }
}

/// An output directory held for one run (advisory `flock` on
/// `DIR/.tricept-calib.lock`, released when dropped or when the process ends).
#[derive(Debug)]
pub struct DirLock {
    _file: std::fs::File,
    path: PathBuf,
}

impl DirLock {
    pub fn dir(&self) -> &Path {
        &self.path
    }
}

/// Create an output directory (and parents), check that it is writable and
/// hold it: a second run into the same directory is refused (exit 2).
pub fn claim_dir(dir: &Path) -> Result<DirLock> {
    if let Ok(m) = std::fs::metadata(dir) {
        if !m.is_dir() {
            return Err(Error::Argument(format!(
                "{} is not a directory: --out needs a directory for this command",
                dir.display()
            )));
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io("create the output directory", dir, e))?;
    let lock_path = dir.join(".tricept-calib.lock");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| Error::io("write into the output directory", dir, e))?;
    #[cfg(unix)]
    {
        use std::os::unix::io::AsRawFd;
        // SAFETY: flock on a file descriptor we own; no memory is shared.
        let rc = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if rc != 0 {
            let e = std::io::Error::last_os_error();
            if e.kind() == std::io::ErrorKind::WouldBlock {
                return Err(Error::Argument(format!(
                    "{} is in use by another tricept-calib run; wait for it or choose another --out",
                    dir.display()
                )));
            }
            return Err(Error::io("lock the output directory", dir, e));
        }
    }
    remove_orphans(dir);
    Ok(DirLock {
        _file: file,
        path: dir.to_path_buf(),
    })
}

/// Temporary files (`.NAME.tmp-PID`) a killed run left in a directory we
/// now hold: nobody else can be writing them.
fn remove_orphans(dir: &Path) {
    let mine = format!(".tmp-{}", std::process::id());
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let orphan = name.starts_with('.')
            && name
                .rsplit_once(".tmp-")
                .is_some_and(|(_, pid)| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()));
        if orphan && !name.ends_with(&mine) && e.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// The output files of one run, rendered in memory, written as a unit:
/// every temporary file is written and synced first (a failure leaves the
/// directory as it was), then the earlier run's outputs this run does not
/// write are removed, then the files are renamed into place in the order
/// they were added (the manifest last).
#[derive(Default)]
pub struct Outputs {
    files: Vec<(PathBuf, Vec<u8>)>,
    /// Files already written and synced at a temporary path: (tmp, final).
    ready: Vec<(PathBuf, PathBuf)>,
    stale: Vec<PathBuf>,
}

impl Outputs {
    pub fn add(&mut self, path: PathBuf, bytes: Vec<u8>) {
        self.files.push((path, bytes));
    }

    /// A file the run streamed to `tmp` (written and synced), renamed to
    /// `path` with the others, before them.
    pub fn add_ready(&mut self, tmp: PathBuf, path: PathBuf) {
        self.ready.push((tmp, path));
    }

    /// Remove `dir/name` for each of a command's possible output names
    /// that this run does not write (only regular files are removed).
    pub fn replace_all(&mut self, dir: &Path, names: &[&str]) {
        self.stale.extend(names.iter().map(|n| dir.join(n)));
    }

    pub fn write(self) -> Result<Vec<PathBuf>> {
        // A streamed file goes where any output would: renamed onto a
        // regular file or a symlink's regular target, copied through a
        // special file (device, pipe, a symlink to one), never renamed over it.
        let mut staged = Vec::new();
        let mut streamed_through = Vec::new();
        for (tmp, path) in &self.ready {
            match classify(path)? {
                Target::Atomic(real) => staged.push((tmp.clone(), real)),
                t => streamed_through.push((tmp.clone(), t)),
            }
        }
        let mut later = Vec::new();
        let n_ready = staged.len();
        let cleanup = |staged: &[(PathBuf, PathBuf)]| {
            // Streamed files stay where they are (a resumable run needs them).
            for (tmp, _) in staged.iter().skip(n_ready) {
                let _ = std::fs::remove_file(tmp);
            }
        };
        for (p, b) in &self.files {
            match classify(p) {
                Ok(Target::Atomic(real)) => match write_tmp(&real, b) {
                    Ok(tmp) => staged.push((tmp, real)),
                    Err(e) => {
                        cleanup(&staged);
                        return Err(Error::io("write", p, e));
                    }
                },
                Ok(t) => later.push((t, b)),
                Err(e) => {
                    cleanup(&staged);
                    return Err(e);
                }
            }
        }
        for s in &self.stale {
            let written =
                self.files.iter().any(|(p, _)| p == s) || self.ready.iter().any(|(_, p)| p == s);
            let regular = std::fs::symlink_metadata(s).is_ok_and(|m| m.is_file());
            if !written && regular {
                let _ = std::fs::remove_file(s);
            }
        }
        for (i, (tmp, real)) in staged.iter().enumerate() {
            if let Err(e) = std::fs::rename(tmp, real) {
                for (t, _) in staged.iter().skip(i.max(n_ready)) {
                    let _ = std::fs::remove_file(t);
                }
                return Err(Error::io("write", real, e));
            }
        }
        for (tmp, t) in streamed_through {
            let copy = |to: &mut dyn Write| -> std::io::Result<()> {
                let mut from = std::fs::File::open(&tmp)?;
                std::io::copy(&mut from, to)?;
                to.flush()
            };
            match t {
                Target::Through(p) => {
                    let mut f = std::fs::OpenOptions::new()
                        .write(true)
                        .truncate(true)
                        .open(&p)
                        .map_err(|e| Error::io("open", &p, e))?;
                    copy(&mut f).map_err(|e| Error::io("write", &p, e))?;
                }
                Target::Stdout => copy(&mut std::io::stdout().lock())
                    .map_err(|e| Error::io("write", "<stdout>", e))?,
                Target::Atomic(_) => {}
            }
            let _ = std::fs::remove_file(&tmp);
        }
        for (t, b) in later {
            match t {
                Target::Through(p) => write_through(&p, b)?,
                Target::Stdout => write_stdout(b)?,
                Target::Atomic(_) => {}
            }
        }
        let mut written: Vec<PathBuf> = self.ready.into_iter().map(|(_, p)| p).collect();
        written.extend(self.files.into_iter().map(|(p, _)| p));
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_are_written_through_and_never_replaced() {
        let d = tempfile::tempdir().unwrap();
        let real = d.path().join("real.csv");
        std::fs::write(&real, b"old").unwrap();
        let link = d.path().join("link.csv");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_output(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        write_output(Path::new("/dev/null"), b"x").unwrap();
        assert!(!std::fs::metadata("/dev/null").unwrap().is_file());
        let dir_err = write_output(d.path(), b"x").unwrap_err();
        assert!(dir_err.is_input(), "{dir_err}");
    }

    /// A file streamed to a temporary name (the trials file) lands where
    /// any output would: through a symlink onto its target (the link kept),
    /// through /dev/null and a fifo by writing, never renamed over them.
    #[test]
    fn streamed_files_are_written_through_special_files() {
        let d = tempfile::tempdir().unwrap();
        let stream = |name: &str, bytes: &[u8]| {
            let tmp = d.path().join(format!(".{name}.tmp"));
            std::fs::write(&tmp, bytes).unwrap();
            tmp
        };
        let real = d.path().join("real.csv");
        std::fs::write(&real, b"old").unwrap();
        let link = d.path().join("trials.csv");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        let mut o = Outputs::default();
        let tmp = stream("a", b"rows");
        o.add_ready(tmp.clone(), link.clone());
        o.write().unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"rows");
        assert!(!tmp.exists());
        let mut o = Outputs::default();
        let tmp = stream("b", b"rows");
        o.add_ready(tmp.clone(), PathBuf::from("/dev/null"));
        o.write().unwrap();
        assert!(!std::fs::metadata("/dev/null").unwrap().is_file());
        assert!(!tmp.exists());
        // A fifo: a reader on the other end receives the bytes.
        let fifo = d.path().join("fifo.csv");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo on a path this test owns.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        let mut o = Outputs::default();
        o.add_ready(stream("c", b"through the pipe"), fifo.clone());
        o.write().unwrap();
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
    }

    #[test]
    fn a_second_claim_of_a_directory_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let first = claim_dir(d.path()).unwrap();
        let second = claim_dir(d.path()).unwrap_err();
        assert!(second.is_input() && second.to_string().contains("in use"));
        drop(first);
        claim_dir(d.path()).unwrap();
    }

    #[test]
    fn outputs_remove_what_this_run_does_not_write() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("a.csv"), b"old").unwrap();
        std::fs::write(d.path().join("b.csv"), b"old").unwrap();
        std::fs::write(d.path().join("keep.txt"), b"mine").unwrap();
        let mut o = Outputs::default();
        o.replace_all(d.path(), &["a.csv", "b.csv"]);
        o.add(d.path().join("a.csv"), b"new".to_vec());
        o.write().unwrap();
        assert_eq!(std::fs::read(d.path().join("a.csv")).unwrap(), b"new");
        assert!(!d.path().join("b.csv").exists());
        assert!(d.path().join("keep.txt").exists());
    }
}
