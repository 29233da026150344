//! Cutter radius compensation (G41/G42, G41.1/G42.1) as LinuxCNC 2.9
//! computes it. Expected points are derived by hand below; the error
//! messages are the ones `rs274` (LinuxCNC 2.9.0~pre1) prints for the same
//! programs. The agreement fixtures `cutter_comp_g41_1_g18.ngc` and
//! `linuxcnc_ccomp_*.ngc` check whole paths against `rs274`.

use crate::common;
use volcomp_gcode::{GcodeError, InterpOptions, Motion, MotionKind, MotionSource, Setup};

fn run_with(program: &str, setup: Setup) -> Result<Vec<(u64, Motion)>, GcodeError> {
    common::numbered_motions(program, setup, InterpOptions::default())
}

fn run(program: &str) -> Result<Vec<(u64, Motion)>, GcodeError> {
    run_with(program, Setup::default())
}

fn close(m: &Motion, x: f64, y: f64) {
    assert!(
        (m.end.x - x).abs() < 1e-9 && (m.end.y - y).abs() < 1e-9,
        "end {:?} != ({x}, {y})",
        m.end
    );
}

#[test]
fn square_on_the_left_with_entry_convex_corner_and_exit() {
    // Tool diameter 2 (radius 1) on the left of a counter-clockwise
    // square 0..10: the path is the square grown by 1, with a quarter arc
    // about each programmed corner.
    let m = run("G21 F100\nG0 X0 Y-5\nG41.1 D2 G1 X0 Y0\nX10\nY10\nG40 G1 X20 Y20\nM2\n").unwrap();
    // Entry: from (0,-5) to (0,0), tool on the left of +Y: x = 0 - 1.
    let (line, entry) = m[1];
    assert_eq!(entry.source, MotionSource::CutterComp);
    assert_eq!((entry.line, line), (3, 4), "given out one block late");
    close(&entry, -1.0, 0.0);
    // Corner at (0,0), +Y then +X: convex for a tool on the left (it goes
    // round the outside): an arc about (0,0) from (-1,0) to (0,1), clockwise.
    let MotionKind::Arc(a) = m[2].1.kind else {
        panic!("corner arc expected, got {:?}", m[2].1.kind)
    };
    assert!(a.clockwise());
    close(&m[2].1, 0.0, 1.0);
    assert!(a.center.x.abs() < 1e-12 && a.center.y.abs() < 1e-12);
    // Along +X the tool is at y = 1; +X then +Y turns left, a concave corner
    // for a tool on the left: the line ends where y = 1 meets x = 10 - 1.
    close(&m[3].1, 9.0, 1.0);
    // Up +Y at x = 9 to (9, 10), given out at G40, which keeps its end.
    close(&m[4].1, 9.0, 10.0);
    // The exit move goes from there to the programmed point.
    assert_eq!(m[5].1.source, MotionSource::Program);
    close(&m[5].1, 20.0, 20.0);
    assert!((m[5].1.start.x - 9.0).abs() < 1e-12 && (m[5].1.start.y - 10.0).abs() < 1e-12);
}

#[test]
fn g42_with_a_tool_table_diameter_and_negative_diameter_switches_side() {
    let mut s = Setup::default();
    s.tool_diameters_mm.insert(3, 4.0);
    s.tool_diameters_mm.insert(4, -4.0);
    // G42 D3: radius 2 on the right of +X: y = -2.
    let m = run_with(
        "G21 F100\nG0 X0 Y0\nG42 D3 G1 X10\nG40 G0 X20\nM2\n",
        s.clone(),
    )
    .unwrap();
    close(&m[1].1, 10.0, -2.0);
    // A negative diameter puts the tool on the other side (LinuxCNC's
    // convert_cutter_compensation_on): y = +2.
    let m = run_with("G21 F100\nG0 X0 Y0\nG42 D4 G1 X10\nG40 G0 X20\nM2\n", s).unwrap();
    close(&m[1].1, 10.0, 2.0);
}

