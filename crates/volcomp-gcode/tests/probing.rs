//! Probing moves G38.2–G38.5: refused by default, read as a feed move to
//! their end point with `InterpOptions::accept_probing` (the checks of
//! LinuxCNC 2.9's `Interp::convert_probe`, src/emc/rs274ngc/interp_convert.cc).
//! Expected positions are derived by hand in each test; the generated
//! probing programs are also run through `rs274` by the `probe` tests of
//! volcomp-cli.

use crate::common;
use volcomp_gcode::{ErrorClass, GcodeError, InterpOptions, Motion, MotionKind, Setup};

fn run(program: &str, accept_probing: bool) -> Result<Vec<Motion>, GcodeError> {
    let mut setup = Setup::default();
    setup.work_offsets_mm[0] = volcomp_gcode::Vec3::new(100.0, 50.0, -20.0);
    let options = InterpOptions {
        accept_probing,
        ..InterpOptions::default()
    };
    common::motions_and_warnings(program, setup, options).0
}

#[test]
fn probing_is_refused_unless_asked_for() {
    let e = run("G21 G90 G54\nG0 X0 Y0 Z10\nG38.2 Z-5 F100\nM2\n", false).unwrap_err();
    assert_eq!(e.class, ErrorClass::Unsupported);
    assert_eq!((e.line, e.column), (3, 1));
    assert!(e.message.contains("G38.2 is not supported"), "{e}");
    // G38 and G38.1 are no codes of LinuxCNC: refused even when asked.
    let e = run("G21\nG38 Z-5 F100\nM2\n", true).unwrap_err();
    assert!(e.message.contains("G38 is not supported"), "{e}");
}

#[test]
fn a_probe_move_is_read_as_a_feed_move_to_its_end_point() {
    // G54 = (100, 50, −20): program Z−5 is machine Z −25; incremental
    // back-off of 0.5 from the end point (where the interpreter puts the
    // probe, not knowing where it touched), then G38.3 in the same mode.
    let m = run(
        "G21 G90 G54\nG0 X1 Y2 Z10\nG38.2 Z-5 F100\nG91 G1 Z0.5\nG90 G38.3 X3\nM2\n",
        true,
    )
    .unwrap();
    assert_eq!(m.len(), 4);
    assert_eq!(m[1].kind, MotionKind::Feed);
    assert_eq!(m[1].line, 3);
    assert_eq!([m[1].end.x, m[1].end.y, m[1].end.z], [101.0, 52.0, -25.0]);
    assert_eq!(m[2].end.z, -24.5);
    assert_eq!([m[3].end.x, m[3].end.z], [103.0, -24.5]);
}

#[test]
fn probing_checks_of_linuxcnc() {
    let cases = [
        // No feed rate yet.
        (
            "G21 G0 X0 Y0 Z1\nG38.2 Z-1\nM2\n",
            "Cannot probe with zero feed rate",
            2,
        ),
        // Feed per revolution.
        (
            "G21 G95 S100 M3 F0.1\nG0 X0 Y0 Z1\nG38.2 Z-1\nM2\n",
            "feed per rev",
            3,
        ),
        // Start point = end point for G38.2 / G38.4 (not for G38.3).
        (
            "G21 F10\nG0 X0 Y0 Z1\nG38.4 Z1\nM2\n",
            "Start point too close",
            3,
        ),
    ];
    for (program, want, line) in cases {
        let e = run(program, true).unwrap_err();
        assert!(e.message.contains(want), "{program}: {e}");
        assert_eq!(e.line, line, "{program}");
    }
    assert!(run("G21 F10\nG0 X0 Y0 Z1\nG38.3 Z1\nM2\n", true).is_ok());
    // Cutter radius compensation on.
    let e = run(
        "G21 F10\nG0 X0 Y0 Z1\nG41.1 D2\nG1 X10\nG38.2 X20\nM2\n",
        true,
    )
    .unwrap_err();
    assert!(e.message.contains("cutter radius comp"), "{e}");
}
