//! `volcomp moves` against LinuxCNC's `rs274` on an external corpus of real
//! programs: the measurement behind "volcomp reads what LinuxCNC reads".
//!
//! The corpus is not bundled (hundreds of programs under their own
//! licences); name its directory with `VOLCOMP_EVAL_CORPUS` and run
//!
//! ```text
//! VOLCOMP_EVAL_CORPUS=/path/to/programs \
//!   cargo test -p volcomp-cli --test cli_tests rs274_corpus:: -- --ignored --nocapture
//! ```
//!
//! Every file ending in `.ngc`, `.nc`, `.gcode`, `.tap` or `.cnc` below the
//! directory is run through both interpreters with the set-up of the
//! agreement test (`rs274_agreement.rs`). Each program falls in one class:
//!
//! * both accept → compared motion by motion (a difference is a failure);
//! * rs274 accepts, volcomp refuses → counted, grouped by volcomp's message;
//! * rs274 refuses, volcomp accepts → a failure (volcomp must not accept
//!   what LinuxCNC refuses), unless volcomp's motions end where rs274's
//!   stopped at its error (rs274 refused at run time, volcomp at …);
//! * both refuse → counted, grouped by rs274's message.
//!
//! A program that rs274 runs to its last line and then refuses only for the
//! way the file ends — no M2/M30 ("File ended with no percent sign or
//! program end", "File ended with no percent sign") or a stray `%` as its
//! last line ("Bad character '%' used") — has run on LinuxCNC: every motion
//! was made. It counts as accepted by rs274 and is compared like the others
//! (volcomp accepts it with a warning that says what LinuxCNC reports).
//!
//! Every program both accept is then compensated (`volcomp compensate`,
//! default options) for a ripple map defined over ±20 m (3 µm positioning and
//! 1 µm straightness waves of 40 mm, 30 mm and 25 mm period on X, Y and Z,
//! so the correction is at most 5·√3 ≈ 8.7 µm), and the compensated program
//! must be accepted by rs274 and follow the original path: each original
//! motion's end point is matched, in order, by an end point of the
//! compensated program within the largest correction plus rs274's printing
//! tolerance.
//!
//! `VOLCOMP_EVAL_REPORT` names a file for the full per-program table;
//! `VOLCOMP_EVAL_BIN` names another `volcomp` binary to measure (an older
//! build, for a before/after figure).
//! The test fails on any disagreement; the acceptance rate is printed (the
//! issue's target is at least 95 % of what rs274 accepts).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::rs274;

use rs274::compare::compare;
use rs274::*;

/// Differences that are artifacts of the stand-alone `rs274`, not of
/// LinuxCNC: reported, not failed. (File name, why.)
const RS274_ARTIFACTS: &[(&str, &str)] = &[
    (
        "nc_files/skeleton.ngc",
        "`T1 M06 G43 H1` on one line: after M6 the interpreter re-reads the position from the canonical layer at the next block; LinuxCNC's (emccanon.cc GET_EXTERNAL_POSITION_*) subtracts the new tool offset, the stand-alone rs274's (saicanon.cc) does not, so rs274 alone moves Z by the tool length on the next move",
    ),
    (
        "nc_files/mmount.ngc",
        "`T1 M6 G43` on one line, at each tool change: the same stand-alone rs274 artifact as skeleton.ngc (saicanon.cc does not subtract the new tool offset when the position is re-read after M6)",
    ),
    (
        "violation_checks/tap-discrimant-error-orig.ngc",
        "G43 in G20, then G21: on a change of units the interpreter re-reads the tool offset from the canonical layer (convert_length_units); LinuxCNC's (emccanon.cc GET_EXTERNAL_TOOL_LENGTH_ZOFFSET) converts it to the new units, the stand-alone rs274's (saicanon.cc) returns the number it was given in the old ones, so rs274 alone takes a tool length of 2 in as 2 mm",
    ),
];

/// Seconds either interpreter may take on one program.
const TIMEOUT_S: u32 = 120;

/// Largest rs274 output (512-byte blocks: 64 MB).
const MAX_OUTPUT_BLOCKS: u32 = 131_072;

fn programs(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = rd.filter_map(|e| e.ok()).map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            programs(&p, out);
        } else if let Some(ext) = p.extension().and_then(|e| e.to_str()) {
            if ["ngc", "nc", "gcode", "tap", "cnc"].contains(&ext.to_ascii_lowercase().as_str()) {
                out.push(p);
            }
        }
    }
}

