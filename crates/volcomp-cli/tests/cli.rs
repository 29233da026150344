//! The command line as a user meets it: refusals with located messages,
//! nothing half-written, the input never overwritten.

use std::path::{Path, PathBuf};

use crate::common;
use common::{read, stderr, tempdir, volcomp, write};

/// A map over −100…300 mm with `ex_um` on X given by `f(position)`.
fn write_map(dir: &Path, f: impl Fn(f64) -> f64) -> PathBuf {
    let mut csv = String::from("# test map\naxis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for a in ["X", "Y", "Z"] {
        for k in 0..=40 {
            let p = -100.0 + 10.0 * k as f64;
            let e = if a == "X" { f(p) } else { 0.0 };
            csv.push_str(&format!("{a},both,{p},{e},0,0\n"));
        }
    }
    let path = dir.join("map.csv");
    std::fs::write(&path, csv).unwrap();
    path
}

const PROGRAM: &str = "G21 G90\nG0 X0 Y0 Z0\nG1 X10 F100\nG1 Y10\nM2\n";

#[test]
fn refused_constructs_name_file_line_column_and_write_nothing() {
    let dir = tempdir("refuse");
    write_map(&dir, |_| 0.0);
    let cases = [
        ("G41 D1\n", 1, 5, "diameter the set-up does not give"),
        ("G1 X#<nope> F10\n", 1, 5, "#<nope> is not defined"),
        ("G0 X0 Y0 Z0\nG1 X[1/0] F10\n", 2, 7, "division by zero"),
        ("G0 X0\nG68 X0 Y0 R30\n", 2, 1, "rotation"),
        ("G51 X0 Y0 P2\n", 1, 1, "scaling"),
        ("G16\n", 1, 1, "polar"),
        ("G0 X0\nG0 G70 X1\n", 2, 4, "G70"),
        (
            "G0 X0 Y0 Z0\nG81 X1 Y1 Z-1 R1 A3 F100\n",
            2,
            18,
            "canned cycle",
        ),
        ("G0 X0 Y0 Z0\nG38.2 Z-5 F100\n", 2, 1, "probe"),
        ("G0 X0 Y0 Z0\nM66 P0 L0\n", 2, 1, "input"),
        ("G1 X10 F100 (unclosed\n", 1, 13, "not closed"),
        ("X10\n", 1, 1, "motion mode"),
        (
            "G0 X0 Y0 Z0\nG2 X10 Y0 I3 J0 F100\n",
            2,
            1,
            "radius to end of arc",
        ),
        (
            "G0 X0 Y0 Z0\nG2 X10 Y0 I5 J0 K1 F100\n",
            2,
            17,
            "K word given for an arc",
        ),
        ("M98 P100\n", 1, 1, "no line O100"),
        ("G0 X0 Y0 Z0\nG33 Z-5 K1\n", 2, 1, "Spindle not turning"),
        ("G0 X1 X2\n", 1, 7, "twice"),
        ("G0 G1 X1\n", 1, 4, "same modal group"),
        (
            "G0 X0 Y0 Z5\nG83 X1 Y1 Z-5 R1 Q0 F100\n",
            2,
            18,
            "zero Q value",
        ),
        ("G0 X0 Y0 Z0\nG43 H7 Z5\n", 2, 1, "tool 7"),
        ("G0 X0 Y0 Z0\nG1 X1 F-5\n", 2, 7, "negative feed"),
        (
            "G0 X0 Y0 Z0\nG10 L20 P1 R30 X0\n",
            2,
            12,
            "R is not allowed with G10 L20",
        ),
        ("G0 X0 Y0 Z0\nG3 X1 Y1 P0.5 R1 F10\n", 2, 10, "turns"),
    ];
    for (program, line, col, words) in cases {
        write(&dir, "p.ngc", program);
        let o = common::run(&dir, "compensate p.ngc --map map.csv -o out.ngc");
        let msg = stderr(&o);
        // A refused program (exit 3, docs/errors.md).
        assert_eq!(o.status.code(), Some(3), "{program}: {msg}");
        assert!(
            msg.contains(&format!("p.ngc:{line}:{col}:")),
            "{program}: {msg}"
        );
        assert!(
            msg.to_lowercase().contains(&words.to_lowercase()),
            "{program}: {msg}"
        );
        assert!(msg.contains("help:"), "says what to do: {msg}");
        assert!(
            !dir.join("out.ngc").exists(),
            "nothing written for {program}"
        );
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    }
}

