//! Progress bars: drawn on a terminal (a pseudo-terminal from util-linux
//! `script`), never into a pipe or a file, silenced by `--quiet`; one
//! summary line when the work ends.

use std::path::Path;
use std::process::{Command, Stdio};

use crate::common;
use common::{fixture, large_program};

/// Runs `volcomp ARGS` in `dir` with standard error on a pseudo-terminal;
/// what the terminal showed, or `None` without `script`.
fn on_terminal(dir: &Path, args: &str) -> Option<String> {
    let exe = env!("CARGO_BIN_EXE_volcomp");
    let o = Command::new("script")
        .args(["-qec", &format!("{exe} {args}"), "/dev/null"])
        .current_dir(dir)
        .stdin(Stdio::null())
        .output();
    match o {
        Ok(o) if o.status.success() => Some(String::from_utf8_lossy(&o.stdout).into_owned()),
        Ok(o) => panic!(
            "volcomp {args} failed on a terminal: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => {
            common::missing(
                &format!("`script` (Debian package bsdutils: {e})"),
                "the progress bar on a terminal",
            );
            None
        }
    }
}

fn large(name: &str) -> common::TempDir {
    let dir = fixture(name);
    // 60 000 lines, about 1.1 MiB: above the 1 MiB from which a bar is drawn.
    let p = large_program(&dir, 60_000);
    assert!(std::fs::metadata(p).unwrap().len() > 1 << 20);
    dir
}

const COMPENSATE: &str = "compensate large.ngc --map map.csv --setup machine.toml -o out.ngc";

#[test]
fn a_bar_and_a_summary_line_on_a_terminal() {
    let dir = large("progress-tty");
    let Some(shown) = on_terminal(&dir, COMPENSATE) else {
        return;
    };
    assert!(shown.contains("compensating large.ngc ["), "{shown}");
    assert!(
        shown.contains("\x1b["),
        "no terminal control sequence: {shown}"
    );
    assert!(
        shown.contains("volcomp: compensating large.ngc: 1.11 MiB in "),
        "{shown}"
    );
    let Some(shown) = on_terminal(
        &dir,
        "simulate large.ngc --map map.csv --setup machine.toml",
    ) else {
        return;
    };
    assert!(shown.contains("simulating large.ngc ["), "{shown}");
    // --quiet: neither bar, summary line nor report of what was written;
    // the result as before.
    std::fs::remove_file(dir.join("out.ngc")).unwrap();
    let Some(shown) = on_terminal(&dir, &format!("--quiet {COMPENSATE}")) else {
        return;
    };
    assert!(!shown.contains("compensating large.ngc"), "{shown}");
    assert!(!shown.contains("volcomp: wrote"), "{shown}");
    assert!(!shown.contains("volcomp: size"), "{shown}");
    assert!(dir.join("out.ngc").is_file());
}

#[test]
fn work_under_a_mebibyte_gets_its_bar_once_it_has_taken_a_second() {
    // 20 000 lines, about 0.4 MiB: no bar from the start. Split every
    // 0.05 mm (20 times the work of the 1 MiB case per line), the run
    // takes seconds in a debug build, and a bar appears once it has taken
    // more than one; a run that ends within a second shows none. Which
    // case this is depends on the machine: each is checked as it comes.
    let dir = fixture("progress-late");
    let p = large_program(&dir, 20_000);
    assert!(std::fs::metadata(p).unwrap().len() < 1 << 20);
    let started = std::time::Instant::now();
    let Some(shown) = on_terminal(&dir, &format!("{COMPENSATE} --segment-length 0.05")) else {
        return;
    };
    let took_s = started.elapsed().as_secs_f64();
    let bar = shown.contains("volcomp: compensating large.ngc: ");
    if took_s > 2.5 {
        assert!(bar, "{took_s:.1} s without a bar: {shown}");
    } else if took_s < 1.0 {
        assert!(!bar, "{took_s:.1} s with a bar: {shown}");
    }
}

#[test]
fn never_a_bar_in_a_pipe_or_a_file() {
    let dir = large("progress-pipe");
    let args: Vec<&str> = COMPENSATE.split(' ').collect();
    let o = Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args(&args)
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success());
    let piped = String::from_utf8_lossy(&o.stderr);
    let log = dir.join("stderr.txt");
    let o = Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args(&args)
        .current_dir(&dir)
        .stderr(std::fs::File::create(&log).unwrap())
        .status()
        .unwrap();
    assert!(o.success());
    let filed = std::fs::read_to_string(&log).unwrap();
    for stderr in [piped.as_ref(), filed.as_str()] {
        assert!(!stderr.contains("compensating"), "{stderr}");
        assert!(
            !stderr.contains('\x1b') && !stderr.contains('\r'),
            "{stderr}"
        );
        assert!(stderr.starts_with("volcomp: wrote out.ngc"), "{stderr}");
    }
}
