//! Under G61, a take-up of the arc plane's normal axis that a quarter
//! point's switch calls for is written right before the S-curve where the
//! reversing axis' step from the normal axis' switch runs its old way
//! (docs/compensation.md, "A normal-axis take-up before the S-curve"),
//! checked on the written words against hand values.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// The switching straightness of bench/coarse_map.py without its waves:
/// bands X 12, Y 15, Z 10 µm; each off-axis column +s forward, −s reverse
/// (X: Y 2, Z −1.5; Y: X 2.5, Z 1; Z: X 1.5, Y −2 µm).
fn coarse_switching_map() -> AxisTableMap {
    common::map_from(|a, _p, rev| {
        let s = if rev { -1.0 } else { 1.0 };
        let band = if rev { [12.0, 15.0, 10.0][a] } else { 0.0 };
        let mut e = match a {
            0 => [0.0, 2.0 * s, -1.5 * s],
            1 => [2.5 * s, 0.0, 1.0 * s],
            _ => [1.5 * s, -2.0 * s, 0.0],
        };
        e[a] = band;
        e
    })
}

/// Every written line with the modal X, Y, Z after it (absolute words).
fn modal_lines(out: &str) -> Vec<(String, [f64; 3])> {
    let mut q = [f64::NAN; 3];
    let mut lines = Vec::new();
    for line in out.lines() {
        let code = line.split('(').next().unwrap_or("");
        for w in code.split_whitespace() {
            for (a, c) in ['X', 'Y', 'Z'].iter().enumerate() {
                if let Some(v) = w.strip_prefix(*c) {
                    q[a] = v.parse().unwrap();
                }
            }
        }
        lines.push((line.to_string(), q));
    }
    lines
}

#[test]
fn under_g61_a_z_take_up_a_quarter_point_calls_for_comes_before_the_s_curve() {
    // By hand. The circle runs clockwise from 30°, X forward, Y reverse, Z
    // forward after the plunge's take-up. At X's quarter point (20, 0) X's
    // switch moves the tool +3 µm in Z (X's Z column −1.5 → +1.5 µm), so
    // Z's command must fall 3 µm against its flank: Z reverses. Z's own
    // switch moves the tool by its band 10 µm in Z, −3 µm in X (Z's X
    // column 1.5 → −1.5) and +4 µm in Y (−2 → 2): the take-up moves X
    // +3 µm, Y −4 µm and Z −10 µm. After the quarter point X runs its
    // reverse way and cannot step +3 µm (main 6d877ee writes the block
    // after the S-curve without an X word: the tool stands 3 µm off in X);
    // before it X still runs forward and Y reverse, so every step of the
    // block runs its axis' way there.
    let map = coarse_switching_map();
    // The circle about (250, 200, 150), as bench/eval writes g2_d40 with its
    // work offset: there the approach leaves Z on its forward flank.
    let program = "G21 G17 G90 G61\nG0 X267.3205 Y210 Z155\nG1 Z150 F6000\n\
                   G2 X267.3205 Y210 I-17.3205 J-10\nG0 Z155\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let lines = modal_lines(&out);
    let at = lines
        .iter()
        .position(|(l, q)| l.contains("(volcomp L4 take-up)") && (q[0] - 270.0).abs() < 0.01)
        .unwrap_or_else(|| panic!("no take-up at X's quarter point:\n{out}"));
    let (line, q) = &lines[at];
    let before = lines[at - 1].1;
    let want_um = [3.0, -4.0, -10.0];
    for a in 0..3 {
        let step_um = (q[a] - before[a]) * 1e3;
        assert!(
            (step_um - want_um[a]).abs() < 0.015,
            "axis {a}: {step_um} µm, want {} ({line})\n{out}",
            want_um[a]
        );
        assert!(
            line.contains(['X', 'Y', 'Z'][a]),
            "axis {a} not written ({line})\n{out}"
        );
    }
    // The block is before the quarter point: X still rises to it and turns
    // back on the S-curve after the block.
    assert!(before[0] < q[0], "{out}");
    let after: Vec<f64> = lines[at + 1..at + 6].iter().map(|(_, p)| p[0]).collect();
    assert!(after.iter().all(|x| *x <= q[0]), "{after:?}\n{out}");
    assert!(after[4] < q[0] - 0.005, "{after:?}\n{out}");
}

