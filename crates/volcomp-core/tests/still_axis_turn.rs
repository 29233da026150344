//! Under G61, a raster's pass axis Y, which the passes do not move, turned
//! back by the map along a pass (docs/compensation.md, "A still axis'
//! reversal at a line's end that the next motion turns back is held"):
//! held at the pass' end where the step-over after it moves Y its old way
//! (compensate/tail_hold.rs), or, where it was turned back on an earlier
//! pass line, taken up again on the pass' last piece before the step-over
//! (compensate/idle.rs `State::turned_back_axes`). Checked by hand (the
//! written Y) and by the dead-band simulation.

use volcomp_core::compensate::CompensateSummary;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;
use common::map_from;

/// X's tables (both directions) with a straightness in Y of `slope_um`
/// per mm of X (e = actual − commanded: the tool is `slope_um·x` high in
/// Y, so Y's command falls as X travels), and Y's reverse table 4 µm above
/// its forward one (a band of 4 µm); nothing else.
fn drift_map(slope_um: f64) -> AxisTableMap {
    map_from(move |a, p, rev| match (a, rev) {
        (0, _) => [0.0, slope_um * p, 0.0],
        (1, true) => [0.0, 4.0, 0.0],
        _ => [0.0; 3],
    })
}

/// `program` compensated with the defaults at `decimals` decimals, without
/// the lines of the approach before the first cut.
fn compensate(program: &str, map: &AxisTableMap, decimals: u8) -> (String, CompensateSummary) {
    common::compensate_cut(program, map, decimals)
}

/// The dead-band simulation's contour maximum (µm) of `out` against
/// `program`.
fn contour_max_um(out: &str, program: &str, map: &AxisTableMap) -> f64 {
    common::simulated(out, program, map).contour_max_um
}

/// Y as written (modal: the last Y word so far) on the last written line
/// whose X word is `x`.
fn y_at(out: &str, x: f64) -> f64 {
    let (mut y, mut found) = (f64::NAN, None);
    for line in out.lines().filter(|l| !l.starts_with('(')) {
        let word = |letter: char| {
            line.split_whitespace()
                .find(|w| w.starts_with(letter))
                .and_then(|w| w[1..].parse::<f64>().ok())
        };
        if let Some(v) = word('Y') {
            y = v;
        }
        if word('X') == Some(x) {
            found = Some(y);
        }
    }
    found.unwrap_or_else(|| panic!("no X{x} in {out}"))
}

#[test]
fn a_pass_end_drifting_back_under_the_hold_bound_before_a_step_on_holds_y() {
    // Y moves +5, then the pass X0 → X10 (Z rising, out of the plane: no
    // held tail) leaves Y at 5 while its command must fall by
    // 0.006 µm/mm · 10 mm = 0.06 µm: a reversal of Y at the pass' end,
    // which would take up Y's whole band, Y5 − 0.00006 − 0.004 = 4.99594
    // → Y4.9959. The step-over after it moves Y +5 again: Y is held at its
    // command, Y5.0000 (0.06 µm off, within the hold's 0.1 µm), and the
    // step goes on forward to Y10 − 0.00006 → Y9.9999.
    let map = drift_map(0.006);
    let program =
        "G21 G90 G17 G61\nG0 X0 Y0 Z0\nG1 Y5 F6000\nG1 X10 Z1\nG1 Y10 Z1.5\nG1 X0 Z2\nM2\n";
    let (out, s) = compensate(program, &map, 4);
    // The pass is written without a Y word: Y stays at 5.
    assert_eq!(y_at(&out, 10.0), 5.0, "{out}");
    assert!(!out.contains("Y4.99"), "{out}");
    assert!(s.small_reversals_held >= 1, "{out}");
    // Y never reverses: no take-up block of Y at the pass' end or at the
    // step-over, and the tool stays within the hold's 0.1 µm.
    assert!(!out.contains("take-up"), "{out}");
    let contour = contour_max_um(&out, program, &map);
    assert!(contour < 0.1, "{contour}: {out}");
}

