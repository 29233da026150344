//! What the G-code engine's tests share: walking a program held in memory,
//! and LinuxCNC's stand-alone interpreter `rs274` on the same text.
#![allow(dead_code)]

use std::io::Cursor;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use volcomp_gcode::{GcodeError, InterpOptions, Motion, Setup, Walker, Warning};

/// A walker over `program` (named `t.ngc` in messages).
pub fn walker(program: &str, setup: Setup, options: InterpOptions) -> Walker<Cursor<Vec<u8>>> {
    Walker::new(
        Cursor::new(program.as_bytes().to_vec()),
        Some("t.ngc".into()),
        setup,
        options,
    )
}

/// Every motion of `program` with the line number of its block, or the
/// first error.
pub fn numbered_motions(
    program: &str,
    setup: Setup,
    options: InterpOptions,
) -> Result<Vec<(u64, Motion)>, GcodeError> {
    let mut w = walker(program, setup, options);
    let mut motions = Vec::new();
    while let Some(ev) = w.next_line()? {
        motions.extend(ev.motions.iter().map(|m| (ev.number, *m)));
    }
    Ok(motions)
}

/// Every motion of `program`, or the first error, and the warnings given
/// up to the end or the error.
pub fn motions_and_warnings(
    program: &str,
    setup: Setup,
    options: InterpOptions,
) -> (Result<Vec<Motion>, GcodeError>, Vec<Warning>) {
    let mut w = walker(program, setup, options);
    let mut motions = Vec::new();
    loop {
        match w.next_line() {
            Ok(Some(ev)) => motions.extend_from_slice(ev.motions),
            Ok(None) => return (Ok(motions), w.warnings().to_vec()),
            Err(e) => return (Err(e), w.warnings().to_vec()),
        }
    }
}

/// Every motion of `program` under `setup` and the default options.
pub fn motions_with(program: &str, setup: Setup) -> Result<Vec<Motion>, GcodeError> {
    motions_and_warnings(program, setup, InterpOptions::default()).0
}

/// Asserts that each program of `cases` is refused under `setup` with a
/// message that holds the text beside it.
#[track_caller]
pub fn refused_with(setup: &Setup, cases: &[(&str, &str)]) {
    for (program, said) in cases {
        let e = motions_with(program, setup.clone()).expect_err(program);
        assert!(e.to_string().contains(said), "{program}: {e}");
    }
}

/// [`refused_with`] under the default set-up.
#[track_caller]
pub fn refused(cases: &[(&str, &str)]) {
    refused_with(&Setup::default(), cases)
}

/// Every motion of `program` under the default set-up and options.
pub fn motions(program: &str) -> Result<Vec<Motion>, GcodeError> {
    motions_with(program, Setup::default())
}

/// What `rs274 -g` made of `program` (written as it is to `t.ngc`): its exit
/// status and output, and the canonical calls it wrote. `None` when rs274 is
/// not installed.
pub struct Rs274 {
    pub output: Output,
    /// The canonical calls (the output file), one per line.
    pub canon: String,
}

impl Rs274 {
    /// Standard output, then standard error.
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.output.stdout).into_owned()
            + &String::from_utf8_lossy(&self.output.stderr)
    }

    /// rs274's first message about `program`: the first line of its output
    /// that is not a numbered canonical call, not "executing" and not a
    /// block of `program` (`None` when there is none: it accepted it).
    pub fn message(&self, program: &str) -> Option<String> {
        self.text()
            .lines()
            .map(str::trim)
            .find(|l| {
                !l.is_empty()
                    && !l.starts_with(|c: char| c.is_ascii_digit())
                    && *l != "executing"
                    && !program.lines().any(|p| p.trim() == *l)
            })
            .map(str::to_string)
    }
}

/// The first error of the program `reader` holds (named `name`), read line
/// by line; a program read to its end without one fails with `accepted`.
pub fn first_error(reader: impl std::io::BufRead, name: &str, accepted: &str) -> GcodeError {
    let mut w = Walker::new(
        reader,
        Some(name.into()),
        Setup::default(),
        InterpOptions::default(),
    );
    loop {
        match w.next_line() {
            Ok(Some(_)) => {}
            Ok(None) => panic!("{accepted}"),
            Err(e) => break e,
        }
    }
}

/// Runs `rs274 -g t.ngc out.txt` on `program` in a directory of its own.
/// rs274 2.9 keeps its tool data in `$HOME/.tool.mmap`, and concurrent runs
/// sharing that file die with a bus error (SIGBUS): every run gets its own
/// HOME, so the tests of every file may run it side by side. A run killed by
/// a signal all the same is tried again, twice. `None` where rs274 is not
/// installed: the test then skips its comparison and says so, except under
/// CI (the `CI` variable set, as `.ci/run` sets it), where it fails.
pub fn rs274(program: &[u8]) -> Option<Rs274> {
    let Some(rs274) = ["/usr/bin/rs274", "/usr/local/bin/rs274"]
        .into_iter()
        .find(|p| Path::new(p).exists())
    else {
        let tool = "rs274 (LinuxCNC's stand-alone interpreter, Debian package linuxcnc-uspace)";
        if std::env::var_os("CI").is_some() {
            panic!("{tool} is not installed, and CI is set: CI must install it (.ci/run does)");
        }
        eprintln!("!! SKIPPED: {tool} is not installed: the comparison with rs274 was NOT checked");
        return None;
    };
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("t.ngc");
    let canon = dir.path().join("out.txt");
    std::fs::write(&file, program).unwrap();
    for attempt in 1.. {
        let output = Command::new(rs274)
            .arg("-g")
            .arg(&file)
            .arg(&canon)
            .current_dir(dir.path())
            .env("HOME", dir.path())
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let crashed = output.status.code().is_none_or(|c| c > 128);
        if !crashed || attempt == 3 {
            assert!(
                !crashed,
                "rs274 crashed 3 times on {:?}",
                String::from_utf8_lossy(program)
            );
            let canon = std::fs::read_to_string(&canon).unwrap_or_default();
            return Some(Rs274 { output, canon });
        }
    }
    unreachable!()
}

/// proptest's configuration for this crate's property tests: `default_cases`
/// cases unless the `PROPTEST_CASES` variable gives a count (proptest's own
/// `Config::with_cases` overrides the variable), and failing cases kept beside
/// the test file as `<file>.proptest-regressions`, which proptest replays
/// before new cases. (Its default place, a tree parallel to `src/`, does not
/// exist for `tests/`: it warns and falls back to the same file.)
pub fn proptest_config(default_cases: u32) -> proptest::test_runner::Config {
    let cases = match std::env::var("PROPTEST_CASES") {
        Ok(text) => text
            .parse()
            .unwrap_or_else(|_| panic!("PROPTEST_CASES={text:?} is not a count of cases")),
        Err(_) => default_cases,
    };
    proptest::test_runner::Config {
        cases,
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"),
        )),
        ..proptest::test_runner::Config::default()
    }
}
