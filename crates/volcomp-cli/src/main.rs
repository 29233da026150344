//! `volcomp`: the command-line front end. It parses arguments, calls the
//! library crates and prints; the work happens in `volcomp-gcode` and
//! `volcomp-core`.

mod args;
mod commands;
mod output;
mod plot;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    match commands::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`volcomp moves … | head`) is not an error.
            if e.is_broken_pipe() {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
