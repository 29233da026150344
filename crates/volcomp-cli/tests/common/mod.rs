//! What every command-line test needs: run the binary in a directory, and a
//! fresh directory per test.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `volcomp ARGS…` in `dir`.
pub fn volcomp(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run volcomp")
}

/// A fresh, empty directory for one test (named after the test binary, the
/// test and the process, so parallel test binaries never share one).
pub fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "volcomp-{}-{name}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
