//! What the library's tests share: maps made by hand, a walker over a
//! program held in memory, a compensation of such a program, and LinuxCNC's
//! `rs274` where it is installed (and a failure under CI where it is not).
#![allow(dead_code)]

use std::io::Cursor;
use std::path::PathBuf;
use volcomp_core::compensate::{
    compensate_program, survey_style, CompensateOptions, CompensateSummary, PointRecord,
};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_core::simulate::report::{simulate_program, SimReport};
use volcomp_gcode::{InterpOptions, Setup, Walker};

/// A map of zeros over ±10 m on every axis: compensation changes nothing,
/// so every expected number is the program's own.
pub fn zero_map() -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for axis in ["X", "Y", "Z"] {
        csv.push_str(&format!(
            "{axis},both,-10000,0,0,0\n{axis},both,10000,0,0,0\n"
        ));
    }
    AxisTableMap::from_csv(&csv, "zero.csv").unwrap()
}

/// A map over −100…300 mm in 4 mm rows whose errors (µm) on axis `a`
/// (0 = X) at position `p` in direction `reverse` are `f(a, p, reverse)`.
pub fn map_from(f: impl Fn(usize, f64, bool) -> [f64; 3]) -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, name) in ["X", "Y", "Z"].iter().enumerate() {
        for (dir, rev) in [("forward", false), ("reverse", true)] {
            for k in 0..=100 {
                let p = -100.0 + 4.0 * k as f64;
                let e = f(a, p, rev);
                csv.push_str(&format!("{name},{dir},{p},{},{},{}\n", e[0], e[1], e[2]));
            }
        }
    }
    AxisTableMap::from_csv(&csv, "test.csv").unwrap()
}

/// A map whose axes in `fine` (0 = X) have tables over −50…50 mm every
/// 0.25 mm and the others two rows at ±`coarse_half_mm` (so their errors
/// should not depend on the position); the errors (µm) of axis `a` at
/// position `p` in direction `reverse` are `f(a, p, reverse)`. The
/// hand-built maps of the take-up tests: a shape in µm on a fine grid, and
/// a band (a reverse table) elsewhere.
pub fn map_fine_on(
    fine: &[usize],
    coarse_half_mm: f64,
    f: impl Fn(usize, f64, bool) -> [f64; 3],
) -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, name) in ["X", "Y", "Z"].iter().enumerate() {
        for (dir, rev) in [("forward", false), ("reverse", true)] {
            let rows: Vec<f64> = if fine.contains(&a) {
                (0..=400).map(|k| -50.0 + 0.25 * k as f64).collect()
            } else {
                vec![-coarse_half_mm, coarse_half_mm]
            };
            for p in rows {
                let e = f(a, p, rev);
                csv.push_str(&format!("{name},{dir},{p},{},{},{}\n", e[0], e[1], e[2]));
            }
        }
    }
    AxisTableMap::from_csv(&csv, "test.csv").unwrap()
}

/// A walker over `program` named `name`, with the default set-up and
/// interpreter options.
pub fn walker(program: &str, name: &str) -> Walker<Cursor<Vec<u8>>> {
    Walker::new(
        Cursor::new(program.as_bytes().to_vec()),
        Some(name.into()),
        Setup::default(),
        InterpOptions::default(),
    )
}

/// End points of the motions of `program` (axis frame), zero-length ones
/// dropped.
pub fn motion_ends(program: &str) -> Vec<volcomp_gcode::Vec3> {
    let mut w = walker(program, "test.ngc");
    let mut out = Vec::new();
    while let Some(ev) = w.next_line().unwrap() {
        for m in ev.motions {
            if out.last() != Some(&m.end) {
                out.push(m.end);
            }
        }
    }
    out
}

/// The motions of the written program `out` end where `program`'s do,
/// moved by `shift_mm` (to 1 nm; the start point is not compared).
pub fn assert_shifted(program: &str, out: &str, shift_mm: volcomp_gcode::Vec3) {
    let nominal = motion_ends(program);
    let written = motion_ends(out);
    assert_eq!(nominal.len(), written.len(), "{out}");
    for (t, q) in nominal.iter().zip(&written).skip(1) {
        assert!(
            (*q - (*t + shift_mm)).max_abs() < 1e-9,
            "{q:?} vs {t:?}\n{out}"
        );
    }
}

/// `program` (named `name`) compensated for `map` with `options` on the
/// default set-up: the written program, or the error's text.
pub fn compensate_text(
    program: &str,
    name: &str,
    map: &AxisTableMap,
    options: &CompensateOptions,
) -> Result<String, String> {
    let mut out = Vec::new();
    compensate_program(
        &mut walker(program, name),
        name,
        map,
        &survey_style(program.as_bytes()),
        options,
        &mut out,
        |_| {},
    )
    .map_err(|e| e.to_string())?;
    Ok(String::from_utf8(out).unwrap())
}

