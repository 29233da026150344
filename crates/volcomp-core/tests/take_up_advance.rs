//! Under G61, a take-up block whose switches move an axis' correction
//! against that axis' new motion ends along the line after the corner
//! (docs/compensation.md, "A correction that jumps against an axis'
//! motion: the take-up ends along the line"), checked end to end
//! (compensate, then the dead-band simulation) against hand values; where
//! several axes reverse, the order of their blocks does it instead.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X has a 10 µm band and its straightness of Z switches with its
/// direction (+1.5 µm forward, −1.5 µm reverse); Z has a 6 µm band and its
/// straightness of X switches the other way (−1.5 µm forward, +1.5 µm
/// reverse). Y has no errors. The switching straightness is the kind of
/// bench/coarse_map.py.
fn switching_map() -> AxisTableMap {
    common::map_from(|a, _p, rev| {
        let s = if rev { -1.0 } else { 1.0 };
        match a {
            0 => [if rev { 10.0 } else { 0.0 }, 0.0, 1.5 * s],
            2 => [-1.5 * s, 0.0, if rev { 6.0 } else { 0.0 }],
            _ => [0.0; 3],
        }
    })
}

/// The X, Y and Z words of the written line whose comment is `comment`.
fn words_of(out: &str, comment: &str) -> [f64; 3] {
    let line = out
        .lines()
        .find(|l| l.contains(comment))
        .unwrap_or_else(|| panic!("no {comment}: {out}"));
    let mut q = [f64::NAN; 3];
    for w in line.split_whitespace() {
        for (a, c) in ['X', 'Y', 'Z'].iter().enumerate() {
            if let Some(v) = w.strip_prefix(*c) {
                q[a] = v.parse().unwrap();
            }
        }
    }
    q
}

#[test]
fn under_g61_a_step_against_an_axis_motion_is_taken_up_in_the_order_that_keeps_the_path() {
    // By hand. Before the corner X 10 Y 10 (after the plunge Z is on its
    // reverse flank, X forward): X's command is 10 − 1.5 µm (Z's reverse
    // straightness of X), Z's 0 − (1.5 + 6) µm. The line to X 0 Y 20 turns
    // X back (band 10 µm); X's switch moves the tool −3 µm in Z, so Z must
    // rise 3 µm, against its flank: Z reverses too (band 6 µm). Z's switch
    // moves the tool −3 µm in X. Taken up in one block, X turns back by only
    // 7 µm of its 10 µm band and the tool sits 3 µm off the corner in X
    // (main 8453e54 wrote X9.99150 Z0.00150 so, 3·sin 45° = 2.1 µm across the
    // next line). One block per reversing axis, Z first, keeps every step
    // along its axis' motion: Z's switch (Z −0.0075 → −0.0015, its 6 µm band)
    // asks X for +3 µm, which X, still running forward, follows (X 9.9985 →
    // 10.0015); then X's switch (10.0015 → 9.9915, its 10 µm band) asks Z for
    // +3 µm more, which Z, now running up, follows (Z −0.0015 → 0.0015). The
    // ends are the one block's, reached in an order the dead band follows
    // (compensate/take_up_order.rs; the advance along the line of
    // compensate/take_up_advance.rs is not needed here).
    let map = switching_map();
    let program = "G21 G61\nG0 X0 Y0 Z1\nG1 Z0 F6000\nG1 X10 Y10\nG1 X0 Y20\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let blocks: Vec<[f64; 3]> = out
        .lines()
        .filter(|l| l.contains("(volcomp L5 take-up)"))
        .map(|l| words_of(l, "(volcomp L5 take-up)"))
        .collect();
    assert_eq!(blocks.len(), 2, "{out}");
    let want = [[10.0015, f64::NAN, -0.0015], [9.9915, f64::NAN, 0.0015]];
    for (q, w) in blocks.iter().zip(&want) {
        for a in [0, 2] {
            assert!((q[a] - w[a]).abs() < 1.5e-5, "{q:?} vs {w:?}\n{out}");
        }
    }
    // Through the dead band the tool stays on the path: the G61
    // bound of 0.5 µm (main 8453e54: 2.1 µm at the corner).
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.5, "{report:?}\n{out}");
}

/// X has a 10 µm band and its straightness of Y switches with its
/// direction (−1.5 µm forward, +1.5 µm reverse); Y has an 8 µm band and no
/// straightness; Z has no errors.
fn one_reversal_map() -> AxisTableMap {
    common::map_from(|a, _p, rev| match a {
        0 => [
            if rev { 10.0 } else { 0.0 },
            if rev { 1.5 } else { -1.5 },
            0.0,
        ],
        1 => [0.0, if rev { 8.0 } else { 0.0 }, 0.0],
        _ => [0.0; 3],
    })
}

#[test]
fn under_g61_one_reversal_whose_switch_steps_a_moving_axis_back_ends_along_the_next_line() {
    // By hand. Only X reverses at X 10 Y 10 (Y runs on forward), so no
    // order of blocks helps. Before the corner Y's command is 10 + 1.5 µm
    // (X's forward straightness of Y is −1.5 µm); X's switch makes the new
    // command 10 − 1.5 µm: a 3 µm step back against Y's motion, which Y
    // could follow only by reversing across its 8 µm band. A block of X
    // alone leaves the tool 3 µm off in Y, 3·sin 45° = 2.12 µm across the
    // next line, and the line's end takes all of its 14.14 mm to bring it
    // back. Y moves along the line at cos 45°, so it catches the step up
    // after (3 + 0.01)/0.7071 = 4.257 µm of path: the take-up ends at
    // X 10 − 0.00301, Y 10 + 0.00301, commanded X 9.99699 − 0.010 =
    // 9.98699, Y 10.00301 − 0.0015 = 10.00151.
    let map = one_reversal_map();
    let program = "G21 G61\nG0 X0 Y0 Z1\nG1 Z0 F6000\nG1 X10 Y10\nG1 X0 Y20\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let q = words_of(&out, "(volcomp L5 take-up)");
    let want = [9.98699, 10.00151];
    for a in 0..2 {
        assert!((q[a] - want[a]).abs() < 1.5e-5, "{q:?} vs {want:?}\n{out}");
    }
    // X stands while it crosses its band, so on the way the tool leaves
    // the path by about as much (2.13 µm), but over 4 µm of path instead
    // of the whole line: the contour RMS falls from 0.85 µm (the block of
    // X alone, this map and program) to a small fraction of it.
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_rms_um < 0.1, "{report:?}\n{out}");
    assert!(report.contour_max_um < 2.2, "{report:?}\n{out}");
}
