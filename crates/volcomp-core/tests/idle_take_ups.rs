//! Take-ups ahead in an idle move (docs/compensation.md, "Take-ups ahead in
//! an idle move"): a zigzag's X reversal taken up during the Y step before
//! it, where X stands still; checked by hand and by the dead-band
//! simulation.

use volcomp_core::compensate::CompensateSummary;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;
use common::map_from;

/// X's reverse table `b_um` above its forward one (a reversal value of
/// `b_um`), nothing else.
fn x_reversal_map(b_um: f64) -> AxisTableMap {
    map_from(move |a, _, rev| match (a, rev) {
        (0, true) => [b_um, 0.0, 0.0],
        _ => [0.0; 3],
    })
}

/// `program` compensated with the defaults at 4 decimals (a step of
/// 0.1 µm, what the words below were worked out with), without the lines
/// of the approach before the first cut (tests/compensation.rs checks them;
/// a short move away and back, they change no direction the compensation
/// holds).
fn compensate(program: &str, map: &AxisTableMap) -> (String, CompensateSummary) {
    common::compensate_cut(program, map, 4)
}

/// The dead-band simulation's contour maximum (µm) of `out` against
/// `program`.
fn contour_max_um(out: &str, program: &str, map: &AxisTableMap) -> f64 {
    common::simulated(out, program, map).contour_max_um
}

/// Under G61 a line in the plane holds back its last `w = 2·v·√(b/a_n)`
/// for an S-curve into an arc that may follow (docs/compensation.md, "Held
/// tails"): at F6000 (v = 100 mm/s) with b = 4 µm and a_n = 1000·√0.75 =
/// 866.03 mm/s², w = 0.42982 mm, so the step to Y5 is cut at Y4.5702.
const G61_CUT: &str = "G1 Y4.5702 G64 P0.0001 Q0";

#[test]
fn a_zigzag_takes_up_x_during_the_y_step_in_every_path_mode() {
    // X's reverse error is +4 µm (e = actual − commanded): moving −X the
    // command is 4 µm below the target. The step in Y (X still at 30) is
    // written with its end solved in X's new direction: X30 − 0.004 =
    // 29.996, its command crossing X's band while X's table stands; the
    // pass back needs no take-up block and no fold.
    let map = x_reversal_map(4.0);
    for mode in ["G61", "G61.1", "G64 P0.005", "G64"] {
        let program = format!("G21 G90 G17 {mode}\nG0 X0 Y0 Z0\nG1 X30 F6000\nG1 Y5\nG1 X0\nM2\n");
        let (out, s) = compensate(&program, &map);
        let lines: Vec<&str> = out.lines().collect();
        let step: Vec<&str> = if mode == "G61" {
            vec![G61_CUT, "X29.9960 Y5.0000 G61 (volcomp L4)"]
        } else {
            vec!["G1 Y5 X29.9960"]
        };
        assert_eq!(lines[3..3 + step.len()], step[..], "{mode}: {out}");
        assert_eq!(lines[3 + step.len()], "G1 X-0.0040", "{mode}: {out}");
        assert!(!out.contains("take-up"), "{mode}: {out}");
        assert_eq!(
            (s.take_ups, s.take_ups_folded, s.take_ups_idle),
            (0, 0, 1),
            "{mode}: {out}"
        );
        assert!(
            s.reversals_text()
                .contains("1 taken up ahead in an idle move"),
            "{}",
            s.reversals_text()
        );
        // Under the dead band the tool stays on the path: X's command
        // crosses exactly its band during the step.
        let contour = contour_max_um(&out, &program, &map);
        assert!(contour < 0.01, "{mode}: {contour}");
    }
}

#[test]
fn a_step_between_passes_the_same_way_is_written_as_before() {
    // Pass, step, pass on in +X: X does not reverse, so the step keeps X
    // at 30 and nothing changes (the forward table is zero: the program
    // comes back as it was, under G61 with the step's held tail cut off).
    let map = x_reversal_map(4.0);
    for mode in ["G61", "G61.1", "G64"] {
        let program = format!("G21 G90 G17 {mode}\nG0 X0 Y0 Z0\nG1 X30 F6000\nG1 Y5\nG1 X60\nM2\n");
        let (out, s) = compensate(&program, &map);
        let expected = if mode == "G61" {
            program.replace("G1 Y5\n", &format!("{G61_CUT}\nY5.0000 G61 (volcomp L4)\n"))
        } else {
            program.clone()
        };
        assert_eq!(out, expected, "{mode}");
        assert_eq!(s.take_ups_idle, 0);
    }
}

#[test]
fn a_comment_between_the_step_and_the_pass_lets_the_step_go_as_solved() {
    // The line after the step is not a motion: the step goes out as it
    // was solved before it (X at 30), and the pass folds X's take-up into
    // itself as before (its lag lies along the pass: exact).
    let map = x_reversal_map(4.0);
    let program = "G21 G90 G17 G64\nG0 X0 Y0 Z0\nG1 X30 F6000\nG1 Y5\n(pass back)\nG1 X0\nM2\n";
    let (out, s) = compensate(program, &map);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines[3..6],
        ["G1 Y5", "(pass back)", "G1 X-0.0040"],
        "{out}"
    );
    assert_eq!(
        (s.take_ups, s.take_ups_folded, s.take_ups_idle),
        (0, 1, 0),
        "{out}"
    );
}

#[test]
fn a_negative_reversal_value_is_not_taken_up_ahead() {
    // X's reverse error 4 µm below its forward one: the new direction's
    // command lies the old way (X30 + 0.004), no dead band to cross: the
    // step is written as before (X stays at 30).
    let map = x_reversal_map(-4.0);
    let program = "G21 G90 G17 G64\nG0 X0 Y0 Z0\nG1 X30 F6000\nG1 Y5\nG1 X0\nM2\n";
    let (out, s) = compensate(program, &map);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[3], "G1 Y5", "{out}");
    assert_eq!(s.take_ups_idle, 0, "{out}");
}

#[test]
fn a_rapid_step_carries_no_take_up() {
    // The step is a rapid: positioning, where the take-up stays off.
    let map = x_reversal_map(4.0);
    let program = "G21 G90 G17 G64\nG0 X0 Y0 Z0\nG1 X30 F6000\nG0 Y5\nG1 X0\nM2\n";
    let (out, s) = compensate(program, &map);
    assert_eq!(s.take_ups_idle, 0, "{out}");
    assert!(out.lines().any(|l| l == "G0 Y5"), "{out}");
}