/// `program` (named `test.ngc`) compensated for `map` at `decimals`
/// decimals, the other options the defaults, each solved point given to
/// `on_point`: the written program and the summary.
fn compensate_with(
    program: &str,
    map: &AxisTableMap,
    decimals: u8,
    on_point: impl FnMut(&PointRecord),
) -> (String, CompensateSummary) {
    let options = CompensateOptions {
        decimals: Some(decimals),
        ..Default::default()
    };
    let mut out = Vec::new();
    let summary = compensate_program(
        &mut walker(program, "test.ngc"),
        "test.ngc",
        map,
        &survey_style(program.as_bytes()),
        &options,
        &mut out,
        on_point,
    )
    .unwrap();
    (String::from_utf8(out).unwrap(), summary)
}

/// `program` (named `test.ngc`) compensated for `map` at 5 decimals, the
/// other options the defaults, every solved point recorded: the written
/// program, the points and the summary.
pub fn compensate_recorded(
    program: &str,
    map: &AxisTableMap,
) -> (String, Vec<PointRecord>, CompensateSummary) {
    let mut records = Vec::new();
    let (text, summary) = compensate_with(program, map, 5, |r| records.push(*r));
    (text, records, summary)
}

/// `program` compensated for `map` as [`compensate_recorded`] does, and the
/// ratio of its cutting time to the original's on the planner model
/// ([`cutting_s`]).
pub fn compensated_time_ratio(program: &str, map: &AxisTableMap) -> (String, f64) {
    let (out, _, _) = compensate_recorded(program, map);
    let ratio = cutting_s(&out) / cutting_s(program);
    (out, ratio)
}

/// `program` (named `test.ngc`) compensated for `map` at `decimals`
/// decimals, the other options the defaults, without the lines of the
/// approach before the first cut (tests/compensation.rs checks them): the
/// written program and the summary.
pub fn compensate_cut(
    program: &str,
    map: &AxisTableMap,
    decimals: u8,
) -> (String, CompensateSummary) {
    let (out, summary) = compensate_with(program, map, decimals, |_| {});
    let text = out
        .lines()
        .filter(|l| !l.ends_with("approach)"))
        .map(|l| format!("{l}\n"))
        .collect();
    (text, summary)
}

/// The compensated program `out` run through the dead-band simulation of
/// `map` and measured against the original `program`, arcs followed within
/// a chord tolerance of 0.1 µm: the report.
pub fn simulated(out: &str, program: &str, map: &AxisTableMap) -> SimReport {
    simulate_program(
        &mut walker(out, "out"),
        "out",
        Some(&mut walker(program, "test.ngc")),
        map,
        1e-4,
        |_| {},
    )
    .unwrap()
}

/// The axis-table map `name` kept in tests/data (a map a bench script
/// wrote, copied there).
pub fn data_map(name: &str) -> AxisTableMap {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    AxisTableMap::from_csv(&std::fs::read_to_string(path).unwrap(), name).unwrap()
}

/// The cutting time (s) of `program` on the planner model (LinuxCNC 2.9's
/// planner; `plan::estimate_program`) with the default set-up and limits.
pub fn cutting_s(program: &str) -> f64 {
    let setup = volcomp_core::compensate::MachineSetup::default();
    let limits = volcomp_core::plan::Limits::default();
    volcomp_core::plan::estimate_program(program.as_bytes(), "t.ngc", &setup, &limits)
        .unwrap()
        .motion
        .cutting_s
}

/// LinuxCNC's stand-alone interpreter, where it is installed. Where it is
/// not, a test under CI (the `CI` variable set) fails, since CI installs it
/// (`.ci/run`); elsewhere the caller skips its rs274 part, said loudly.
pub fn rs274(not_checked: &str) -> Option<PathBuf> {
    let found = ["/usr/bin/rs274", "/usr/local/bin/rs274"]
        .into_iter()
        .map(PathBuf::from)
        .find(|p| p.exists());
    if found.is_none() {
        if std::env::var_os("CI").is_some() {
            panic!("rs274 (LinuxCNC's stand-alone interpreter, Debian package linuxcnc-uspace) is not installed, and CI is set: CI must install it (.ci/run does)");
        }
        eprintln!("!! SKIPPED: rs274 is not installed: {not_checked} was NOT checked");
    }
    found
}

/// rs274's error on `program`, `None` when it accepts it; skipped (`Some(None)`
/// never) when rs274 is not installed ([`rs274`], `not_checked` says what).
pub fn rs274_refusal(program: &str, not_checked: &str) -> Option<Option<String>> {
    let rs274 = rs274(not_checked)?;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("t.ngc");
    std::fs::write(&file, program).unwrap();
    let out = std::process::Command::new(rs274)
        .arg("-g")
        .arg(&file)
        .arg(dir.path().join("out.txt"))
        .env("HOME", dir.path())
        .current_dir(dir.path())
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    let msg: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "executing")
        .collect();
    Some((!out.status.success() || !msg.is_empty()).then(|| msg.join(" | ")))
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