#[test]
fn a_map_in_millimetres_is_refused() {
    let dir = tempdir("mm");
    // 0.15 "µm" per mm means 45 µm at 300 mm… a map written in mm instead of
    // µm has values 1000 times too large: 150 at X = 10 here.
    write_map(&dir, |p| 15.0 * p);
    write(&dir, "p.ngc", PROGRAM);
    let o = common::run(&dir, "compensate p.ngc --map map.csv -o out.ngc");
    let msg = stderr(&o);
    // A correction above its limit refuses the program (exit 3, docs/errors.md).
    assert_eq!(o.status.code(), Some(3), "{msg}");
    assert!(msg.contains("p.ngc:3:") && msg.contains("µm"), "{msg}");
    assert!(!dir.join("out.ngc").exists());
}

#[test]
fn out_of_range_names_axis_position_range_and_line() {
    let dir = tempdir("range");
    write_map(&dir, |_| 1.0);
    write(&dir, "p.ngc", "G0 X0 Y0 Z0\nG1 X350 F100\nM2\n");
    let o = common::run(&dir, "compensate p.ngc --map map.csv -o out.ngc --no-split");
    let msg = stderr(&o);
    assert!(
        msg.contains("p.ngc:2:")
            && msg.contains("axis X = 350 mm")
            && msg.contains("-100 … 300 mm"),
        "{msg}"
    );
    // No --setup, no --work-offset: said first, in the warning and the error.
    assert!(
        msg.starts_with("volcomp: warning: no work offset was given (G54 = 0)"),
        "{msg}"
    );
    assert!(
        msg.contains("error: no work offset was given (G54 = 0): p.ngc:2:")
            || msg.contains("no work offset was given (G54 = 0): p.ngc:2:"),
        "{msg}"
    );
    assert!(!dir.join("out.ngc").exists());
    // With --clamp the error is held at the table end.
    common::ok(&common::run(
        &dir,
        "compensate p.ngc --map map.csv -o out.ngc --no-split --clamp",
    ));
    let out = read(&dir, "out.ngc");
    assert!(out.contains("X349.9990"), "{out}");
}

#[test]
fn the_input_is_never_overwritten() {
    let dir = tempdir("overwrite");
    write_map(&dir, |_| 1.0);
    write(&dir, "p.ngc", PROGRAM);
    let o = common::run(&dir, "compensate p.ngc --map map.csv -o ./p.ngc");
    assert_eq!(o.status.code(), Some(2));
    common::said(&o, "refusing to write");
    assert_eq!(read(&dir, "p.ngc"), PROGRAM);
}

#[test]
fn bad_map_files_name_row_and_column() {
    let dir = tempdir("badmap");
    write(&dir, "p.ngc", PROGRAM);
    let cases = [
        (
            "axis,direction,position_mm,ex_um,ey_um,ez_um\nX,both,0,0,0,0\nX,both,10,NaN,0,0\n",
            "map.csv:3:4:",
        ),
        ("axis,direction,position_mm,ex_um,ey_um\n", "map.csv:1:6:"),
        (
            "axis,direction,position_mm,ex_um,ey_um,ez_um\nX,both,10,0,0,0\nX,both,5,0,0,0\n",
            "map.csv:3:3:",
        ),
        (
            "axis,direction,position_mm,ex_mm,ey_um,ez_um\n",
            "map.csv:1:4:",
        ),
        (
            "axis,direction,position_mm,ex_um,ey_um,ez_um\nQ,both,0,0,0,0\n",
            "map.csv:2:1:",
        ),
    ];
    for (csv, located) in cases {
        write(&dir, "map.csv", csv);
        let o = common::run(&dir, "compensate p.ngc --map map.csv -o out.ngc");
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(located), "{located}: {}", stderr(&o));
        assert!(!dir.join("out.ngc").exists());
    }
}

#[test]
fn simulate_json_reports_the_metrics_and_compensation_improves_them() {
    let dir = tempdir("simulate");
    // A linear pitch error of 0.2 µm/mm along X.
    write_map(&dir, |p| 0.2 * p);
    write(&dir, "p.ngc", PROGRAM);
    let sim = |args: &[&str]| -> serde_json::Value { common::json(&volcomp(args, &dir)) };
    let before = sim(&["simulate", "p.ngc", "--map", "map.csv", "--json"]);
    for key in [
        "point_rms_um",
        "point_max_um",
        "contour_rms_um",
        "contour_max_um",
        "blocks",
    ] {
        assert!(before.get(key).is_some(), "{key} missing: {before}");
    }
    // At X = 10 the tool is 2 µm long: point errors are 2 µm at (10,0) and (10,10).
    assert!(
        (before["point_max_um"].as_f64().unwrap() - 2.0).abs() < 1e-9,
        "{before}"
    );
    common::ok(&common::run(
        &dir,
        "compensate p.ngc --map map.csv -o c.ngc",
    ));
    let after = sim(&[
        "simulate",
        "c.ngc",
        "--map",
        "map.csv",
        "--reference",
        "p.ngc",
        "--json",
    ]);
    assert!(after["contour_max_um"].as_f64().unwrap() < 0.06, "{after}");
}

