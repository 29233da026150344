//! Under G64 P, a small reversal inside a line taken up where its take-up
//! keeps the path tangent, not held to the line's end
//! (docs/compensation.md, "Small reversals held"; compensate/turn_back.rs
//! `holds_at`), checked against hand values.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X's table moves the tool in Z by −0.2 µm per mm of X and Y's by
/// +0.02·y² µm (both directions), so Z's command, with Z standing still in
/// the program, is 0.2·x − 0.02·y² µm; Z has a 2 µm band (its reverse
/// table moves the tool 2 µm up). Table points every 0.25 mm.
fn corner_map() -> AxisTableMap {
    common::map_fine_on(&[0, 1], 100.0, |a, p, rev| match a {
        0 => [0.0, 0.0, -0.2 * p],
        1 => [0.0, 0.0, 0.02 * p * p],
        _ => [0.0, 0.0, if rev { 2.0 } else { 0.0 }],
    })
}

#[test]
fn under_g64_p_a_reversal_inside_a_line_is_taken_up_not_held_on() {
    // Along X to X 20 Z's command rises to 4 µm; along Y after the corner
    // it falls by 0.02·y² µm: Z reverses at the corner. The line along Y
    // is split every 2.5 mm (the contour tolerance on the quadratic). At
    // the corner (the line's first target, Y 2.5) the fall is held
    // (solve.rs `hold_small_reversals`, within P0.005 less the 0.1 µm
    // contour tolerance): the tool off by 0.02·2.5² = 0.125 µm, by hand.
    // Main 81922d1 held it on at Y 5 and Y 7.5 too (the tool off by
    // 1.125 µm there, three holds) and took it up at Y 10 (contour max
    // 1.681 µm on the simulation). Inside the line a take-up that keeps
    // the path tangent is taken: here a ramp from Y 2.5 to Y 7.5
    // (points.rs `plan_ramp`; each end turns by 2 µm / 5 mm = 0.4 mrad,
    // under the 1 mrad tp.c `tpSetupTangent` gives between lines at
    // F6000). One hold, and from Y 10 on Z's command is its reverse
    // state's, 4 − 0.02·y² − 2 µm (by hand).
    let map = corner_map();
    let program = "G21 G90 G17 G64 P0.005\nG0 X0 Y0 Z0\nG1 X20 F6000\nG1 Y20\nM2\n";
    let (out, records, summary) = common::compensate_recorded(program, &map);
    assert_eq!(summary.small_reversals_held, 1, "{out}");
    assert!(
        (summary.max_hold_error_um - 0.125).abs() < 0.01,
        "{}: {out}",
        summary.max_hold_error_um
    );
    let line: Vec<_> = records.iter().filter(|r| r.line == 4).collect();
    let at = |y: f64| line.iter().find(|r| (r.target_mm.y - y).abs() < 1e-9);
    // Held at the corner's command at Y 2.5; turned down by Y 5.
    let corner_um = at(2.5).unwrap().command_mm.z * 1e3;
    assert!((corner_um - 4.0).abs() < 0.011, "{corner_um}: {out}");
    assert!(
        at(5.0).unwrap().command_mm.z * 1e3 < corner_um - 1.0,
        "{out}"
    );
    for y in [10.0, 15.0, 20.0] {
        let z_um = at(y).unwrap().command_mm.z * 1e3;
        let hand_um = 4.0 - 0.02 * y * y - 2.0;
        assert!(
            (z_um - hand_um).abs() < 0.011,
            "Y{y}: {z_um} vs {hand_um}: {out}"
        );
    }
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um < 1.0, "{report:?}: {out}");
}
