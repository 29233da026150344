//! A program that never sets one axis (a 2-D router, laser or plasma
//! program without Z words): compensated from the set-up's `start` when the
//! set-up gives one, else refused at its first feed move, or, when allowed,
//! written with those moves counted as not compensated.
//!
//! The map is a constant error e = (10, 0, 5) µm everywhere, so every
//! command is by hand q = t − e: X − 0.010 mm, Y unchanged, Z − 0.005 mm.

use volcomp_core::error::ErrorKind;
use volcomp_core::{AxisTableMap, CompensateOptions, Compensator, MachineSetup, Segmentation};

/// The 2-D program: no Z word anywhere.
const PROGRAM: &str = "G21 G90\nG0 X0 Y0\nG1 X10 Y10 F100\nG1 X20 Y0\nM2\n";

fn constant_map() -> AxisTableMap {
    AxisTableMap::from_csv(
        "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
         X,both,-10,10,0,0\nX,both,100,10,0,0\n\
         Y,both,-10,0,0,0\nY,both,100,0,0,0\n\
         Z,both,-10,0,0,5\nZ,both,100,0,0,5\n",
        "constant.csv",
    )
    .unwrap()
}

fn setup(start: bool) -> MachineSetup {
    let text = if start {
        "units = \"mm\"\nstart = [0, 0, 20]\n[work_offsets]\nG54 = [0, 0, 0]\n"
    } else {
        "units = \"mm\"\n[work_offsets]\nG54 = [0, 0, 0]\n"
    };
    MachineSetup::from_setup_toml(text, "s.toml").unwrap()
}

fn options(allow: bool) -> CompensateOptions {
    CompensateOptions {
        segmentation: Segmentation::Off,
        allow_uncompensated_axes: allow,
        ..Default::default()
    }
}

fn run(
    program: &str,
    start: bool,
    allow: bool,
) -> Result<(String, volcomp_core::CompensateSummary), Box<volcomp_core::Error>> {
    let map = constant_map();
    let mut out = Vec::new();
    let summary = Compensator::new(&map)
        .setup(setup(start))
        .options(options(allow))
        .file_name("p.ngc")
        .run(program.as_bytes(), &mut out)
        .map_err(Box::new)?;
    Ok((String::from_utf8(out).unwrap(), summary))
}

#[test]
fn the_start_of_the_setup_gives_the_axis_never_set() {
    // Start Z = 20: the rapid's end (0, 0, 20) is commanded at
    // (−0.010, 0, 19.995), the Z word added; the feed moves keep Z 19.995.
    let (out, summary) = run(PROGRAM, true, false).unwrap();
    assert_eq!(
        out,
        "G21 G90\nG0 X-0.01000 Y0 Z19.99500\nG1 X9.99000 Y10 F100\nG1 X19.99000 Y0\nM2\n"
    );
    assert_eq!(summary.points, 3);
    assert_eq!(summary.uncompensated_moves, 0);
    assert!(summary.uncompensated_text().is_none());
}

#[test]
fn without_a_start_the_first_feed_move_is_refused_at_its_axis_word() {
    let e = run(PROGRAM, false, false).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::RefusedProgram);
    let text = e.to_string();
    // Line 3, column 4: the X word of `G1 X10 Y10 F100`.
    assert!(
        text.starts_with("p.ngc:3:4: this move cannot be compensated: the program has not set Z before it and the set-up gives no start"),
        "{text}"
    );
    assert!(text.contains("`start = [X, Y, Z]`"), "{text}");
    assert!(text.contains("add a move of Z"), "{text}");
    // Two axes never set are both named; the column is that of the first
    // axis word after the N word.
    let e = run("G21 G90\nG0 X0\nN30 G1 X10 F100\nM2\n", false, false).unwrap_err();
    assert!(
        e.to_string().starts_with(
            "p.ngc:3:8: this move cannot be compensated: the program has not set Y and Z"
        ),
        "{e}"
    );
}

#[test]
fn a_rapid_before_the_program_sets_every_axis_is_no_refusal() {
    // The usual lead-in: Z to a safe height, then X Y; the rapids are
    // positioning moves, and everything after them is compensated. A feed
    // move that goes nowhere (`G1 F100`) has nothing to compensate.
    let (out, summary) = run(
        "G21 G90\nG1 F100\nG0 Z5\nG0 X0 Y0\nG1 X10\nM2\n",
        false,
        false,
    )
    .unwrap();
    assert_eq!(
        out,
        "G21 G90\nG1 F100\nG0 Z5\nG0 X-0.01000 Y0 Z4.99500\nG1 X9.99000\nM2\n"
    );
    assert_eq!(summary.points, 2);
    assert_eq!(summary.uncompensated_moves, 0);
}

#[test]
fn allowed_the_moves_are_written_as_they_are_and_counted() {
    let (out, summary) = run(PROGRAM, false, true).unwrap();
    assert_eq!(out, PROGRAM);
    assert_eq!(summary.points, 0);
    assert_eq!(summary.uncompensated_moves, 2);
    assert_eq!(summary.first_uncompensated, Some((3, 4)));
    assert_eq!(summary.unset_axes, [false, false, true]);
    assert_eq!(
        summary.uncompensated_text().unwrap(),
        "2 feed moves NOT compensated, the first on line 3: the program never set Z before them and the set-up gives no start"
    );
    // Z set on line 4: the move before is counted, the ones after are
    // compensated: line 4 ends at (10, 10, 5), commanded (9.990, 10, 4.995)
    // (the X word added after the Z word), line 5 at (20, 0, 5).
    let (out, summary) = run(
        "G21 G90\nG0 X0 Y0\nG1 X10 Y10 F100\nG0 Z5\nG1 X20 Y0\nM2\n",
        false,
        true,
    )
    .unwrap();
    assert_eq!(summary.uncompensated_moves, 1);
    assert_eq!(summary.points, 2);
    assert!(
        out.ends_with("G0 Z4.99500 X9.99000\nG1 X19.99000 Y0\nM2\n"),
        "{out}"
    );
}
