//! What every command-line test needs: run the binary in a directory, and a
//! fresh directory per test.
#![allow(dead_code)]

pub mod pdf;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// rs274, LinuxCNC's stand-alone interpreter (the reference of the G-code
/// tests).
pub const RS274: &str =
    "rs274 (LinuxCNC's stand-alone interpreter, Debian package linuxcnc-uspace)";
/// LinuxCNC's headless simulator (the motion-controller tests).
pub const LINUXCNC: &str =
    "LinuxCNC (Debian package linuxcnc-uspace: linuxcnc, halcmd, python3-linuxcnc)";

/// A tool a test needs is not installed. Under CI (the `CI` variable set,
/// as `.ci/run` and hosted CI set it) the test fails: CI installs every
/// tool the tests use (README, "Testing"). Elsewhere it says loudly what
/// was not checked, and the caller returns.
pub fn missing(tool: &str, not_checked: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("{tool} is not installed, and CI is set: CI must install it (.ci/run does)");
    }
    eprintln!("!! SKIPPED: {tool} is not installed: {not_checked} was NOT checked");
}

/// Runs `volcomp ARGS…` in `dir`.
pub fn volcomp(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run volcomp")
}

/// Runs `volcomp` in `dir` with the words of `line` as its arguments, as a
/// user types them (split at white space: an argument holding a space
/// goes through [`volcomp`]).
pub fn run(dir: &Path, line: &str) -> Output {
    volcomp(&args(line), dir)
}

/// The words of a command line, as [`run`] splits it (for a test that adds
/// arguments holding a space, or varies some).
pub fn args(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// Runs each command line of `lines` in turn in `dir` (as [`run`]); each
/// must succeed.
#[track_caller]
pub fn run_all(dir: &Path, lines: &[&str]) {
    for line in lines {
        let o = run(dir, line);
        assert_eq!(o.status.code(), Some(0), "{line}: {}", text(&o));
    }
}

/// `volcomp` with the words of `line` as its arguments, to run in `dir`
/// (for a test that sets its standard streams or environment).
pub fn command(dir: &Path, line: &str) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_volcomp"));
    c.args(line.split_whitespace()).current_dir(dir);
    c
}

/// A test's own directory: removed when the test is done with it, kept when
/// the test fails (a panic is unwinding), so its files can be looked at.
pub struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl TempDir {
    /// The directory's path.
    pub fn as_path(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for TempDir {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A fresh, empty directory for one test, named after the calling test file,
/// `name` and the process: the files' tests run side by side in one binary
/// (tests/cli_tests.rs), and two files may use the same `name`. It is removed
/// when the returned guard goes out of scope (kept if the test fails).
#[track_caller]
pub fn tempdir(name: &str) -> TempDir {
    let file = Path::new(std::panic::Location::caller().file());
    let stem = file.file_stem().unwrap_or_default().to_string_lossy();
    let d = std::env::temp_dir().join(format!("volcomp-{stem}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TempDir(d)
}

/// Writes `contents` as the file `name` in `dir` (a test's input).
#[track_caller]
pub fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) {
    let path = dir.join(name);
    if let Err(e) = std::fs::write(&path, contents) {
        panic!("cannot write {}: {e}", path.display());
    }
}

/// The text of the file `name` in `dir` (what a run wrote).
#[track_caller]
pub fn read(dir: &Path, name: &str) -> String {
    let path = dir.join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// What a run wrote on standard error.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// What a run wrote on standard output.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard output then standard error (for messages of a failed check).
pub fn text(o: &Output) -> String {
    format!("{}{}", stdout(o), stderr(o))
}

/// Asserts the run succeeded (exit 0), showing what it said if not, and
/// returns what it wrote on standard output.
#[track_caller]
pub fn ok(o: &Output) -> String {
    assert_eq!(o.status.code(), Some(0), "{}", text(o));
    stdout(o)
}

/// Asserts the run was refused (exit 2: bad input or options) and returns
/// what it said on standard error.
#[track_caller]
pub fn refused(o: &Output) -> String {
    assert_eq!(o.status.code(), Some(2), "{}", text(o));
    stderr(o)
}

/// Asserts that the run said `what` on standard error.
#[track_caller]
pub fn said(o: &Output, what: &str) {
    assert!(stderr(o).contains(what), "no `{what}` in: {}", text(o));
}

/// The run's standard output as JSON (the run must succeed).
#[track_caller]
pub fn json(o: &Output) -> serde_json::Value {
    ok(o);
    serde_json::from_slice(&o.stdout).unwrap()
}

/// A small axis-table map over 0…600 mm with a pitch error of 2 µm per 100 mm
/// on every axis (hand-made, so the test does not depend on `map example`).
pub fn write_map(dir: &Path) -> PathBuf {
    let mut s = String::from("axis,position_mm,direction,ex_um,ey_um,ez_um\n");
    for axis in ["X", "Y", "Z"] {
        for dir in ["+", "-"] {
            for k in 0..=6 {
                let p = k as f64 * 100.0;
                let e = 0.02 * p;
                let (ex, ey, ez) = match axis {
                    "X" => (e, 0.0, 0.0),
                    "Y" => (0.0, e, 0.0),
                    _ => (0.0, 0.0, e),
                };
                s.push_str(&format!("{axis},{p},{dir},{ex},{ey},{ez}\n"));
            }
        }
    }
    let path = dir.join("map.csv");
    std::fs::write(&path, s).unwrap();
    path
}

// A small part on a pitch-error map, shared by the output-safety and header tests.
pub const PROGRAM: &str =
    "G21 G90 G17\nG0 X10 Y10 Z5\nG1 Z-1 F300\nG1 X60 Y40\nG1 X10\nG0 Z5\nM2\n";

pub const SETUP: &str = "units = \"mm\"\n[work_offsets]\nG54 = [200, 150, 100]\n";

/// A directory with the map, program and set-up above (see [`tempdir`]).
#[track_caller]
pub fn fixture(name: &str) -> TempDir {
    let d = tempdir(name);
    write_map(&d);
    std::fs::write(d.join("part.ngc"), PROGRAM).unwrap();
    std::fs::write(d.join("machine.toml"), SETUP).unwrap();
    d
}

/// A long program: enough lines that a compensation takes a while.
pub fn large_program(dir: &Path, lines: usize) -> PathBuf {
    let path = dir.join("large.ngc");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    writeln!(f, "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z-1 F600").unwrap();
    for k in 0..lines {
        // Within the map over G54 = (200, 150, 100): X ≤ 449.5, Y ≤ 299.5.
        let x = (k % 500) as f64 * 0.5;
        let y = ((k / 500) % 300) as f64 * 0.5;
        writeln!(f, "G1 X{x:.3} Y{y:.3}").unwrap();
    }
    writeln!(f, "M2").unwrap();
    path
}

/// `volcomp compensate part.ngc --map map.csv --setup machine.toml -o OUT
/// EXTRA…` in a [`fixture`] directory.
pub fn compensate_with(d: &Path, out: &str, extra: &[&str]) -> Output {
    let mut args = args("compensate part.ngc --map map.csv --setup machine.toml -o");
    args.push(out);
    args.extend_from_slice(extra);
    volcomp(&args, d)
}

/// [`compensate_with`] without extra options.
pub fn compensate_to(d: &Path, out: &str) -> Output {
    compensate_with(d, out, &[])
}
