//! Under G61, a reversal on the tail of an arc (its last piece, which the
//! original runs through into a tangent line) whose fold into that short
//! piece would kink the path is held to the arc's end instead, and the line
//! after it takes the reversal up from its start (compensate/points.rs,
//! the fold deferred for `exact_hold::held_instead_of_stop`). A fold that
//! kinks is a stop under G61 (tp.c `tpSetupTangent` finds the join not
//! tangent): two of them at a tangent join the original runs through.

use volcomp_core::example::example_map;

use crate::common;

/// The outer loop of bench/eval's pocket_r4 (a 60 × 40 mm pocket with R4
/// corners, lines joined tangent to quarter arcs) under G61 at F6000, in
/// machine coordinates (G54 at 250, 200, 150 mm as in bench/eval).
const POCKET: &str = "G21 G17 G90 G94 G61\nG0 Z155\nG0 X224 Y180\nG1 Z149 F6000\n\
G1 X276\nG3 X280 Y184 I0 J4\nG1 Y216\nG3 X276 Y220 I-4 J0\nG1 X224\n\
G3 X220 Y216 I0 J-4\nG1 Y184\nG3 X224 Y180 I4 J0\nG0 Z155\nM2\n";

#[test]
fn under_g61_a_reversal_on_an_arcs_tail_into_a_tangent_line_is_no_stop() {
    let map = example_map();
    let (out, ratio) = common::compensated_time_ratio(POCKET, &map);
    // On the example map Z's command turns back where the arc of L10 meets
    // the line of L11 (X stops there, and with it X's straightness along
    // Z). Folded into the arc's last 0.08 mm, the 2 µm of Z's band turned
    // Z's slope by 25 mrad at both ends of that piece, 50 times the
    // 0.495 mrad the planner takes as tangent at F6000 with an arc (tp.c
    // tpSetupTangent): two stops. On the planner model (LinuxCNC 2.9's
    // planner to the ms) main d648139 cut this loop in +6.7 % of the
    // original's time; held to the arc's end and taken up on the line's
    // first millimetres, +1.8 %.
    assert!(ratio < 1.03, "{ratio}\n{out}");
    // The hold and the ramp after it leave the tool within the 0.4 µm a
    // take-up the machine runs through may leave under G61 (the 0.5 µm
    // goal less a margin), plus the written numbers' step.
    let report = common::simulated(&out, POCKET, &map);
    assert!(report.contour_max_um <= 0.4 + 0.01, "{report:?}\n{out}");
}
