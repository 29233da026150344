//! Canned cycles written back by `compensate`: G73/G83 pecks, G86's
//! spindle stop and restart, G82/G89 dwells with L repeats, and the cycles
//! that are refused (G87, G88); G84's strokes written unaltered. Expected text derived from LinuxCNC
//! 2.9's interp_cycles.cc by hand.

use std::io::Cursor;
use volcomp_core::compensate::{CompensateOptions, Segmentation};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_gcode::{Vec3, Walker};

/// A map that shifts every point by (5, -3, 2) µm.
fn constant_map() -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, name) in ["X", "Y", "Z"].iter().enumerate() {
        for dir in ["forward", "reverse"] {
            for k in 0..=100 {
                let p = -100.0 + 4.0 * k as f64;
                let e = if a == 0 { [5.0, -3.0, 2.0] } else { [0.0; 3] };
                csv.push_str(&format!("{name},{dir},{p},{},{},{}\n", e[0], e[1], e[2]));
            }
        }
    }
    AxisTableMap::from_csv(&csv, "test.csv").unwrap()
}

use crate::common;

fn walker(program: &str) -> Walker<Cursor<Vec<u8>>> {
    common::walker(program, "test.ngc")
}

fn compensate(program: &str) -> Result<String, String> {
    let options = CompensateOptions {
        segmentation: Segmentation::Off,
        ..Default::default()
    };
    common::compensate_text(program, "test.ngc", &constant_map(), &options)
}

use common::motion_ends as ends;

/// `out` is `program` moved by −e of [`constant_map`].
fn shifted_by_minus_e(program: &str, out: &str) {
    common::assert_shifted(program, out, Vec3::new(-0.005, 0.003, -0.002));
}

#[test]
fn peck_cycles_are_written_as_their_compensated_moves() {
    let program = "G21 G90 G17\nG0 X0 Y0 Z10\nG98 G83 X10 Y10 Z-5 R2 Q2 F100\nG99 G73 X20 Z-3 R1 Q1.5\nG80\nG0 Z20\nM2\n";
    let out = compensate(program).unwrap();
    assert!(out.contains("G98 G80 F100\n"), "{out}");
    assert!(out.contains("G99 G80\n"), "{out}");
    assert!(!out.contains('Q'), "{out}");
    shifted_by_minus_e(program, &out);
}

/// The lines of `out`, and the indices of those that are `line`: there must
/// be `count` of them.
fn lines_and_where<'a>(out: &'a str, line: &str, count: usize) -> (Vec<&'a str>, Vec<usize>) {
    let lines: Vec<&str> = out.lines().collect();
    let at: Vec<usize> = (0..lines.len()).filter(|&i| lines[i] == line).collect();
    assert_eq!(at.len(), count, "`{line}`: {out}");
    (lines, at)
}

#[test]
fn g86_stops_the_spindle_at_the_bottom_and_restarts_it_after_the_retract() {
    let program =
        "G21 G90 G17 S1000 M4\nG0 X0 Y0 Z10\nG98 G86 X10 Y10 Z-5 R2 P0.25 F100 L2\nG80\nM2\n";
    let out = compensate(program).unwrap();
    // Each repeat: … feed to the bottom, G4 P0.25, M5, rapid out, M4.
    let (lines, dwells) = lines_and_where(&out, "G4 P0.25", 2);
    for i in dwells {
        assert!(lines[i - 1].starts_with("G1"), "{out}");
        assert_eq!(lines[i + 1], "M5", "{out}");
        assert!(lines[i + 2].starts_with("G0"), "{out}");
        assert_eq!(lines[i + 3], "M4", "{out}");
    }
    shifted_by_minus_e(program, &out);
}

#[test]
fn g89_dwells_only_at_the_bottom_of_each_repeat() {
    let program = "G21 G90 G17\nG0 X0 Y0 Z10\nG91 G99 G89 X5 Z-4 R-8 P0.5 F100 L3\nG90 G80\nM2\n";
    let out = compensate(program).unwrap();
    assert_eq!(out.matches("G4 P0.5").count(), 3, "{out}");
    shifted_by_minus_e(program, &out);
}

#[test]
fn back_boring_and_manual_retract_are_refused_with_reasons() {
    for (block, what) in [
        ("G87 X10 Y10 Z-5 R2 I1 J0 K-3", "G87"),
        ("G88 X10 Y10 Z-5 R2 P1", "G88"),
    ] {
        let program = format!("G21 G90 G17 S500 M3\nG0 X0 Y0 Z10\nF100 {block}\nG80\nM2\n");
        let e = compensate(&program).unwrap_err();
        assert!(e.contains(what) && e.contains(":3"), "{e}");
    }
}

