//! Bounded work and no unconverged success: absurd coordinates and options
//! are refused before any work is sized, the output is capped, and a point
//! the solver does not reach is an error at its line, never a written
//! program with exit 0.

use crate::common;

use common::{compensate_with, fixture, stderr, volcomp, write};
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
        write(
            &d,
            "part.ngc",
            format!("G21 G90 G17\nG0 X10 Y10 Z5\nF300\n{line}\nM2\n"),
        );
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
    // Each option's bound is checked before any work, naming the option
    // (docs/errors.md, "Limits"): 4e9 segments, 1 nm segments, arcs
    // linearised within 1e-15 mm, adaptive pieces down to 1e-9 mm.
    let d = fixture("segments");
    for (args, said) in [
        (
            &["--segments", "4000000000"][..],
            "--segments must be 1 … 10000",
        ),
        (
            &["--segment-length", "1e-9"],
            "--segment-length must be a length of at least 0.001 mm",
        ),
        (
            &["--chord-tolerance", "1e-15"],
            "--chord-tolerance must be a length of 0.000001 mm (1 nm) to 1 mm",
        ),
        (
            &["--chord-tolerance", "100"],
            "--chord-tolerance must be a length of 0.000001 mm (1 nm) to 1 mm",
        ),
        (&["--chord-tolerance", "-inf"], "--chord-tolerance"),
        (
            &["--min-segment-length", "1e-9"],
            "--min-segment-length must be a length of at least 0.001 mm",
        ),
        (
            &["--contour-tolerance-um", "1e-9"],
            "--contour-tolerance-um must be at least 0.001 µm",
        ),
        (
            &[
                "--method",
                "ilc",
                "--gain",
                "1e-9",
                "--max-iterations",
                "1000000000",
            ],
            "--max-iterations must be 1 … 1000",
        ),
    ] {
        let o = compensate(&d, args);
        refused(&d, &o, said);
    }
    // Within the options' bounds, a block can still ask for too much: a
    // 1.5 m move (held at the map's ends) in 1 µm segments is 1.5 million
    // points, refused at its line before any is generated.
    let d = fixture("block");
    write(
        &d,
        "part.ngc",
        "G21 G90 G17\nG0 X0 Y10 Z5\nG1 X1500 F300\nM2\n",
    );
    let o = compensate(&d, &["--clamp", "--segment-length", "0.001"]);
    refused_program(&d, &o, "more than the 1000000");
    common::said(&o, "part.ngc:3");
}

/// Options that would be ignored, or would correct nothing, are refused.
#[test]
fn options_that_mean_nothing_together_are_refused() {
    let d = fixture("meaningless");
    let o = compensate(&d, &["--method", "direct", "--gain", "0.3"]);
    refused(&d, &o, "--gain is an option of --method ilc");
    let o = compensate(&d, &["--max-iterations", "5"]);
    refused(&d, &o, "--max-iterations is an option of --method ilc");
    let o = compensate(
        &d,
        &[
            "--method",
            "pitch",
            "--controller-compensates",
            "positioning",
        ],
    );
    refused(
        &d,
        &o,
        "--method pitch corrects only the positioning errors",
    );
    // The defaults said again are no conflict.
    let o = compensate(&d, &["--method", "direct", "--gain", "0.5"]);
    common::ok(&o);
}

/// A loop that never ends is refused within seconds at the line that loops,
/// by `moves` and `compensate` alike; lines run once do not count.
#[test]
fn loops_that_never_end_stop_at_the_repeated_lines_limit() {
    let d = fixture("loops");
    for (name, body) in [
        ("empty", "o1 while [1]\no1 endwhile\n"),
        ("counter", "#1=0\no1 while [1]\n#1=[#1+1]\no1 endwhile\n"),
        ("motion", "o1 while [1]\nG1 X1 F100\nG1 X0\no1 endwhile\n"),
        ("recursion", "o<r> sub\no<r> call\no<r> endsub\no<r> call\n"),
    ] {
        write(&d, "loop.ngc", format!("G21 G90\nG0 X0 Y0 Z0\n{body}M2\n"));
        for cmd in [
            &["moves", "loop.ngc", "--max-repeated-lines", "100000"][..],
            &[
                "compensate",
                "loop.ngc",
                "--map",
                "map.csv",
                "--setup",
                "machine.toml",
                "--max-repeated-lines",
                "100000",
                "-o",
                "out.ngc",
            ],
        ] {
            let o = volcomp(cmd, &d);
            let msg = stderr(&o);
            assert_eq!(o.status.code(), Some(3), "{name} {cmd:?}: {msg}");
            assert!(msg.contains("loop.ngc:"), "{name}: {msg}");
            assert!(
                msg.contains("executed 100000 lines of loops and subroutine calls")
                    || msg.contains("nested"),
                "{name}: {msg}"
            );
            if msg.contains("executed") {
                assert!(msg.contains("--max-repeated-lines"), "{name}: {msg}");
            }
            assert!(!d.join("out.ngc").exists());
        }
    }
    // A loop of 300 passes runs 4 lines a pass (the while test, the G1, the
    // assignment, the endwhile); the first pass is the main program's lines
    // run once, so 299 passes × 4 + the last while test = 1197 lines run
    // again: 1196 refuse it, 1197 let it run.
    write(&d, "loop.ngc", "G21 G90\nG0 X0 Y0 Z0\n#1=0\no1 while [#1 LT 300]\nG1 X[#1/10] F100\n#1=[#1+1]\no1 endwhile\nM2\n");
    let o = common::run(&d, "moves loop.ngc --max-repeated-lines 1196");
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    common::ok(&common::run(&d, "moves loop.ngc --max-repeated-lines 1197"));
}