#[test]
fn moves_json_is_valid_and_lists_every_motion() {
    let dir = tempdir("moves");
    write(
        &dir,
        "p.ngc",
        "G21 G90\nG0 X1 Y2 Z3\nG2 X5 Y2 I2 J0 F100\nM2\n",
    );
    let v = common::json(&common::run(
        &dir,
        "moves p.ngc --format json --work-offset 100,0,-50",
    ));
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["kind"], "arc_cw");
    assert_eq!(rows[1]["end_mm"][0].as_f64().unwrap(), 105.0);
    assert_eq!(rows[1]["center_mm"][0].as_f64().unwrap(), 103.0);
    assert_eq!(rows[1]["end_mm"][2].as_f64().unwrap(), -47.0);
}

#[test]
fn demo_runs_and_meets_the_issue_targets() {
    let dir = tempdir("demo");
    // `-o` as every command that writes takes it.
    let text = common::ok(&common::run(&dir, "demo -o d --markdown d/table.md"));
    // Every contour row's exact column (the fourth method) reduces the
    // error by at least 95 %: its change is −95 % or less.
    let mut rows = 0;
    for line in text.lines().filter(|l| l.starts_with("  contour")) {
        let changes: Vec<f64> = line
            .split_whitespace()
            .filter_map(|t| t.strip_suffix('%'))
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(changes.len(), 5, "{line}");
        assert!(changes[3] <= -95.0, "{line}");
        rows += 1;
    }
    assert_eq!(rows, 6, "{text}");
    // A terminal of 100 columns shows the table whole.
    let table_rows = text.lines().filter(|l| {
        ["  point", "  contour"].iter().any(|p| l.starts_with(p))
            || l.trim_start().starts_with("before")
    });
    assert!(
        table_rows.clone().count() == 13 && table_rows.clone().all(|l| l.chars().count() <= 100),
        "{text}"
    );
    assert!(dir.join("d/circle_d20_20seg.exact.ngc").exists());
    // BENCHMARKS.md shows the demo's table as the demo writes it.
    let table = read(&dir, "d/table.md");
    let benchmarks =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../BENCHMARKS.md"))
            .unwrap();
    assert!(
        benchmarks.contains(&table),
        "BENCHMARKS.md's demo table is stale: paste `volcomp demo --markdown table.md`'s table:\n{table}"
    );
}

#[test]
fn simulate_draws_svg_and_png_plots() {
    let dir = tempdir("plot");
    write_map(&dir, |p| 0.2 * p);
    write(&dir, "p.ngc", PROGRAM);
    for (name, magic) in [("e.svg", &b"<svg"[..]), ("e.png", &b"\x89PNG"[..])] {
        let o = volcomp(
            &["simulate", "p.ngc", "--map", "map.csv", "--plot", name],
            &dir,
        );
        common::ok(&o);
        let bytes = std::fs::read(dir.join(name)).unwrap();
        assert!(
            bytes.windows(magic.len()).take(200).any(|w| w == magic),
            "{name} is not an image"
        );
        assert!(bytes.len() > 2000, "{name} is nearly empty");
    }
    let o = common::run(&dir, "simulate p.ngc --map map.csv --plot e.pdf");
    assert_eq!(o.status.code(), Some(2));
    common::said(&o, ".svg or .png");
}

