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
    // A closed standard output would lose results with exit 0 (and let the
    // next opened file take its descriptor): refuse it first.
    if let Err(why) = volcomp_core::output::check_standard_streams() {
        eprintln!("error: {why}");
        return ExitCode::from(2);
    }
    // A reader that goes away (`volcomp moves P | head`) ends volcomp as it
    // ends every Unix filter: quietly, killed by SIGPIPE (the shell sees
    // status 141). Rust ignores SIGPIPE by default, which would turn it into
    // a write error in the middle of printing. Temporaries are unnamed on
    // Linux, so nothing is left behind.
    // SAFETY: sets a signal disposition before any thread is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Named temporaries (where the OS has no unnamed ones) are removed on
    // SIGINT, SIGTERM and SIGHUP.
    if let Err(e) = volcomp_core::output::install_cleanup() {
        eprintln!("volcomp: warning: cannot watch for signals ({e}); an interrupted run may leave a .volcomp-*.tmp file");
    }
    let cli = args::Cli::parse();
    match commands::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`volcomp moves … | head`) is not an error.
            if e.is_broken_pipe() {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {e}");
            // Partial commits already list what was written.
            if !matches!(e, output::CliError::Output(_)) {
                if let Some(note) = output::outputs_note() {
                    eprintln!("{note}");
                }
            }
            ExitCode::from(2)
        }
    }
}