/// A file read whole is bounded before it is read: a device is read up to
/// the limit and refused, a regular file by its size; the limit is an
/// option.
#[test]
fn inputs_read_whole_are_bounded() {
    let d = fixture("input_size");
    for dev in ["/dev/zero", "/dev/urandom"] {
        if !Path::new(dev).exists() {
            continue;
        }
        let o = volcomp(
            &[
                "compensate",
                "part.ngc",
                "--map",
                dev,
                "--setup",
                "machine.toml",
                "--max-input-size",
                "16M",
                "-o",
                "out.ngc",
            ],
            &d,
        );
        refused(&d, &o, "(a device or a pipe) gives more than the 16 MiB");
        common::said(&o, "--max-input-size");
    }
    // The fixture's map is a few hundred bytes: 256 is less.
    let o = compensate(&d, &["--max-input-size", "256"]);
    refused(&d, &o, "map.csv: the file holds");
    common::said(&o, "more than the 256 bytes");
    let o = compensate(&d, &["--max-input-size", "none"]);
    common::ok(&o);
    std::fs::remove_file(d.join("out.ngc")).unwrap();
    // A table whose line is longer than a table's line may be.
    let mut line = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    line.push_str(&"1,".repeat(600_000));
    line.push('\n');
    write(&d, "line.csv", line);
    let o = common::run(
        &d,
        "compensate part.ngc --map line.csv --setup machine.toml -o out.ngc",
    );
    refused(
        &d,
        &o,
        "line.csv:2:1: line 2 is 1200000 bytes long, more than the 1048576",
    );
}

#[test]
fn the_output_size_is_capped_and_nothing_is_written_past_it() {
    let d = fixture("cap");
    let o = compensate(&d, &["--max-output-size", "200"]);
    refused(&d, &o, "--max-output-size");
    // Without the cap the same run succeeds (so the cap was the reason).
    let o = compensate(&d, &["--max-output-size", "none"]);
    common::ok(&o);
    let o = common::run(
        &d,
        "compensate part.ngc --map map.csv -o x.ngc --max-output-size 12Q",
    );
    common::said(&o, "is not a size");
}

#[test]
fn an_unconverged_point_is_an_error_not_a_success() {
    // ILC with one step of gain 0.5 leaves half the error: on a map of
    // 2 µm per 100 mm at X ≈ 260 mm that is about 2.6 µm, above 1 µm.
    let d = fixture("ilc1");
    let o = compensate(&d, &["--method", "ilc", "--max-iterations", "1"]);
    refused_program(&d, &o, "is not reached");
    common::said(&o, "part.ngc:");
    // Twenty steps converge (0.5^20 of the error).
    let o = compensate(&d, &["--method", "ilc", "--max-iterations", "20"]);
    common::ok(&o);
    let d = fixture("ilc0");
    let o = compensate(&d, &["--method", "ilc", "--max-iterations", "0"]);
    refused(&d, &o, "--max-iterations must be 1 … 1000");
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
        "--segment-length must be a length of at least 0.001 mm",
    );
    let o = compensate(&d, &["--max-correction", "-0.1"]);
    refused(&d, &o, "--max-correction must be a positive length");
    // A negative work offset is a value, not a flag.
    let o = common::run(
        &d,
        "compensate part.ngc --map map.csv --work-offset -10,150,100 -o out.ngc",
    );
    let msg = stderr(&o);
    assert!(!msg.contains("unexpected argument"), "{msg}");
}

/// A controller table resampled at a step that would give more points than a
/// table may have is refused before it is built: the fixture's tables span
/// 0 … 600 mm, so a step of 1e-9 mm would be 6·10¹¹ + 1 points and one of
/// 2⁻¹¹ mm (exact in binary) 600·2048 + 1 = 1 228 801, past the million a
/// table may have (LinuxCNC's own limit, 256 a joint, is checked after);
/// 3 mm gives 201 and is written.
#[test]
fn resampled_tables_are_bounded_before_they_are_built() {
    let d = fixture("export_step");
    for (step, said, points) in [
        ("1e-9", "0.000000001", "600000000001"),
        ("0.00048828125", "0.00048828125", "1228801"),
    ] {
        let o = volcomp(
            &[
                "map", "export", "map.csv", "--to", "linuxcnc", "--type", "1", "--units", "mm",
                "--step", step, "-o", "comp",
            ],
            &d,
        );
        let msg = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{step}: {msg}");
        assert!(
            msg.contains(&format!("--step {said} mm gives {points} table points"))
                && msg.contains("more than the 1000000"),
            "{step}: {msg}"
        );
        assert!(!d.join("comp").join("x.comp").exists());
    }
    common::ok(&common::run(
        &d,
        "map export map.csv --to linuxcnc --type 1 --units mm --step 3 -o comp",
    ));
}
