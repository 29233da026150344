//! A compensated program says what it is for (its header, and no second
//! compensation), standard input and output, and the LinuxCNC filter
//! protocol as AXIS runs it.

mod common;

use common::{compensate_to, fixture, large_program, stderr, volcomp, PROGRAM};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

#[test]
fn standard_input_and_output() {
    let d = fixture("stdio");
    let mut child = Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args([
            "compensate",
            "-",
            "--map",
            "map.csv",
            "--setup",
            "machine.toml",
            "-o",
            "-",
        ])
        .current_dir(&d)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(PROGRAM.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let from_stdin = String::from_utf8(o.stdout).unwrap();
    // The same as compensating the file (the header's date aside).
    let o = volcomp(
        &[
            "compensate",
            "part.ngc",
            "--map",
            "map.csv",
            "--setup",
            "machine.toml",
            "-o",
            "-",
        ],
        &d,
    );
    let from_file = String::from_utf8(o.stdout).unwrap();
    let body = |s: &str| volcomp_core::io::provenance::strip_header(s);
    assert_eq!(body(&from_stdin), body(&from_file));
    assert!(from_stdin.starts_with(volcomp_core::io::provenance::FIRST_LINE));
    assert!(from_stdin.contains("G1"), "{from_stdin}");
}

/// Runs a filter exactly as LinuxCNC's AXIS does (axis.py, filter_program):
/// `sh -c "FILTER 'PATH'"`, standard input closed, standard output into the
/// file AXIS then opens, standard error read line by line for
/// `FILTER_PROGRESS=n` (regex `^FILTER_PROGRESS=(\d*)$`), the rest shown to
/// the operator when the exit status is not 0.
fn run_as_axis(dir: &Path, filter: &str, program: &Path) -> (i32, String, Vec<u32>, Vec<String>) {
    let quoted = program.display().to_string().replace('\'', "'\\''");
    let out_path = dir.join("filtered.ngc");
    let out = std::fs::File::create(&out_path).unwrap();
    let mut p = Command::new("sh")
        .arg("-c")
        .arg(format!("{filter} '{quoted}'"))
        .current_dir(dir)
        .env("AXIS_PROGRESS_BAR", "1")
        .stdin(Stdio::piped())
        .stdout(out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(p.stdin.take());
    let mut progress = Vec::new();
    let mut text = Vec::new();
    for line in BufReader::new(p.stderr.take().unwrap()).lines() {
        let line = line.unwrap();
        match line.strip_prefix("FILTER_PROGRESS=") {
            Some(n) if n.chars().all(|c| c.is_ascii_digit()) => progress.push(n.parse().unwrap()),
            _ => text.push(line),
        }
    }
    let code = p.wait().unwrap().code().unwrap_or(-1);
    let filtered = std::fs::read_to_string(&out_path).unwrap();
    (code, filtered, progress, text)
}

#[test]
fn linuxcnc_filter_protocol() {
    let d = fixture("filter");
    large_program(&d, 2_000);
    let bin = env!("CARGO_BIN_EXE_volcomp");
    let map = d.join("map.csv");
    let setup = d.join("machine.toml");
    let filter = format!(
        "'{bin}' compensate --filter --map '{}' --setup '{}'",
        map.display(),
        setup.display()
    );
    let (code, filtered, progress, text) = run_as_axis(&d, &filter, &d.join("large.ngc"));
    assert_eq!(code, 0, "{text:?}");
    assert!(filtered.starts_with(volcomp_core::io::provenance::FIRST_LINE));
    assert!(
        filtered.trim_end().ends_with("M2"),
        "{}",
        &filtered[filtered.len() - 80..]
    );
    assert!(progress.len() >= 10, "{progress:?}");
    assert!(progress.windows(2).all(|w| w[0] < w[1]), "{progress:?}");
    assert_eq!(progress.last(), Some(&100));
    // A program with a space and a quote in its name arrives intact.
    let odd = d.join("it's a part.ngc");
    std::fs::write(&odd, PROGRAM).unwrap();
    let (code, filtered, _, text) = run_as_axis(&d, &filter, &odd);
    assert_eq!(code, 0, "{text:?}");
    assert!(filtered.contains("(volcomp header end)"));
    // A bad program: non-zero exit, the message names the file and line,
    // nothing on standard output.
    let bad = d.join("bad.ngc");
    std::fs::write(&bad, "G21 G90\nG1 X10 F100\nG7.5 X3\nM2\n").unwrap();
    let (code, filtered, _, text) = run_as_axis(&d, &filter, &bad);
    assert_ne!(code, 0);
    let message = text.join("\n");
    assert!(message.contains("bad.ngc:3"), "{message}");
    assert!(filtered.is_empty(), "{filtered}");
}

#[test]
fn header_content_and_refusal_of_double_compensation() {
    let d = fixture("header");
    std::fs::write(d.join("part.ngc"), format!("%\nO0042 (PART)\n{PROGRAM}%\n")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args([
            "compensate",
            "part.ngc",
            "--map",
            "map.csv",
            "--setup",
            "machine.toml",
            "-o",
            "out.ngc",
        ])
        .current_dir(&d)
        .env("SOURCE_DATE_EPOCH", "951782400")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(d.join("out.ngc")).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "%");
    assert_eq!(lines[1], "O0042 (PART)");
    assert_eq!(lines[2], volcomp_core::io::provenance::FIRST_LINE);
    let map_sha = {
        use sha2_check::sha256_hex;
        sha256_hex(&std::fs::read(d.join("map.csv")).unwrap())
    };
    for want in [
        format!("(volcomp {})", env!("CARGO_PKG_VERSION")),
        "(map map.csv)".to_string(),
        format!("(map sha256 {map_sha})"),
        "(setup machine.toml)".to_string(),
        "(G54 X200 Y150 Z100 mm)".to_string(),
        "(method exact)".to_string(),
        "(date 2000-02-29T00:00:00Z)".to_string(),
    ] {
        assert!(lines.contains(&want.as_str()), "missing {want}:\n{out}");
    }
    let end = lines
        .iter()
        .position(|l| *l == "(volcomp header end)")
        .unwrap();
    assert_eq!(lines[end + 1], "G21 G90 G17", "{out}");
    // The same again is refused, naming the line, and writes nothing.
    let o = volcomp(
        &[
            "compensate",
            "out.ngc",
            "--map",
            "map.csv",
            "--setup",
            "machine.toml",
            "-o",
            "again.ngc",
        ],
        &d,
    );
    let e2 = stderr(&o);
    // Compensating twice refuses the program (exit 3, docs/errors.md).
    assert_eq!(o.status.code(), Some(3), "{e2}");
    assert!(
        e2.contains("out.ngc:3") && e2.contains("--allow-recompensate"),
        "{e2}"
    );
    assert!(!d.join("again.ngc").exists());
    let o = volcomp(
        &[
            "compensate",
            "out.ngc",
            "--map",
            "map.csv",
            "--setup",
            "machine.toml",
            "--allow-recompensate",
            "-o",
            "again.ngc",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// SHA-256 computed by the system's `sha256sum`, a second implementation.
mod sha2_check {
    pub fn sha256_hex(bytes: &[u8]) -> String {
        use std::io::Write as _;
        let mut c = std::process::Command::new("sha256sum")
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("sha256sum");
        c.stdin.take().unwrap().write_all(bytes).unwrap();
        let o = c.wait_with_output().unwrap();
        String::from_utf8(o.stdout).unwrap()[..64].to_string()
    }
}

#[test]
fn rs274_reads_a_compensated_program_with_its_header() {
    let Ok(rs274) = which("rs274") else {
        eprintln!("rs274 not installed: skipped");
        return;
    };
    let d = fixture("rs274_header");
    std::fs::write(d.join("part.ngc"), format!("%\n{PROGRAM}%\n")).unwrap();
    let o = compensate_to(&d, "out.ngc");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = Command::new(rs274)
        .arg("-g")
        .arg(d.join("out.ngc"))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o);
    assert!(o.status.success(), "{text}");
    assert!(!text.to_lowercase().contains("error"), "{text}");
    // The header's comments reach the interpreter as comments.
    assert!(text.contains("COMMENT(\"volcomp header end\")"), "{text}");
}

fn which(name: &str) -> Result<PathBuf, ()> {
    let path = std::env::var_os("PATH").ok_or(())?;
    std::env::split_paths(&path)
        .map(|p| p.join(name))
        .find(|p| p.is_file())
        .ok_or(())
}