#[test]
fn under_g61_the_take_up_after_an_s_curve_at_an_arcs_start_reaches_the_arc() {
    // By hand. A G19 circle of radius 8 about (250, 200, 141) begins at the
    // extreme of Y (208, 141), where the plunge meets it tangentially: Y
    // reverses there on an S-curve, and the plane's normal X must reverse
    // after it (Y's X column +2.5 → −2.5 µm moves the tool −5 µm in X).
    // With the map's values X's command is 250 − e_x: after the plunge
    // (X reverse, Y forward, Z reverse) e_x = 12 + 2.5 − 1.5 = 13 µm; on
    // the circle (X forward, Y reverse, Z reverse) e_x = 0 − 2.5 − 1.5 =
    // −4 µm. So the take-up moves X from 249.987 to 250.004 (+17 µm).
    // Main 621cc8b kept the tool where the S-curve left it: X 249.999
    // (+12 µm, the band only), 5 µm short until the first piece's end.
    let map = coarse_switching_map();
    let program = "G21 G17 G90 G61\nG0 X250 Y208 Z155\nG1 Z141 F6000\n\
                   G19 G2 Y208 Z141 J-8 K0\nG17 G0 Z155\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let lines = modal_lines(&out);
    let at = lines
        .iter()
        .position(|(l, _)| l.contains("(volcomp L4 take-up)"))
        .unwrap_or_else(|| panic!("no take-up on the circle:\n{out}"));
    let (line, q) = &lines[at];
    assert!(line.contains('X'), "no X word ({line})\n{out}");
    assert!(
        (q[0] - 250.004).abs() < 0.02e-3,
        "X {} , want 250.004 ({line})\n{out}",
        q[0]
    );
    // The block ends on the way down the circle (Z below where it starts)
    // and the piece after it is still an arc of the circle.
    assert!(q[2] < lines[at - 1].1[2], "{out}");
    let next = &lines[at + 1..]
        .iter()
        .find(|(l, _)| !l.contains("path mode"))
        .unwrap()
        .0;
    assert!(next.contains("G2") || next.contains("G3"), "{next}\n{out}");
}

#[test]
fn a_take_up_ending_along_an_arc_piece_leaves_the_piece_after_it_an_arc() {
    // Set c's R-arc wave (bench/eval/make_set_c.py r_arcs_g91_b, with its
    // G54 of (250, 200, 150) added by hand) on the coarse map, where Z
    // reverses right after Y's quarter-point S-curve of the G2 and its
    // take-up block ends a little along the piece after it. The faster the
    // feed, the longer the S-curve's pieces and the fewer the pieces after
    // it: from F8000 on, main c4f6cb2 ended the block 10 % along a 1.8 mm
    // piece (a 0.17 mm chord) and fitted the piece after it as if it began
    // where the block did; its words did not read as an arc, and it was
    // written as a straight line, 121.9 µm off the arc in the dead-band
    // simulation (a second method: simulate/) and 150.3 µm in its own
    // estimate. Every feed now leaves at most what F3000 leaves, where no
    // block ends along a piece: 3.70 µm, the coarse map's switching steps
    // (the original: 25.9 µm).
    let map = common::data_map("coarse_map.csv");
    for feed in [3000, 8000, 10000] {
        let program = format!(
            "G21 G17 G90 G94 G61\nG0 X235 Y188 Z155\nG1 Z149.6 F{feed}\nG91\n\
             G3 X4 Y1 R2.5\nG2 X4 Y1 R2.5\nG3 X4 Y1 R2.5\nG2 X4 Y1 R2.5\nG90\nG0 Z155\nM2\n"
        );
        let (out, _, summary) = common::compensate_recorded(&program, &map);
        let report = common::simulated(&out, &program, &map);
        assert!(
            report.contour_max_um <= 3.75,
            "F{feed}: {} µm\n{out}",
            report.contour_max_um
        );
        let estimate_um = summary.max_estimated_contour_um.unwrap();
        assert!(
            estimate_um <= 0.1,
            "F{feed}: estimate {estimate_um} µm\n{out}"
        );
    }
}