#[test]
fn y_turned_back_on_a_pass_is_taken_up_again_on_the_last_pass_line_before_a_step_on() {
    // At 5 decimals (a step of 0.01 µm). Y moves +5; the pass X0 → X10 →
    // X20 (Z rising) leaves Y at 5 while its command falls by
    // 0.005 µm/mm: Y reverses on the first pass line, where the next line
    // does not move Y (no hold), and takes up its band there: at X10
    // Y5 − 0.00005 − 0.004 = 4.99595. On the second pass line Y would stay
    // reversed (Y5 − 0.0001 − 0.004 = 4.9959, the last test); the
    // step-over after it moves Y +5, so that line's last piece is written
    // with Y forward again, Y5 − 0.0001 = 4.9999, its command crossing
    // Y's band along the pass (3.95 µm of 4: the drift takes the rest),
    // and the step-over starts with Y already forward, to
    // Y10 − 0.0001 = 9.9999: no take-up block at its corner.
    let map = drift_map(0.005);
    let program =
        "G21 G90 G17 G61\nG0 X0 Y0 Z0\nG1 Y5 F6000\nG1 X10 Z1\nG1 X20 Z2\nG1 Y10 Z2.5\nG1 X0 Z3\nM2\n";
    let (out, s) = compensate(program, &map, 5);
    assert_eq!(y_at(&out, 10.0), 4.99595, "{out}");
    assert_eq!(y_at(&out, 20.0), 4.9999, "{out}");
    assert_eq!(s.take_ups_idle, 1, "{out}");
    assert!(out.contains("G1 Y9.9999 Z2.5\n"), "{out}");
    assert!(!out.contains("take-up"), "{out}");
    // Under the dead band the tool stays within the fold's bound: Y's
    // command crosses its band along the last pass line but for the
    // 0.05 µm the drift takes, which the step-over then takes up.
    let contour = contour_max_um(&out, program, &map);
    assert!(contour < 0.06, "{contour}: {out}");
}

#[test]
fn a_step_over_back_leaves_the_last_pass_line_as_solved() {
    // The same passes, then a step-over in −Y: Y's reversal stands, nothing
    // is taken up ahead: at X20 Y5 − 0.0001 − 0.004 = 4.9959, and the step
    // to Y0 − 0.0001 − 0.004 = −0.0041.
    let map = drift_map(0.005);
    let program =
        "G21 G90 G17 G61\nG0 X0 Y0 Z0\nG1 Y5 F6000\nG1 X10 Z1\nG1 X20 Z2\nG1 Y0 Z2.5\nG1 X0 Z3\nM2\n";
    let (out, s) = compensate(program, &map, 5);
    assert_eq!(y_at(&out, 20.0), 4.9959, "{out}");
    assert_eq!(s.take_ups_idle, 0, "{out}");
    assert!(out.contains("G1 Y-0.0041 Z2.5\n"), "{out}");
}

#[test]
fn only_the_pass_line_before_the_step_on_is_taken_up_ahead() {
    // Three pass lines: the second, followed by a pass line, keeps Y
    // reversed (Y5 − 0.0001 − 0.004 = 4.9959); the third, before the
    // step-over, is written with Y forward, Y5 − 0.00015 = 4.99985.
    let map = drift_map(0.005);
    let program = "G21 G90 G17 G61\nG0 X0 Y0 Z0\nG1 Y5 F6000\nG1 X10 Z1\nG1 X20 Z2\nG1 X30 Z3\nG1 Y10 Z2.5\nG1 X0 Z3\nM2\n";
    let (out, s) = compensate(program, &map, 5);
    assert_eq!(y_at(&out, 20.0), 4.9959, "{out}");
    assert_eq!(y_at(&out, 30.0), 4.99985, "{out}");
    assert_eq!(s.take_ups_idle, 1, "{out}");
}