#[test]
fn g84_strokes_are_the_nominal_strokes_moved_with_the_hole() {
    // LinuxCNC 2.9's G84 (convert_cycle_g74_g84): feed down, M5, M4, dwell,
    // feed up, M5, M3, with feed and speed overrides disabled for it.
    let program =
        "G21 G90 G17 S500 M3\nG0 X0 Y0 Z10\nG99 G84 X10 Y10 Z-5 R2 P0.5 F100 L2\nG80\nM2\n";
    let out = compensate(program).unwrap();
    let (lines, tops) = lines_and_where(&out, "M49", 2);
    for i in tops {
        assert_eq!(&lines[i + 2..i + 5], &["M5", "M4", "G4 P0.5"], "{out}");
        assert_eq!(&lines[i + 6..i + 9], &["M5", "M3", "M48"], "{out}");
    }
    // The written moves: every move but the strokes is the nominal one
    // shifted by −e; each stroke is a pure Z move of the nominal 7 mm, down
    // from and back up to the compensated R point.
    let written = ends(&out);
    let shift = Vec3::new(-0.005, 0.003, -0.002);
    let top = Vec3::new(10.0, 10.0, 2.0) + shift;
    let bottom = top + Vec3::new(0.0, 0.0, -7.0);
    let n = written.len();
    assert!((written[n - 1] - top).max_abs() < 1e-9, "{out}");
    assert!((written[n - 2] - bottom).max_abs() < 1e-9, "{out}");
    assert!((written[n - 3] - top).max_abs() < 1e-9, "{out}");
    assert!((written[n - 4] - bottom).max_abs() < 1e-9, "{out}");
}

#[test]
fn g74_reverses_the_other_way() {
    let program = "G21 G90 G17 S500 M4\nG0 X0 Y0 Z10\nG99 G74 X10 Y10 Z-5 R2 P0.5 F100\nG80\nM2\n";
    let out = compensate(program).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    let i = lines.iter().position(|l| *l == "M49").unwrap();
    assert_eq!(&lines[i + 2..i + 5], &["M5", "M3", "G4 P0.5"], "{out}");
    assert_eq!(&lines[i + 6..i + 9], &["M5", "M4", "M48"], "{out}");
    shifted_by_minus_e_except_strokes(&out);
}

fn shifted_by_minus_e_except_strokes(out: &str) {
    // The stroke from the compensated R point is the nominal 7 mm in Z.
    let written = ends(out);
    let n = written.len();
    let dz = written[n - 2].z - written[n - 3].z;
    assert!((dz + 7.0).abs() < 1e-9, "{out}");
}

/// The path mode of every motion of `program` (zero-length ones dropped,
/// as [`ends`] drops them).
fn modes(program: &str) -> Vec<volcomp_gcode::PathMode> {
    let mut w = walker(program);
    let (mut out, mut last) = (Vec::new(), None);
    while let Some(ev) = w.next_line().unwrap() {
        for m in ev.motions {
            if last != Some(m.end) {
                out.push(m.path_mode);
            }
            last = Some(m.end);
        }
    }
    out
}

#[test]
fn a_cycle_written_as_moves_runs_in_exact_path_as_the_cycle_does() {
    // LinuxCNC runs a cycle's moves in G61 and then restores the program's
    // mode (interp_cycles.cc): the written moves say G61 before them and
    // the program's G64 P0.01 after them, so every move of the output runs
    // in the mode its original move runs in.
    let program = "G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z10\nG98 G81 X10 Y10 Z-5 R2 F100\nX20\nG80\nG1 X0 F100\nM2\n";
    let out = compensate(program).unwrap();
    assert_eq!(out.matches("\nG61\n").count(), 2, "{out}");
    assert_eq!(out.matches("\nG64 P0.01\n").count(), 2, "{out}");
    shifted_by_minus_e(program, &out);
    assert_eq!(modes(&out), modes(program), "{out}");
    // So the planner model gives both the same time, to the servo period.
    let setup = volcomp_core::compensate::MachineSetup::default();
    let limits = volcomp_core::plan::Limits::default();
    let time = |p: &str| {
        volcomp_core::plan::estimate_program(p.as_bytes(), "t.ngc", &setup, &limits)
            .unwrap()
            .motion
            .total_s
    };
    assert!((time(&out) - time(program)).abs() <= 0.0015, "{out}");
    // In inch, the tolerance is written in inches; under G61 nothing is
    // added.
    let inch = "G20 G90 G17 G64 P0.001\nG0 X0 Y0 Z0.5\nG81 X1 Y1 Z-0.2 R0.1 F4\nG80\nM2\n";
    let out = compensate(inch).unwrap();
    assert!(
        out.contains("\nG61\n") && out.contains("\nG64 P0.001\n"),
        "{out}"
    );
    assert_eq!(modes(&out), modes(inch), "{out}");
    let exact = "G21 G90 G17 G61\nG0 X0 Y0 Z10\nG81 X10 Y10 Z-5 R2 F100\nG80\nM2\n";
    let out = compensate(exact).unwrap();
    assert_eq!(out.matches("G61").count(), 1, "{out}");
}
