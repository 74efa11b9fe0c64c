//! `tricept-calib`: parse the command line, run, report. Exit status 0 on
//! success, 2 on bad input (config, readings, arguments), 1 otherwise.

use clap::Parser;
use std::process::ExitCode;
use tricept_calib::cli::{run, Cli};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e}");
            ExitCode::from(if e.is_input() { 2 } else { 1 })
        }
    }
}
