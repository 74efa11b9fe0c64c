//! `completions` and `man`: shell completions and man pages from the
//! command line's own definition.

use crate::cli::Cli;
use crate::error::{Error, Result};
use crate::io::Outputs;
use clap::CommandFactory;
use std::path::Path;

/// The completion script for `shell` on stdout.
pub fn completions(shell: clap_complete::Shell) -> Result<()> {
    let mut cmd = Cli::command();
    let mut buf = Vec::new();
    clap_complete::generate(shell, &mut cmd, "tricept-calib", &mut buf);
    use std::io::Write;
    let mut out = std::io::stdout();
    out.write_all(&buf)
        .and_then(|_| out.flush())
        .map_err(|e| Error::io("write", "stdout", e))
}

/// Man pages into `dir`: tricept-calib.1 and one per command
/// (tricept-calib-sweep.1, …).
pub fn man(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io("create", dir, e))?;
    let cmd = Cli::command();
    let mut outputs = Outputs::default();
    let render = |c: clap::Command| -> Result<Vec<u8>> {
        let mut buf = Vec::new();
        clap_mangen::Man::new(c)
            .render(&mut buf)
            .map_err(|e| Error::Internal(format!("man page: {e}")))?;
        Ok(buf)
    };
    outputs.add(dir.join("tricept-calib.1"), render(cmd.clone())?);
    let mut n = 1;
    for sub in cmd.get_subcommands() {
        let name = format!("tricept-calib-{}", sub.get_name());
        let page = sub.clone().name(name.clone());
        outputs.add(dir.join(format!("{name}.1")), render(page)?);
        n += 1;
    }
    outputs.write()?;
    crate::cli::console::line(format_args!("wrote {n} man pages to {}", dir.display()));
    Ok(())
}