enum Class {
    /// Both accept and agree (motions; whether rs274 ran to the end of the
    /// file and then complained about the way it ends).
    Agree(usize, bool),
    Mismatch(Vec<String>),
    Refused(String),
    AcceptedRejected(String),
    /// rs274's message.
    BothRefuse(String),
}

/// Whether rs274's refusal `why` of `program` comes only after it ran every
/// line: the file ends without M2/M30 (or without the `%` that closes a
/// program opened by `%`), or its last non-blank line is its only stray `%`
/// line (`Interp::read`, src/emc/rs274ngc/interp_read.cc `read_text`).
fn ran_to_end(why: &str, program: &Path) -> bool {
    if why.contains("File ended with no percent sign") {
        return true;
    }
    if !why.contains("Bad character '%' used") {
        return false;
    }
    let Ok(bytes) = std::fs::read(program) else {
        return false;
    };
    let lines: Vec<&[u8]> = bytes
        .split(|&b| b == b'\n')
        .map(|l| l.trim_ascii())
        .filter(|l| !l.is_empty())
        .collect();
    let percents = lines.iter().filter(|l| l.starts_with(b"%")).count();
    lines.last().is_some_and(|l| l.starts_with(b"%")) && percents == 1
}

/// rs274's message without its exit status, for grouping.
fn rs274_cause(why: &str) -> String {
    let msg = why.split_once(": ").map_or(why, |(_, m)| m);
    msg.split(" | ")
        .next()
        .unwrap_or(msg)
        .chars()
        .take(90)
        .collect()
}

/// The first line of volcomp's error message, without its location, so that
/// refusals group by cause.
fn cause(stderr: &str) -> String {
    let line = stderr
        .lines()
        .find(|l| l.contains("error"))
        .unwrap_or_else(|| stderr.lines().next().unwrap_or(""));
    let msg = line.rsplit(": ").next().unwrap_or(line);
    msg.trim().chars().take(90).collect()
}

