//! `volcomp`: the command-line front end. It parses arguments, calls the
//! library crates and prints; the work happens in `volcomp-gcode` and
//! `volcomp-core`.
// Files are read through `volcomp_geom::inputs` only (clippy.toml).
#![cfg_attr(not(test), warn(clippy::disallowed_methods))]

mod args;
mod commands;
mod flags;
mod options;
mod output;
mod plot;
mod progress;

use clap::Parser;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Whether descriptor 1 was closed when the process started (`volcomp …
/// >&-`). Rust's runtime re-opens closed standard descriptors on
/// `/dev/null` before `main`, so output written there would be lost with
/// exit 0; this is recorded before that, from the ELF `.init_array`.
static STDOUT_CLOSED_AT_START: AtomicBool = AtomicBool::new(false);

#[cfg(target_os = "linux")]
#[used]
#[link_section = ".init_array"]
static RECORD_STDOUT: extern "C" fn() = {
    extern "C" fn record() {
        // SAFETY: fcntl(F_GETFD) only queries the descriptor.
        if unsafe { libc::fcntl(1, libc::F_GETFD) } == -1 {
            STDOUT_CLOSED_AT_START.store(true, Ordering::Relaxed);
        }
    }
    record
};

fn main() -> ExitCode {
    // A closed standard output would lose results with exit 0: refuse it.
    if STDOUT_CLOSED_AT_START.load(Ordering::Relaxed) {
        eprintln!("error: standard output is closed (`>&-`): volcomp writes results or messages there; redirect it to a file or to /dev/null");
        return ExitCode::from(output::EXIT_BAD_INPUT);
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
    if let Err(e) = volcomp_core::io::output::install_cleanup() {
        eprintln!("volcomp: warning: cannot watch for signals ({e}); an interrupted run may leave a .volcomp-*.tmp file");
    }
    let argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let cli = match args::Cli::try_parse_from(&argv) {
        Ok(cli) => cli,
        Err(e) => {
            let words: Vec<String> = argv.iter().map(|a| a.to_string_lossy().into()).collect();
            let cmd = <args::Cli as clap::CommandFactory>::command();
            options::suggest_flag(e, &cmd, &words).exit()
        }
    };
    progress::set_quiet(cli.quiet);
    volcomp_core::io::inputs::set_max_file_bytes(cli.max_input_size.0.unwrap_or(u64::MAX));
    match commands::run(cli) {
        Ok(()) => ExitCode::from(output::EXIT_OK),
        Err(e) => {
            // A closed pipe (`volcomp moves … | head`) is not an error.
            if e.is_broken_pipe() {
                return ExitCode::from(output::EXIT_OK);
            }
            // File names and values a user gave are printed escaped.
            eprintln!("error: {}", output::clean(&e.to_string()));
            if e.to_string()
                .contains(volcomp_core::io::inputs::TOO_LARGE_HELP)
            {
                eprintln!("  help: raise the limit with --max-input-size SIZE (e.g. 1G), or remove it with --max-input-size none");
            } else if e.passed_size_limit() {
                eprintln!("  help: raise the limit with --max-output-size SIZE (e.g. 1G), or remove it with --max-output-size none");
            }
            // Partial commits already list what was written.
            if !matches!(e, output::CliError::Output(_)) {
                if let Some(note) = output::outputs_note() {
                    eprintln!("{}", output::clean(&note));
                }
            }
            ExitCode::from(e.exit_code())
        }
    }
}
