//! `volcomp time`, and the machining time in `compensate` and `simulate`:
//! the planner model's estimate against closed forms of a trapezoidal
//! velocity profile (`L/v + v/a`, LinuxCNC's G64 halving the acceleration
//! of a segment that ends in a blend; docs/planner.md).

use crate::common;
use common::{stderr, tempdir, write, write_map};

const SETUP: &str =
    "units = \"mm\"\n[limits]\nmax_velocity = 200\nmax_acceleration = [500, 500, 400]\n";

/// Parses the first `machining time A s` figure of `text`.
fn first_seconds(text: &str) -> f64 {
    let rest = text
        .split("machining time: ")
        .nth(1)
        .expect("a machining time");
    rest.split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn time_of_a_single_move_is_the_trapezoid() {
    let d = tempdir("single");
    write(&d, "s.toml", SETUP);
    // G61: 60 mm at 50 mm/s with 500 mm/s²: 60/50 + 50/500 = 1.3 s.
    write(&d, "p.ngc", "G21 G90 G61\nG1 X60 F3000\nM2\n");
    let out = common::ok(&common::run(&d, "time p.ngc --setup s.toml"));
    assert!((first_seconds(&out) - 1.3).abs() <= 0.002, "{out}");
    assert!(
        out.contains("200 mm/s and X 500 Y 500 Z 400 mm/s² per axis"),
        "{out}"
    );
    assert!(out.contains("from the set-up's [limits]"), "{out}");
    // The same move under G64 (the default) ends in a blend: LinuxCNC
    // halves its acceleration, 60/50 + 50/250 = 1.4 s.
    write(&d, "q.ngc", "G21 G90\nG1 X60 F3000\nM2\n");
    let v = common::json(&common::run(
        &d,
        "time q.ngc --setup s.toml --reference p.ngc --json",
    ));
    let t = v["program"]["motion"]["total_s"].as_f64().unwrap();
    let r = v["original"]["motion"]["total_s"].as_f64().unwrap();
    assert!((t - 1.4).abs() <= 0.002 && (r - 1.3).abs() <= 0.002, "{v}");
    assert_eq!(v["limits_from_setup"], true);
}

/// `time p.ngc --setup s.toml --per-line --json` of `program` under
/// [`SETUP`], in a new folder named `name` (returned with the JSON).
fn per_line_json(name: &str, program: &str) -> (common::TempDir, serde_json::Value) {
    let d = tempdir(name);
    write(&d, "s.toml", SETUP);
    write(&d, "p.ngc", program);
    let v = common::json(&common::run(
        &d,
        "time p.ngc --setup s.toml --per-line --json",
    ));
    (d, v)
}

/// `--per-line`: each moving line's time, by hand. Under G61.1 every
/// line stops, so each is its own trapezoid from rest to rest at
/// 500 mm/s² (Y at 500 too): line 3, 60 mm at 50 mm/s, 60/50 + 50/500 =
/// 1.3 s; line 4, 40 mm, 40/50 + 0.1 = 0.9 s; line 2 a rapid of 10 mm at
/// 200 mm/s, a triangle 2√(10/500) = 0.283 s (each within two periods).
#[test]
fn per_line_gives_each_line_its_trapezoid() {
    let (d, v) = per_line_json(
        "per_line",
        "G21 G90 G61.1\nG0 X-10\nG1 X50 F3000\nG1 Y40\nM2\n",
    );
    let rows = v["per_line"].as_array().unwrap_or_else(|| panic!("{v}"));
    let got: Vec<(u64, f64, f64, f64)> = rows
        .iter()
        .map(|r| {
            let f = |k: &str| r[k].as_f64().unwrap();
            (
                r["line"].as_u64().unwrap(),
                f("total_s"),
                f("cutting_s"),
                f("rapid_s"),
            )
        })
        .collect();
    let want = [(2, 2.0 * (10.0f64 / 500.0).sqrt()), (3, 1.3), (4, 0.9)];
    assert_eq!(got.len(), want.len(), "{v}");
    for ((line, total, cutting, rapid), (w_line, w_total)) in got.iter().zip(want) {
        assert_eq!(*line, w_line, "{v}");
        assert!(
            (total - w_total).abs() <= 0.002,
            "line {line}: {total} s, by hand {w_total} s"
        );
        let (c, r) = if *line == 2 {
            (0.0, *total)
        } else {
            (*total, 0.0)
        };
        assert_eq!((*cutting, *rapid), (c, r), "{v}");
    }
    // The lines' times add up to the program's.
    let sum: f64 = got.iter().map(|g| g.1).sum();
    let total = v["program"]["motion"]["total_s"].as_f64().unwrap();
    assert!((sum - total).abs() < 1e-9, "{sum} against {total}");
    // The text: a row per line with its words.
    let out = common::ok(&common::run(&d, "time p.ngc --setup s.toml --per-line"));
    assert!(out.contains("time per line (3 lines)"), "{out}");
    let row = out
        .lines()
        .find(|l| l.trim_start().starts_with("3 "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(row.ends_with("G1 X50 F3000"), "{row}");
    // Under G61.1 every line ends at rest.
    for r in rows {
        assert_eq!(r["end_speed_mm_s"].as_f64(), Some(0.0), "{v}");
    }
}

/// `--per-line`'s end speed, by hand: under G61 a join the path runs
/// straight through (two collinear lines) is tangent and runs at the feed,
/// 3000 mm/min = 50 mm/s (each line is long enough to reach it: 2.5 mm at
/// 500 mm/s²); a corner is an exact stop (0); a rapid into a feed move and
/// the program's end stop too.
#[test]
fn per_line_gives_the_speed_each_line_ends_at() {
    let (d, v) = per_line_json(
        "per_line_end",
        "G21 G90 G61\nG0 X-10\nG1 X30 F3000\nG1 X60\nG1 Y40\nM2\n",
    );
    let rows = v["per_line"].as_array().unwrap_or_else(|| panic!("{v}"));
    let got: Vec<(u64, f64)> = rows
        .iter()
        .map(|r| {
            (
                r["line"].as_u64().unwrap(),
                r["end_speed_mm_s"].as_f64().unwrap(),
            )
        })
        .collect();
    let want = [(2, 0.0), (3, 50.0), (4, 0.0), (5, 0.0)];
    assert_eq!(got.len(), want.len(), "{v}");
    for ((line, end), (w_line, w_end)) in got.iter().zip(want) {
        assert_eq!(*line, w_line, "{v}");
        assert!(
            (end - w_end).abs() <= 1e-6,
            "line {line}: {end} mm/s, by hand {w_end}"
        );
    }
    let out = common::ok(&common::run(&d, "time p.ngc --setup s.toml --per-line"));
    assert!(out.contains("rapid ms, end mm/s, text"), "{out}");
    let row = out
        .lines()
        .find(|l| l.trim_start().starts_with("3 "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(row.contains(" 50.0  G1 X30 F3000"), "{row}");
}

#[test]
fn compensate_and_simulate_state_both_times_and_the_change() {
    let d = tempdir("both");
    write_map(&d);
    write(&d, "s.toml", SETUP);
    write(
        &d,
        "p.ngc",
        "G21 G90\nG0 X0 Y0 Z0\nG1 X60 F3000\nG1 Y40\nM2\n",
    );
    let o = common::run(&d, "compensate p.ngc --map map.csv --setup s.toml -o c.ngc");
    common::ok(&o);
    let err = stderr(&o);
    let line = err
        .lines()
        .find(|l| l.starts_with("volcomp: machining time: "))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(line.contains(" -> ") && line.contains(" %)"), "{line}");
    let v = common::json(&common::run(
        &d,
        "simulate c.ngc --map map.csv --setup s.toml --reference p.ngc --json",
    ));
    assert!(v["point_rms_um"].is_number(), "{v}");
    let t = &v["machining_time"];
    assert!(
        t["program"]["motion"]["total_s"].as_f64().unwrap() > 0.0,
        "{v}"
    );
    assert!(
        t["original"]["motion"]["total_s"].as_f64().unwrap() > 0.0,
        "{v}"
    );
    // --quiet: no summary, no time.
    let o = common::run(
        &d,
        "compensate p.ngc --map map.csv --setup s.toml -o c2.ngc --quiet",
    );
    assert!(
        o.status.success() && !stderr(&o).contains("machining time"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_limits_are_located_in_the_set_up() {
    let d = tempdir("bad");
    write(
        &d,
        "s.toml",
        "units = \"mm\"\n[limits]\nmax_acceleration = [500, 0, 400]\n",
    );
    write(&d, "p.ngc", "G21 G90\nG1 X60 F3000\nM2\n");
    let o = common::run(&d, "time p.ngc --setup s.toml");
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("s.toml:3:20: limits.max_acceleration must be positive numbers; got 0"),
        "{e}"
    );
}
