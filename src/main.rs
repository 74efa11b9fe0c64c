//! `tricept-calib`: parse the command line, run, report. Exit status 0 on
//! success, 2 on bad input (config, readings, arguments), 3 when
//! `sweep --require-target` finds no combination meeting the target, 1
//! otherwise.

use clap::Parser;
use std::process::ExitCode;
use tricept_calib::cli::{run, Cli};

fn main() -> ExitCode {
    // Behave like other command-line tools when stdout is a closed pipe
    // (`tricept-calib sweep … | head`): end quietly instead of panicking.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
