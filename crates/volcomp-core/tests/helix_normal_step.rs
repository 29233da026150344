//! Under G64 without P, the step an S-curve makes in a helix' rise axis is
//! spread over the pieces around it, so LinuxCNC joins the helical pieces
//! as tangent (compensate/arcs.rs, `smooth_normal_kinks` under `Smoothing::Folded`).

use crate::common;

/// bench/eval's helix_cw_d10 (a Ø10 bore, three turns of 2 mm clockwise and
/// a flat turn) under G64 at F6000, in machine coordinates (G54 at 250,
/// 200, 150 mm as in bench/eval).
const BORE: &str = "G21 G17 G90 G94 G64\nG0 Z155\nG0 X245 Y200\nG1 Z150 F6000\n\
G2 X245 Y200 Z148 I5 J0\nG2 X245 Y200 Z146 I5 J0\nG2 X245 Y200 Z144 I5 J0\n\
G2 X245 Y200 I5 J0\nG0 Z155\nM2\n";

#[test]
fn under_g64_a_helical_bore_keeps_its_pieces_tangent_across_the_s_curves() {
    // bench/coarse_map.py's map: reversal values of 10–15 µm, and Z
    // straightness that switches with the direction of X and Y, so Z's
    // command steps by about 3 µm across every S-curve at a quarter point.
    let map = common::data_map("coarse_map.csv");
    let (out, ratio) = common::compensated_time_ratio(BORE, &map);
    // Left on the S-curve's two short arcs, that step turned the helical
    // pieces' tangents by about 1 mrad at their joins, above LinuxCNC's
    // tangency tolerance (4.95e-4 rad on an arc at F6000): blended
    // parabolically at every quarter point. On LinuxCNC 2.9 itself
    // (bench/cycle_time's sim, the same program in program coordinates):
    // 2.700 s of cutting in the original, 2.997 s compensated with the
    // step left, 2.718 s spread within each block, 2.522 s spread from the
    // slope each turn comes in with as well (the S-curve at each turn's
    // start, X's reversal); the planner model gives each to the ms.
    assert!(ratio < 0.95, "{ratio}\n{out}");
    // The spread moves Z by up to the step near the quarter points: the
    // dead-band simulation's contour RMS 2.099 → 2.383 µm. Its maximum is
    // at a reversal: the fold of a 10–15 µm reversal value (10.389 µm)
    // with Z moved across it by up to the step (about 3 µm), at most
    // √(10.389² + 3²) µm (10.571 µm here).
    let report = common::simulated(&out, BORE, &map);
    assert!(report.contour_rms_um <= 2.40, "{report:?}\n{out}");
    assert!(
        report.contour_max_um <= 10.389f64.hypot(3.0),
        "{report:?}\n{out}"
    );
}
