//! Bounded work and no unconverged success: absurd coordinates and options
//! are refused before any work is sized, the output is capped, and a point
//! the solver does not reach is an error at its line, never a written
//! program with exit 0.

mod common;

use common::{compensate_with, fixture, stderr, volcomp};
use std::path::Path;

fn compensate(dir: &Path, extra: &[&str]) -> std::process::Output {
    compensate_with(dir, "out.ngc", extra)
}

/// The command fails as bad input (exit 2), says `needle`, and writes no
/// output.
fn refused(dir: &Path, o: &std::process::Output, needle: &str) {
    refused_with(dir, o, needle, 2)
}

/// The program is refused (exit 3, docs/errors.md), the message says
/// `needle`, and no output is written.
fn refused_program(dir: &Path, o: &std::process::Output, needle: &str) {
    refused_with(dir, o, needle, 3)
}

fn refused_with(dir: &Path, o: &std::process::Output, needle: &str, code: i32) {
    let msg = stderr(o);
    assert!(!o.status.success(), "accepted: {msg}");
    assert_eq!(o.status.code(), Some(code), "{msg}");
    assert!(msg.contains(needle), "`{needle}` not in: {msg}");
    assert!(!dir.join("out.ngc").exists(), "an output was written");
}

#[test]
fn a_far_coordinate_is_refused_at_its_line_before_any_work() {
    for (name, line) in [
        ("far_x", "G1 X1e8"),
        ("far_x_plain", "G1 X100000000"),
        ("far_g92", "G92 X-99999999\nG1 X10"),
        ("far_helix", "G2 X10 Y10 I0 J-1000000000 Z-1000000000000"),
    ] {
        let d = fixture(name);
        std::fs::write(
            d.join("part.ngc"),
            format!("G21 G90 G17\nG0 X10 Y10 Z5\nF300\n{line}\nM2\n"),
        )
        .unwrap();
        let o = compensate(&d, &[]);
        let msg = stderr(&o);
        assert!(!o.status.success(), "{name}: accepted: {msg}");
        // The move that goes too far is the snippet's last line.
        let at = format!("part.ngc:{}:", 3 + line.lines().count());
        assert!(msg.contains(&at), "{name}: not located at {at}: {msg}");
        assert!(!d.join("out.ngc").exists());
    }
}

#[test]
fn options_asking_for_unbounded_work_are_refused() {
    // 50 mm of feed in 4e9 segments, arcs linearised within 1e-15 mm, or
    // adaptive pieces (lines and arcs as arcs) down to 1e-9 mm.
    let d = fixture("segments");
    let o = compensate(&d, &["--segments", "4000000000"]);
    refused_program(&d, &o, "more than the 1000000");
    let d = fixture("segment_length");
    let o = compensate(&d, &["--segment-length", "1e-9"]);
    refused_program(&d, &o, "more than the 1000000");
    let d = fixture("chord");
    std::fs::write(
        d.join("part.ngc"),
        "G21 G90 G17\nG0 X10 Y10 Z5\nG1 Z-1 F300\nG2 X30 Y10 I10 J0\nM2\n",
    )
    .unwrap();
    let o = compensate(&d, &["--arcs-as-lines", "--chord-tolerance", "1e-15"]);
    refused_program(&d, &o, "more than the 1000000");
    let o = compensate(&d, &["--min-segment-length", "1e-9"]);
    refused_program(&d, &o, "more than the 1000000");
}

#[test]
fn the_output_size_is_capped_and_nothing_is_written_past_it() {
    let d = fixture("cap");
    let o = compensate(&d, &["--max-output-size", "200"]);
    refused(&d, &o, "--max-output-size");
    // Without the cap the same run succeeds (so the cap was the reason).
    let o = compensate(&d, &["--max-output-size", "none"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = volcomp(
        &[
            "compensate",
            "part.ngc",
            "--map",
            "map.csv",
            "-o",
            "x.ngc",
            "--max-output-size",
            "12Q",
        ],
        &d,
    );
    assert!(stderr(&o).contains("is not a size"), "{}", stderr(&o));
}

#[test]
fn an_unconverged_point_is_an_error_not_a_success() {
    // ILC with one step of gain 0.5 leaves half the error: on a map of
    // 2 µm per 100 mm at X ≈ 260 mm that is about 2.6 µm, above 1 µm.
    let d = fixture("ilc1");
    let o = compensate(&d, &["--method", "ilc", "--max-iterations", "1"]);
    refused_program(&d, &o, "is not reached");
    assert!(stderr(&o).contains("part.ngc:"), "{}", stderr(&o));
    // Twenty steps converge (0.5^20 of the error).
    let o = compensate(&d, &["--method", "ilc", "--max-iterations", "20"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let d = fixture("ilc0");
    let o = compensate(&d, &["--method", "ilc", "--max-iterations", "0"]);
    refused(&d, &o, "--max-iterations must be at least 1");
}

#[test]
fn negative_option_values_reach_the_range_check() {
    let d = fixture("neg");
    let o = compensate(&d, &["--method", "ilc", "--gain", "-1"]);
    refused(&d, &o, "--gain must satisfy 0 < γ ≤ 1; got -1");
    let o = compensate(&d, &["--segment-length", "-2"]);
    refused(
        &d,
        &o,
        "--segment-length must be a positive length in mm; got -2",
    );
    let o = compensate(&d, &["--max-correction", "-0.1"]);
    refused(&d, &o, "--max-correction must be a positive length");
    // A negative work offset is a value, not a flag.
    let o = volcomp(
        &[
            "compensate",
            "part.ngc",
            "--map",
            "map.csv",
            "--work-offset",
            "-10,150,100",
            "-o",
            "out.ngc",
        ],
        &d,
    );
    let msg = stderr(&o);
    assert!(!msg.contains("unexpected argument"), "{msg}");
}