#[test]
#[ignore = "needs VOLCOMP_EVAL_CORPUS and rs274"]
fn external_corpus() {
    let Some(dir) = std::env::var_os("VOLCOMP_EVAL_CORPUS").map(PathBuf::from) else {
        panic!("set VOLCOMP_EVAL_CORPUS to a directory of G-code programs");
    };
    let rs274 = find_rs274().expect("rs274 is not installed (apt install linuxcnc-uspace)");
    let mut files = Vec::new();
    programs(&dir, &mut files);
    assert!(!files.is_empty(), "no programs below {}", dir.display());

    let work = std::env::temp_dir().join(format!("volcomp-rs274-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&work).unwrap();
    // rs274 may loop for ever on a bad program (LinuxCNC's own tests have
    // endless G71 loops): run it under `timeout` and a file-size limit
    // (512-byte blocks in POSIX sh), so a runaway run is a rejection.
    let wrapper = work.join("rs274-timeout.sh");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/sh\nulimit -f {MAX_OUTPUT_BLOCKS}\nexec timeout {TIMEOUT_S} {} \"$@\"\n",
            rs274.display()
        ),
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let map = work.join("ripple.csv");
    std::fs::write(&map, ripple_map()).unwrap();
    let setup = work.join("setup.toml");
    std::fs::write(&setup, setup_toml()).unwrap();
    let tool_table = work.join("tools.tbl");
    std::fs::write(&tool_table, rs274_tool_table()).unwrap();
    let tools = Tools {
        rs274: wrapper,
        volcomp: std::env::var_os("VOLCOMP_EVAL_BIN").map_or_else(
            || PathBuf::from(env!("CARGO_BIN_EXE_volcomp")),
            PathBuf::from,
        ),
        dir: work.clone(),
        setup,
        tool_table,
        var_text: rs274_var_file(),
    };

    let results: Mutex<Vec<(PathBuf, Class)>> = Mutex::new(Vec::new());
    let next = Mutex::new(0usize);
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(2);
    std::thread::scope(|s| {
        for t in 0..threads {
            let (files, tools, results, next, work, map) =
                (&files, &tools, &results, &next, &work, &map);
            s.spawn(move || loop {
                let i = {
                    let mut n = next.lock().unwrap();
                    let i = *n;
                    *n += 1;
                    i
                };
                let Some(path) = files.get(i) else { break };
                let w = work.join(format!("t{t}-{i}"));
                let class = classify(tools, path, &w, map);
                if std::env::var_os("VOLCOMP_EVAL_KEEP").is_none() {
                    let _ = std::fs::remove_dir_all(&w);
                }
                results.lock().unwrap().push((path.clone(), class));
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort_by(|a, b| a.0.cmp(&b.0));

    let (mut agree, mut refused, mut both, mut motions, mut to_end) = (0, 0, 0, 0usize, 0);
    let mut both_causes: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut causes: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut table = String::from("| program | result |\n|---|---|\n");
    for (path, class) in &results {
        let name = path
            .strip_prefix(&dir)
            .unwrap_or(path)
            .display()
            .to_string();
        let row = match class {
            Class::Agree(n, end) => {
                agree += 1;
                motions += n;
                to_end += usize::from(*end);
                if *end {
                    format!("agree ({n} motions; rs274 ran to the end, then refused the way the file ends)")
                } else {
                    format!("agree ({n} motions)")
                }
            }
            Class::Mismatch(f) => match RS274_ARTIFACTS.iter().find(|(n, _)| name.ends_with(n)) {
                Some((_, why)) => {
                    println!("known rs274 artifact, not a failure: {name}: {why}");
                    format!("differs (rs274 artifact: {why})")
                }
                None => {
                    failures.push(format!("{name}: {}", f.join("; ")));
                    format!("MISMATCH: {}", f.join("; "))
                }
            },
            Class::Refused(c) => {
                refused += 1;
                causes.entry(c.clone()).or_default().push(name.clone());
                format!("refused by volcomp: {c}")
            }
            Class::AcceptedRejected(why) => {
                match RS274_ARTIFACTS.iter().find(|(n, _)| name.ends_with(n)) {
                    Some((_, art)) => {
                        println!("known rs274 artifact, not a failure: {name}: {art}");
                        format!("accepted, rs274 refuses (rs274 artifact: {art})")
                    }
                    None => {
                        failures.push(format!(
                            "{name}: volcomp accepts a program rs274 rejects ({why})"
                        ));
                        format!("ACCEPTED although rs274 rejects: {why}")
                    }
                }
            }
            Class::BothRefuse(why) => {
                both += 1;
                both_causes
                    .entry(rs274_cause(why))
                    .or_default()
                    .push(name.clone());
                format!("both refuse (rs274: {})", rs274_cause(why))
            }
        };
        table.push_str(&format!("| {name} | {row} |\n"));
    }
    let accepted_by_rs274 = agree + refused + failures.len();
    println!(
        "{} programs; rs274 accepts {accepted_by_rs274} (of which {to_end} run to the end of the file, then refused for the way it ends); volcomp accepts and agrees on {agree} ({:.1} %, {motions} motions); volcomp refuses {refused}; both refuse {both}; disagreements {}",
        results.len(),
        100.0 * agree as f64 / accepted_by_rs274.max(1) as f64,
        failures.len()
    );
    let mut by_count: Vec<_> = causes.into_iter().collect();
    by_count.sort_by_key(|b| std::cmp::Reverse(b.1.len()));
    for (c, names) in &by_count {
        println!("  {:4} × {c}   e.g. {}", names.len(), names[0]);
    }
    let mut both_by_count: Vec<_> = both_causes.into_iter().collect();
    both_by_count.sort_by_key(|b| std::cmp::Reverse(b.1.len()));
    println!("both refuse, by rs274's message:");
    for (c, names) in &both_by_count {
        println!("  {:4} × {c}   e.g. {}", names.len(), names[0]);
    }
    if let Some(report) = std::env::var_os("VOLCOMP_EVAL_REPORT") {
        std::fs::write(report, &table).unwrap();
    }
    for f in &failures {
        println!("FAIL {f}");
    }
    if std::env::var_os("VOLCOMP_EVAL_KEEP").is_none() {
        let _ = std::fs::remove_dir_all(&work);
    } else {
        println!("work files kept in {}", work.display());
    }
    assert!(failures.is_empty(), "{} disagreements", failures.len());
}

/// Largest correction of [`ripple_map`] (mm): 3 + 1 + 1 µm per component.
const MAX_CORRECTION_MM: f64 = 5.0e-3 * 1.732_050_808;

/// The ripple map of the module doc, as an axis-table CSV.
fn ripple_map() -> String {
    rs274::ripple_map(20_000.0)
}

/// Whether every motion of `original` is matched in order by a motion of
/// `compensated` ending within `tol` mm (per axis) of it; the first miss.
fn follows(original: &[RefMotion], compensated: &[RefMotion]) -> Result<(), String> {
    let mut j = 0;
    for (i, m) in original.iter().enumerate() {
        // A NURBS block has no single end point in rs274's output (its
        // control points are compared by the agreement part); a motion that
        // does not move (a cycle's rapid to where the tool already is) may
        // be left out of the compensated program.
        if m.end.iter().any(|v| v.is_nan()) {
            continue;
        }
        if i > 0 && (0..3).all(|a| (original[i - 1].end[a] - m.end[a]).abs() < 1e-9) {
            continue;
        }
        let tol = MAX_CORRECTION_MM + m.tol.iter().cloned().fold(0.0, f64::max);
        let close = |c: &RefMotion| (0..3).all(|a| (c.end[a] - m.end[a]).abs() <= tol);
        match compensated[j..].iter().position(close) {
            Some(k) => j += k + 1,
            None => {
                return Err(format!(
                    "original motion #{i} ({}) has no compensated counterpart within {:.4} mm",
                    rs274::compare::describe_ref(m),
                    tol
                ))
            }
        }
    }
    Ok(())
}

fn compensate_and_check(
    tools: &Tools,
    path: &Path,
    work: &Path,
    map: &Path,
    original: &[RefMotion],
    to_end: bool,
) -> Result<(), String> {
    let out = work.join("compensated.ngc");
    let compensate = |extra: &[&str]| {
        std::process::Command::new(&tools.volcomp)
            .arg("compensate")
            .arg("--map")
            .arg(map)
            .arg("--setup")
            .arg(&tools.setup)
            .arg("-o")
            .arg(&out)
            .args(extra)
            .arg(path)
            .stdin(std::process::Stdio::null())
            .output()
            .map_err(|e| format!("cannot run volcomp: {e}"))
    };
    let mut run = compensate(&[])?;
    // Under G93 volcomp does not split moves by default (a split would
    // change each block's duration): its message says to pass --no-split.
    if !run.status.success() && String::from_utf8_lossy(&run.stderr).contains("--no-split") {
        run = compensate(&["--no-split"])?;
    }
    if !run.status.success() {
        return Err(format!(
            "volcomp compensate refuses a program it reads: {}",
            cause(&String::from_utf8_lossy(&run.stderr))
        ));
    }
    let rs = run_rs274(tools, &out, &work.join("out"))?;
    if let Some(why) = rs.rejected {
        let accepted = why.starts_with("exit status: 0:") || (to_end && ran_to_end(&why, &out));
        if !accepted {
            return Err(format!("rs274 rejects the compensated program: {why}"));
        }
    }
    follows(original, &rs.motions)
}

fn classify(tools: &Tools, path: &Path, work: &Path, map: &Path) -> Class {
    let rs = match run_rs274(tools, path, work) {
        Ok(r) => r,
        Err(e) => return Class::Mismatch(vec![format!("rs274 output unreadable: {e}")]),
    };
    let vol = run_volcomp(tools, path, &[]);
    // rs274 prints `(print, …)` and `(debug, …)` comments: only its exit
    // status tells a rejection.
    let rejected = rs
        .rejected
        .filter(|why| !why.starts_with("exit status: 0:"));
    // Refused only for the way the file ends, after every line ran.
    let to_end = rejected.as_deref().is_some_and(|why| ran_to_end(why, path));
    let rejected = rejected.filter(|_| !to_end);
    match (rejected, vol) {
        (None, Ok(v)) => {
            let c = compare("", &rs.motions, &v);
            if !c.failures.is_empty() {
                return Class::Mismatch(c.failures);
            }
            match compensate_and_check(tools, path, work, map, &rs.motions, to_end) {
                Ok(()) => Class::Agree(c.pairs, to_end),
                Err(e) => Class::Mismatch(vec![e]),
            }
        }
        (None, Err(e)) => Class::Refused(cause(&e)),
        (Some(why), Ok(_)) => Class::AcceptedRejected(why.chars().take(200).collect()),
        (Some(why), Err(_)) => Class::BothRefuse(why),
    }
}
