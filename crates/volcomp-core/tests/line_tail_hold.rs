//! Under G61, a reversal on the held tail of a line (its last piece,
//! compensate/mod.rs `flush_tail`) is held to the line's end where the rest
//! is shorter than its take-up's smooth ramp, and taken up at the corner
//! after it, where G61 stops anyway (compensate/points.rs `tail_run`,
//! `hold_to_line_end`): no take-up block, and so no stop, inside a line.
//! Checked end to end on bench/cycle_time's zigzag_40x30 with the example
//! map (the cycle-time bench's map and work offset).

use volcomp_core::example::example_map;

use crate::common;

/// bench/cycle_time/programs/zigzag_40x30.ngc under G61 at F6000, in
/// machine coordinates (the bench's G54 is 250, 200, 150 mm): X passes of
/// 40 mm joined by 2 mm stepovers in Y.
fn zigzag() -> String {
    let mut p = String::from("G21 G17 G90 G94 G61\nG0 Z155\nG0 X250 Y200\nG1 Z149 F6000\n");
    for k in 0..15 {
        let x = if k % 2 == 0 { 290 } else { 250 };
        p.push_str(&format!("G1 X{x}\nG1 Y{}\n", 202 + 2 * k));
    }
    p.push_str("G1 X250\nG0 Z155\nM2\n");
    p
}

#[test]
fn under_g61_a_reversal_on_a_lines_tail_is_held_to_the_corner_not_stopped_on() {
    let program = zigzag();
    let map = example_map();
    let (out, _, _) = common::compensate_recorded(&program, &map);
    // Every take-up block is written at a corner of the original (X 250 or
    // 290, Y a stepover's end; the plunge at Z 149 or above it), where G61
    // stops anyway: within 10 µm of one (the compensation is a few µm).
    // On main ba3c40c seven stepovers (Y 202, 210, 214, …) had a take-up
    // block of X and Z 0.372 mm before their end, at Y 201.628 etc.
    let word = |l: &str, a: char| -> Option<f64> {
        let i = l.find(a)?;
        let v: String = l[i + 1..]
            .chars()
            .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-')
            .collect();
        v.parse().ok()
    };
    let (mut x, mut y) = (0.0, 0.0);
    let mut take_ups = 0;
    for l in out.lines().filter(|l| !l.starts_with('(')) {
        x = word(l, 'X').unwrap_or(x);
        y = word(l, 'Y').unwrap_or(y);
        if l.contains("take-up") {
            take_ups += 1;
            let near = |v: f64, w: f64| (v - w).abs() < 0.01;
            let at_corner = (near(x, 250.0) || near(x, 290.0))
                && (200..=230).step_by(2).any(|c| near(y, c as f64));
            assert!(at_corner, "take-up at X{x} Y{y} inside a line: {l}\n{out}");
        }
    }
    assert!(take_ups > 0, "{out}");
    // The time: the planner model (LinuxCNC 2.9's planner to the ms)
    // gives main's output +3.2 % cutting time; issue 24's G61 goal is
    // +1 %, and the lines' own take-ups at corners cost a few ms each
    // (9.883 s against 9.781 s on LinuxCNC 2.9, +1.04 %). A line's tail
    // merged with the line's last piece before the corner (the fold over
    // the longer piece) gave +1.38 %: the bound keeps it out.
    let ratio = common::cutting_s(&out) / common::cutting_s(&program);
    assert!(ratio < 1.012, "{ratio}\n{out}");
    // The hold leaves the tool within G61's 0.5 µm (issue 24) everywhere.
    let report = common::simulated(&out, &program, &map);
    assert!(report.contour_max_um <= 0.5, "{report:?}");
    eprintln!("ratio {ratio} take-ups {take_ups} report {report:?}");
}
