//! Under G61, an axis a line does not move whose command turns back by a
//! hundredth of a micrometre at the line's end, where the next line moves
//! it on its old way, is held through the corner instead of reversing
//! there and back (docs/compensation.md, "A still axis' reversal at a
//! line's end that the next motion turns back is held"), checked end to
//! end against hand values.

use crate::common;

#[test]
fn under_g61_a_still_axis_that_the_next_line_moves_its_old_way_is_held_at_the_line_s_end() {
    // Y's error from X's table is 0.002 µm per mm of X (its straightness,
    // the same both ways), Y's own band 10 µm; nothing else. The pass
    // X1 → X10 at Y1 (Y forward since the line to Y1) asks Y's command
    // for 1 − 0.002·X µm: 0.999998 mm (written 1.00000) at X1, 0.99998 mm
    // at X10, two steps of the fifth decimal back, so Y would reverse at
    // the pass' end (its band of 10 µm taken up: Y0.98998), and again at
    // the step-over to Y3, which moves it forward. Held, Y stays at
    // 1.00000 to the pass' end, the tool 0.02 µm off (within the 0.1 µm
    // the hold allows), and runs on forward to 3 − 0.00002 = 2.99998 mm:
    // no reversal on either line. Main (621cc8b) writes the pass as
    // `G1 X9.32038 Y0.98998` then `X10.00000 Y0.99998`: Y down its band
    // and up again inside the pass (checked with `volcomp compensate
    // --decimals 5` on the same program and map).
    let map = common::map_from(|a, p, rev| match a {
        0 => [0.0, 0.002 * p, 0.0],
        1 => [0.0, if rev { 10.0 } else { 0.0 }, 0.0],
        _ => [0.0; 3],
    });
    let program = "G21 G61\nG0 X0 Y0 Z0\nG1 X1 F6000\nG1 Y1\nG1 X10\nG1 Y3\nM2\n";
    let (out, _, summary) = common::compensate_recorded(program, &map);
    // Y's written commands from the line to Y1 on, each word carried from
    // the line before where it is not written.
    let mut y = f64::NAN;
    let mut ys = Vec::new();
    let mut on = false;
    for line in out.lines().filter(|l| !l.starts_with('(')) {
        on |= line.starts_with("G1 Y1");
        for w in line.split_whitespace() {
            if let Some(v) = w.strip_prefix('Y') {
                y = v.parse().unwrap();
            }
        }
        if on {
            ys.push(y);
        }
    }
    assert!(ys.len() >= 3, "{out}");
    assert!(ys.windows(2).all(|w| w[1] >= w[0]), "{ys:?}\n{out}");
    assert!((ys[ys.len() - 1] - 2.99998).abs() < 1e-9, "{ys:?}\n{out}");
    assert!(
        !out.contains("L5 take-up") && !out.contains("L6 take-up"),
        "{out}"
    );
    assert!(summary.small_reversals_held >= 1, "{out}");
}
