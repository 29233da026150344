//! G52 local offsets and the tool table writes G10 L1/L10/L11, read as
//! LinuxCNC 2.9 reads them (`Interp::convert_axis_offsets`,
//! `Interp::convert_setup_tool`, src/emc/rs274ngc/interp_convert.cc).
//! Expected axis positions are derived by hand in each test; the same
//! constructs are checked against `rs274` by the agreement fixtures
//! `g52_local_offsets.ngc` and `g10_tool_table.ngc`.

use crate::common;
use volcomp_gcode::{GcodeError, Motion, Setup};

fn run_with(program: &str, setup: Setup) -> Result<Vec<Motion>, GcodeError> {
    common::motions_with(program, setup)
}

fn run(program: &str) -> Result<Vec<Motion>, GcodeError> {
    run_with(program, Setup::default())
}

fn end(m: &Motion) -> [f64; 3] {
    [m.end.x, m.end.y, m.end.z]
}

fn close(a: [f64; 3], b: [f64; 3]) {
    for i in 0..3 {
        assert!((a[i] - b[i]).abs() < 1e-9, "{a:?} != {b:?}");
    }
}

fn tools(list: &[(u32, f64)]) -> Setup {
    let mut s = Setup::default();
    for (n, l) in list {
        s.tool_lengths_mm.insert(*n, *l);
    }
    s
}

#[test]
fn g52_shifts_the_program_origin_without_moving() {
    // G52 X10 Y20: program (0, 0) is axis (10, 20); Z untouched.
    let m = run("G21 G90\nG0 X0 Y0 Z5\nG52 X10 Y20\nG0 X0 Y0\nG1 X1 Y2 F100\nM2\n").unwrap();
    assert_eq!(m.len(), 3);
    close(end(&m[1]), [10.0, 20.0, 5.0]);
    close(end(&m[2]), [11.0, 22.0, 5.0]);
}

#[test]
fn g52_replaces_not_accumulates_and_is_cleared_by_g92_1() {
    // A second G52 X-5 sets the offset to -5 (not 10 - 5); G92.1 clears it.
    let p = "G21\nG52 X10\nG52 X-5\nG0 X0\nG92.1\nG0 X0\nM2\n";
    let m = run(p).unwrap();
    close(end(&m[0]), [-5.0, 0.0, 0.0]);
    close(end(&m[1]), [0.0, 0.0, 0.0]);
}

#[test]
fn g52_is_saved_and_restored_by_g92_2_and_g92_3() {
    // G92.2 zeroes the shared offset, G92.3 restores G52's 3 mm.
    let m = run("G21\nG52 Y3\nG92.2\nG0 Y0\nG92.3\nG0 Y0\nM2\n").unwrap();
    close(end(&m[0]), [0.0, 0.0, 0.0]);
    close(end(&m[1]), [0.0, 3.0, 0.0]);
}

#[test]
fn g52_in_inches_and_g91_after_it() {
    // G20 G52 X1: 25.4 mm; G0 X0 → 25.4; G91 X1 → 50.8.
    let m = run("G20\nG52 X1\nG0 X0\nG91 G0 X1\nM2\n").unwrap();
    close(end(&m[0]), [25.4, 0.0, 0.0]);
    close(end(&m[1]), [50.8, 0.0, 0.0]);
}

#[test]
fn g52_with_g92_shares_one_offset() {
    // G52 X7 then, at axis X 7 (program 0), G92 X1: the shared offset
    // becomes 7 − 1 = 6 (convert_axis_offsets' G92 branch: current + offset − X).
    let m = run("G21\nG52 X7\nG0 X0\nG92 X1\nG0 X0\nM2\n").unwrap();
    close(end(&m[0]), [7.0, 0.0, 0.0]);
    close(end(&m[1]), [6.0, 0.0, 0.0]);
}

#[test]
fn g10_l1_sets_a_length_used_by_the_next_g43() {
    // Tool 1 is 40 mm in the set-up; G10 L1 P1 Z12.5 makes it 12.5. The
    // active offset changes only at the next G43 (as on LinuxCNC).
    let p = "G21\nG43 H1\nG0 Z0\nG10 L1 P1 Z12.5\nG0 Z0\nG43 H1\nG0 Z0\nM2\n";
    let m = run_with(p, tools(&[(1, 40.0)])).unwrap();
    close(end(&m[0]), [0.0, 0.0, 40.0]);
    close(end(&m[1]), [0.0, 0.0, 40.0]);
    close(end(&m[2]), [0.0, 0.0, 12.5]);
}

#[test]
fn g10_l1_x_y_offsets_are_applied_by_g43() {
    // X1 Y-2 Z30 for tool 2: program (0, 0, 5) is axis (1, −2, 35).
    let p = "G21\nG10 L1 P2 X1 Y-2 Z30\nG43 H2\nG0 X0 Y0 Z5\nM2\n";
    let m = run_with(p, tools(&[(2, 10.0)])).unwrap();
    close(end(&m[0]), [1.0, -2.0, 35.0]);
}

#[test]
fn g10_l10_makes_the_current_point_the_given_coordinate() {
    // At axis Z 6 (no offsets), G10 L10 P3 Z1: length = 6 − 1 = 5, so after
    // G43 H3 the current point is program Z 1 and G0 Z0 goes to axis 5.
    let p = "G21\nG0 Z6\nG10 L10 P3 Z1\nG43 H3\nG0 Z0\nM2\n";
    let m = run_with(p, tools(&[(3, 99.0)])).unwrap();
    close(end(&m[1]), [0.0, 0.0, 5.0]);
}