#[test]
fn every_demo_figure_is_what_simulate_reports() {
    // The demo prints the commands that reproduce its cells; run them for
    // the first program and compare with the printed figures (3 decimals).
    let dir = tempdir("demo_reproduced");
    let text = common::ok(&common::run(&dir, "demo --out-dir d"));
    assert!(
        text.contains("volcomp simulate d/<program>.<method>.ngc --reference d/<program>.ngc --map d/example_map.csv --work-offset 250,200,150"),
        "{text}"
    );
    // The title line, then a point and a contour row: before, then each
    // method's value and change.
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| *l == "circle D20, 20 segments")
        .unwrap_or_else(|| panic!("{text}"));
    let cells = |line: &str| -> Vec<String> {
        line.split_whitespace()
            .skip(1)
            .filter(|t| !t.ends_with('%'))
            .map(str::to_string)
            .collect()
    };
    let (point, contour) = (cells(lines[at + 1]), cells(lines[at + 2]));
    assert_eq!(point.len(), 6, "{point:?}");
    assert_eq!(contour.len(), 6, "{contour:?}");
    let programs = [
        None,
        Some("pitch"),
        Some("ilc_papers"),
        Some("ilc"),
        Some("exact"),
        Some("adaptive"),
    ];
    for (k, method) in programs.iter().enumerate() {
        let mut args = vec!["simulate".to_string()];
        match method {
            None => args.push("d/circle_d20_20seg.ngc".into()),
            Some(m) => {
                args.push(format!("d/circle_d20_20seg.{m}.ngc"));
                args.push("--reference".into());
                args.push("d/circle_d20_20seg.ngc".into());
            }
        }
        for a in [
            "--map",
            "d/example_map.csv",
            "--work-offset",
            "250,200,150",
            "--json",
        ] {
            args.push(a.into());
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = volcomp(&args, &dir);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let fmt = |key: &str| format!("{:.3}", v[key].as_f64().unwrap());
        assert_eq!(fmt("point_rms_um"), point[k], "{method:?}: {v}");
        assert_eq!(fmt("contour_rms_um"), contour[k], "{method:?}: {v}");
        assert_eq!(
            v["nominal"],
            if method.is_some() {
                "reference"
            } else {
                "program"
            }
        );
        assert!(v["point_definition"]
            .as_str()
            .unwrap()
            .contains("end of every feed move"));
    }
}

#[test]
fn assumptions_are_warned_about_on_stderr_with_file_and_line() {
    let dir = tempdir("warn");
    write_map(&dir, |_| 0.0);
    // No G20/G21 before the first move, and a G28 with no reference point.
    write(&dir, "p.ngc", "G90\nG0 X0 Y0 Z0\nG28\nG1 X10 F100\nM2\n");
    let o = common::run(
        &dir,
        "compensate p.ngc --map map.csv --work-offset 0,0,0 -o out.ngc",
    );
    common::ok(&o);
    let msg = stderr(&o);
    assert!(
        msg.contains("p.ngc:2:1: warning: ") && msg.contains("G20 or G21"),
        "{msg}"
    );
    assert!(msg.contains("p.ngc:3:1: warning: G28"), "{msg}");
    // Said once each.
    assert_eq!(msg.matches("warning:").count(), 2, "{msg}");
}

#[test]
fn completions_and_the_man_page_come_from_the_same_flags() {
    let d = common::tempdir("completions");
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let o = volcomp(&["completions", shell], &d);
        assert!(o.status.success(), "{shell}: {}", common::stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        // A flag the library's option table gives compensate.
        assert!(text.contains("max-correction"), "{shell}");
    }
    let page = common::ok(&common::run(&d, "man"));
    assert!(
        page.starts_with(".ie") || page.contains(".TH volcomp"),
        "{page}"
    );
    assert!(page.contains("compensate"));
    // A mistyped flag gets the closest one, swapped letters too.
    let o = common::run(&d, "compensate p.ngc --mpa m.csv -o x");
    assert!(
        common::stderr(&o).contains("a similar argument exists: '--map'"),
        "{}",
        common::stderr(&o)
    );
    // -q is --quiet.
    let o = common::run(&d, "-q completions bash");
    assert!(o.status.success());
}

/// A set-up written in mm under `units = "inch"` puts the part 25.4 times
/// as far out: the message names the set-up as the likely cause, not the
/// map's unit. G54 X = 590 read as inches is 14 986 mm, which 1/1000 would
/// also bring inside the 0…600 mm map ("metres", the hint this replaced).
#[test]
fn a_set_up_in_mm_under_units_inch_is_named_as_the_cause_not_the_map() {
    let dir = common::fixture("inch-setup");
    // The fixture's set-up, its G54 written in mm but said to be inches.
    write(
        &dir,
        "machine.toml",
        "units = \"inch\"\n[work_offsets]\nG54 = [590, 150, 100]\n",
    );
    let o = common::compensate_to(&dir, "o.ngc");
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    // 590 in × 25.4 + X10 (the program is in mm) = 14 996 mm at the
    // first move; 14 996 / 25.4 = 590.3937 mm.
    assert!(
        e.contains("axis X = 14996 mm is outside the map's range 0 … 600 mm"),
        "{e}"
    );
    assert!(
        e.contains(
            "help: the set-up says units = \"inch\", and X / 25.4 = 590.3937 mm is inside the map"
        ),
        "{e}"
    );
    assert!(e.contains("write units = \"mm\" in --setup"), "{e}");
    assert!(
        !e.contains("metres") && !e.contains("map may be in another unit"),
        "{e}"
    );
    assert!(!dir.join("o.ngc").exists());
}