fn message(program: &str) -> String {
    run(program).unwrap_err().to_string()
}

#[test]
fn refusals_have_linuxcncs_messages() {
    // A program that turns compensation on along Y, then runs `block`.
    let then = |block: &str| format!("G21 F100\nG0 X0 Y-5\nG41.1 D2 G1 X0 Y0\nX10\n{block}\nM2\n");
    // Each refusal: why, the program, what the message must hold (its line
    // and LinuxCNC's words).
    let cases: [(&str, String, &[&str]); 10] = [
        (
            "the retreat along X (5 / tan 45° = 5) is longer than the 3 mm side",
            "G21 F100\nG0 X0 Y0\nG41.1 D10 G1 X20 Y0\nY3\nX0\nG40 G0 X-20\nM2\n".into(),
            &[
                "t.ngc:5:",
                "Straight feed in concave corner cannot be reached by the tool without gouging",
            ],
        ),
        (
            "inside a 4 mm arc with a 5 mm radius tool",
            "G21 F100\nG0 X0 Y-10\nG41.1 D10 G1 X0 Y0\nG3 X0 Y8 J4\nG40 G0 X-20\nM2\n".into(),
            &["t.ngc:4:", "Tool radius not less than arc radius with comp"],
        ),
        (
            "entry move 4 mm long with a 5 mm radius",
            "G21 F100\nG0 X0 Y0\nG41.1 D10 G1 X4 Y0\nG40 G0 X-20\nM2\n".into(),
            &[
                "t.ngc:3:",
                "Length of cutter compensation entry move is not greater than the tool radius",
            ],
        ),
        (
            "G19",
            "G21 G19 F100\nG41.1 D2\nM2\n".into(),
            &["Cutter radius compensation allowed only in XY, XZ planes"],
        ),
        (
            "a plane change while compensation is on",
            then("G18"),
            &[
                "t.ngc:5:",
                "Cannot change planes with cutter radius compensation on",
            ],
        ),
        (
            // rs274: the plane is set at step 11, G40 at 13.
            "a plane change even with the G40 that turns compensation off in the same block",
            then("G18 G40 G1 X20 Y-5"),
            &[
                "t.ngc:5:",
                "Cannot change planes with cutter radius compensation on",
            ],
        ),
        (
            "a change of coordinate system",
            "G21 F100\nG41.1 D2\nG55\nM2\n".into(),
            &["Cannot change coordinate systems with cutter radius compensation on"],
        ),
        (
            "compensation turned on twice",
            "G21 F100\nG41.1 D2\nG41.1 D2\nM2\n".into(),
            &["Cannot turn cutter radius comp on when on"],
        ),
        (
            "the current position read",
            "G21 F100\nG0 X0 Y-5\nG41.1 D2 G1 X0 Y0\n#1 = #5420\nG40 G0 X-20\nM2\n".into(),
            &[
                "t.ngc:4:",
                "Cannot read current position with cutter radius compensation on",
            ],
        ),
        (
            "a tool whose diameter the set-up does not give",
            "G21 F100\nG41 D7\nM2\n".into(),
            &["tool 7", "[tool_diameters]"],
        ),
    ];
    for (why, program, said) in cases {
        let e = message(&program);
        for s in said {
            assert!(e.contains(s), "{why}: no `{s}` in: {e}");
        }
    }
    // What comes after G40 in LinuxCNC's order passes in G40's block, as
    // in rs274 (G55 and G43 H1 with G40: the exit move runs).
    for block in ["G40 G55 G1 X20 Y-5", "G40 G43 H1 G1 X20 Y-5"] {
        let mut s = Setup::default();
        s.tool_lengths_mm.insert(1, 10.0);
        s.work_offsets_given[1] = true;
        let r = run_with(&then(block), s);
        assert!(r.is_ok(), "{block}: {r:?}");
    }
}
