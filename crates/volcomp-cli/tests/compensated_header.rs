//! A compensated program says what it is for (its header, and no second
//! compensation), standard input and output, and the LinuxCNC filter
//! protocol as AXIS runs it.

use crate::common;

use common::{compensate_to, fixture, large_program, read, stderr, volcomp, write, PROGRAM};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

#[test]
fn standard_input_and_output() {
    let d = fixture("stdio");
    let mut child = common::command(&d, "compensate - --map map.csv --setup machine.toml -o -")
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
    common::ok(&o);
    let from_stdin = String::from_utf8(o.stdout).unwrap();
    // The same as compensating the file (the header's date aside).
    let o = common::run(
        &d,
        "compensate part.ngc --map map.csv --setup machine.toml -o -",
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
    std::fs::write(&bad, "G21 G90\nG0 X0 Y0 Z5\nG1 X10 F100\nG7.5 X3\nM2\n").unwrap();
    let (code, filtered, _, text) = run_as_axis(&d, &filter, &bad);
    assert_ne!(code, 0);
    let message = text.join("\n");
    assert!(message.contains("bad.ngc:4"), "{message}");
    assert!(filtered.is_empty(), "{filtered}");
}

#[test]
fn header_content_and_refusal_of_double_compensation() {
    let d = fixture("header");
    write(&d, "part.ngc", format!("%\nO0042 (PART)\n{PROGRAM}%\n"));
    let o = common::command(
        &d,
        "compensate part.ngc --map map.csv --setup machine.toml -o out.ngc",
    )
    .env("SOURCE_DATE_EPOCH", "951782400")
    .output()
    .unwrap();
    common::ok(&o);
    let out = read(&d, "out.ngc");
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
    let o = common::run(
        &d,
        "compensate out.ngc --map map.csv --setup machine.toml -o again.ngc",
    );
    let e2 = stderr(&o);
    // Compensating twice refuses the program (exit 3, docs/errors.md).
    assert_eq!(o.status.code(), Some(3), "{e2}");
    assert!(
        e2.contains("out.ngc:3") && e2.contains("--allow-recompensate"),
        "{e2}"
    );
    assert!(!d.join("again.ngc").exists());
    common::ok(&common::run(
        &d,
        "compensate out.ngc --map map.csv --setup machine.toml --allow-recompensate -o again.ngc",
    ));
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
    write(&d, "part.ngc", format!("%\n{PROGRAM}%\n"));
    let o = compensate_to(&d, "out.ngc");
    common::ok(&o);
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

/// A 2-D program (no Z word anywhere) on a map whose error is the constant
/// (10, 0, 5) µm: each command is by hand the target − (0.010, 0, 0.005) mm.
#[test]
fn a_program_that_never_sets_z_is_compensated_from_the_start_or_refused_or_counted() {
    let d = common::tempdir("axis-never-set");
    std::fs::write(
        d.join("map.csv"),
        "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
         X,both,-10,10,0,0\nX,both,100,10,0,0\nY,both,-10,0,0,0\nY,both,100,0,0,0\n\
         Z,both,-10,0,0,5\nZ,both,100,0,0,5\n",
    )
    .unwrap();
    let program = "G21 G90\nG0 X0 Y0\nG1 X10 Y10 F100\nG1 X20 Y0\nM2\n";
    write(&d, "p.ngc", program);
    write(
        &d,
        "start.toml",
        "units = \"mm\"\nstart = [0, 0, 20]\n[work_offsets]\nG54 = [0, 0, 0]\n",
    );
    write(
        &d,
        "nostart.toml",
        "units = \"mm\"\n[work_offsets]\nG54 = [0, 0, 0]\n",
    );
    let run = |setup: &str, out: &str, extra: &[&str]| {
        let mut args = vec![
            "compensate",
            "p.ngc",
            "--map",
            "map.csv",
            "--setup",
            setup,
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        volcomp(&args, &d)
    };

    // With the set-up's start (Z = 20): compensated, the Z word written.
    let o = run("start.toml", "a.ngc", &[]);
    common::ok(&o);
    let a = read(&d, "a.ngc");
    assert!(
        a.starts_with(volcomp_core::io::provenance::FIRST_LINE),
        "{a}"
    );
    assert!(
        a.ends_with(
            "G21 G90\nG0 X-0.01000 Y0 Z19.99500\nG1 X9.99000 Y10 F100\nG1 X19.99000 Y0\nM2\n"
        ),
        "{a}"
    );
    common::said(&o, "3 points compensated");
    // Simulated on the map from the same start: the original ends every
    // feed move |(10, 0, 5)| = √125 = 11.180 µm off, the compensated one on
    // the point.
    let point_max = |program: &str, reference: Option<&str>| {
        let mut args = vec![
            "simulate",
            program,
            "--map",
            "map.csv",
            "--setup",
            "start.toml",
            "--json",
        ];
        if let Some(r) = reference {
            args.extend(["--reference", r]);
        }
        let v = common::json(&volcomp(&args, &d));
        v["point_max_um"].as_f64().unwrap()
    };
    assert!((point_max("p.ngc", None) - 125f64.sqrt()).abs() < 1e-6);
    assert!(point_max("a.ngc", Some("p.ngc")) < 1e-6);

    // Without a start: refused (exit 3, a refused program) at line 3,
    // column 4, nothing written.
    let o = run("nostart.toml", "b.ngc", &[]);
    let msg = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{msg}");
    assert!(
        msg.contains("p.ngc:3:4: this move cannot be compensated: the program has not set Z"),
        "{msg}"
    );
    assert!(msg.contains("in the set-up file (--setup)"), "{msg}");
    assert!(msg.contains("--allow-uncompensated-axes"), "{msg}");
    assert!(!d.join("b.ngc").exists());

    // Allowed: written as it is, the header and the summary say so.
    let o = run("nostart.toml", "c.ngc", &["--allow-uncompensated-axes"]);
    common::ok(&o);
    let msg = stderr(&o);
    assert!(
        msg.contains("0 points compensated, 2 feed moves NOT compensated"),
        "{msg}"
    );
    assert!(
        msg.contains("volcomp: warning: 2 feed moves NOT compensated, the first on line 3: the program never set Z before them and the set-up gives no start; they are written as they are"),
        "{msg}"
    );
    let c = read(&d, "c.ngc");
    assert!(
        c.starts_with(volcomp_core::io::provenance::FIRST_LINE_PARTIAL),
        "{c}"
    );
    assert!(!c.contains(volcomp_core::io::provenance::FIRST_LINE), "{c}");
    assert!(
        c.contains("(WARNING 2 feed moves NOT compensated, the first on line 3: the program never"),
        "{c}"
    );
    assert!(c.ends_with(program), "{c}");
    assert_eq!(
        volcomp_core::io::provenance::strip_header(&c),
        program,
        "{c}"
    );
    // Such a program is marked: compensating it again is refused.
    write(&d, "c2.ngc", &c);
    let o = common::run(
        &d,
        "compensate c2.ngc --map map.csv --setup start.toml -o d.ngc",
    );
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&d);
}