#[test]
fn g10_l10_ignores_the_active_tool_offset_but_not_g92() {
    // Tool 4 (20 mm) active, G0 Z10 → axis 30; G92 Z0 there (offset 10);
    // G10 L10 P4 Z5: here (without work offset and G92) = 30 − 10 = 20,
    // length = 20 − 5 = 15; G43 H4, G0 Z0 → 0 + 10 + 15 = 25.
    let p = "G21\nG43 H4\nG0 Z10\nG92 Z0\nG10 L10 P4 Z5\nG43 H4\nG0 Z0\nM2\n";
    let m = run_with(p, tools(&[(4, 20.0)])).unwrap();
    close(end(&m[0]), [0.0, 0.0, 30.0]);
    close(end(&m[1]), [0.0, 0.0, 25.0]);
}

#[test]
fn g10_l11_is_relative_to_g59_3_and_ignores_g92() {
    // G59.3 Z offset −100 in the set-up; at axis Z 30 with G92 active,
    // G10 L11 P5 Z-3: length = (30 − (−100)) − (−3) = 133.
    let mut s = tools(&[(5, 1.0)]);
    s.work_offsets_mm[8] = volcomp_gcode::Vec3::new(0.0, 0.0, -100.0);
    s.work_offsets_given[8] = true;
    let p = "G21\nG0 Z30\nG92 Z0\nG10 L11 P5 Z-3\nG92.1\nG43 H5\nG0 Z0\nM2\n";
    let m = run_with(p, s).unwrap();
    close(end(&m[1]), [0.0, 0.0, 133.0]);
}

#[test]
fn g10_tool_writes_are_refused_where_linuxcnc_refuses_them() {
    // Tool not in the table, no offsets at all, L without meaning.
    common::refused_with(
        &tools(&[(1, 10.0)]),
        &[
            ("G10 L1 P7 Z1\nM2\n", "not in the tool table"),
            ("G10 L1 P1\nM2\n", "no effect"),
            ("G10 L3 P1 Z1\nM2\n", "L1, L2, L10, L11 and L20"),
        ],
    );
}

#[test]
fn r90_maps_program_x_to_axis_y() {
    // G10 L2 P1 X10 Y5 R90: q = Rot(90°)·p + (10, 5): program (1, 0) is
    // axis (10 + 0, 5 + 1) = (10, 6); program (0, 2) is (10 − 2, 5) = (8, 5).
    let m = run("G21\nG10 L2 P1 X10 Y5 R90\nG0 X1 Y0\nG0 X0 Y2\nM2\n").unwrap();
    close(end(&m[0]), [10.0, 6.0, 0.0]);
    close(end(&m[1]), [8.0, 5.0, 0.0]);
}

#[test]
fn rotated_g91_and_arc_centres_are_in_the_program_frame() {
    // R90, no offset: from program (0, 0), G91 X1 moves along axis +Y to
    // (0, 1); G3 X-1 Y1 I-1 J0 (program, incremental centre) from program
    // (1, 0): centre program (0, 0) → axis (0, 0), end program (0, 1) →
    // axis (−1, 0).
    let m = run("G21\nG10 L2 P1 R90\nG0 X0 Y0\nG91 G1 X1 F100\nG90 G3 X0 Y1 I-1 J0\nM2\n").unwrap();
    close(end(&m[1]), [0.0, 1.0, 0.0]);
    close(end(&m[2]), [-1.0, 0.0, 0.0]);
    match m[2].kind {
        volcomp_gcode::MotionKind::Arc(a) => {
            assert!(a.center.x.abs() < 1e-9 && a.center.y.abs() < 1e-9, "{a:?}");
        }
        k => panic!("{k:?}"),
    }
}

#[test]
fn rotated_g92_is_added_before_the_rotation() {
    // R90 at axis (0, 5) = program (5, 0); G92 X0: G92 offset X 5 (program
    // frame); G0 X1 → program 1 + 5 = 6 rotated → axis (0, 6).
    let m = run("G21\nG10 L2 P1 R90\nG0 X5 Y0\nG92 X0\nG0 X1\nM2\n").unwrap();
    close(end(&m[0]), [0.0, 5.0, 0.0]);
    close(end(&m[1]), [0.0, 6.0, 0.0]);
}

#[test]
fn what_volcomp_does_not_follow_under_rotation_is_refused() {
    common::refused(&[
        (
            "G21\nG10 L2 P1 R30\nG18 G2 X1 Z0 I0.5 K0 F10\nM2\n",
            "G18/G19",
        ),
        (
            "G21\nG10 L2 P1 R30\nG81 X1 Y1 Z-1 R1 F10\nM2\n",
            "canned cycles",
        ),
        (
            "G21\nG10 L20 P1 X0 R30\nM2\n",
            "R is not allowed with G10 L20",
        ),
    ]);
}

#[test]
fn g52_g92_g10_beside_a_motion_code_or_without_axes_are_refused() {
    // LinuxCNC's enhance_block: "Cannot use two g codes that both use axis
    // values", "All axes missing with g52 or g92" (checked with rs274).
    common::refused_with(
        &tools(&[(1, 10.0)]),
        &[
            ("G52 X1 G0\nM2\n", "both use the axis words"),
            ("G1 F10 G92 X1\nM2\n", "both use the axis words"),
            ("G10 L1 P1 Z1 G0 X1\nM2\n", "both use the axis words"),
            ("G52\nM2\n", "without axis words"),
        ],
    );
}
