//! Under G61, where two axes reverse at a corner and each switch moves
//! another axis' correction against its motion, the take-up is one block
//! per reversing axis, in order, each advancing along the next line as
//! far as the steps need (docs/compensation.md, "Several axes reverse at
//! a corner: one take-up block each, in order"), checked end to end
//! against hand values and a dead-band reading sampled inside the blocks.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// Errors (µm) of axis `a` in direction `rev`, the same at every
/// position: X none; Y a 10 µm band and straightness of X that switches
/// (−2 µm forward, +2 µm reverse); Z a 6 µm band and switching
/// straightness of X (∓1.5 µm) and of Y (±1 µm). The kind of
/// bench/coarse_map.py.
fn errors_um(a: usize, rev: bool) -> [f64; 3] {
    let s = if rev { -1.0 } else { 1.0 };
    match a {
        1 => [-2.0 * s, if rev { 10.0 } else { 0.0 }, 0.0],
        2 => [-1.5 * s, s, if rev { 6.0 } else { 0.0 }],
        _ => [0.0; 3],
    }
}

/// The tool's error (mm) in direction state `rev` (per axis).
fn error_mm(rev: [bool; 3]) -> [f64; 3] {
    let mut e = [0.0; 3];
    for (a, r) in rev.iter().enumerate() {
        let c = errors_um(a, *r);
        for k in 0..3 {
            e[k] += c[k] * 1e-3;
        }
    }
    e
}

/// The commands (mm) of the written lines from the one containing
/// `from` on, each word kept from the line before where it is not
/// written.
fn commands_from(out: &str, from: &str) -> Vec<[f64; 3]> {
    let mut q = [f64::NAN; 3];
    let mut all = Vec::new();
    let mut on = false;
    for line in out.lines().filter(|l| !l.starts_with('(')) {
        on |= line.contains(from);
        for w in line.split_whitespace() {
            for (a, c) in ['X', 'Y', 'Z'].iter().enumerate() {
                if let Some(v) = w.strip_prefix(*c) {
                    q[a] = v.parse().unwrap();
                }
            }
        }
        if on && line.contains(['X', 'Y', 'Z']) {
            all.push(q);
        }
    }
    all
}

/// Distance (mm) from `p` to the segment `a`–`b`.
fn to_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let l2: f64 = ab.iter().map(|x| x * x).sum();
    let t = ((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2).clamp(0.0, 1.0);
    (0..3)
        .map(|k| (ap[k] - t * ab[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn under_g61_two_reversals_whose_steps_run_against_the_line_take_up_one_axis_at_a_time() {
    // The corner P1 = (10, 1, 1) between the lines from 0 and to
    // (20, 0, 0): Y and Z reverse, X runs on (u = (10, −1, −1)/√102,
    // u_x = 0.990148). By hand, with J_a the jump of axis a's switch:
    // J_Z = (+3, −2, +6) µm asks X for −3 µm, against its motion, and Y
    // (still forward) for +2; J_Y = (+4, +10, 0) asks X for −4 µm. Z's
    // switch must come first (after Y's, Y reverse could not follow its
    // +2 µm). Each block ends where X's motion along the line has caught
    // its step up: δ1 = 3.01/0.990148 = 3.03995 µm, δ2 = 4.01/0.990148 =
    // 4.04990 µm (one step of five decimals past). Commands = target − e:
    // e(F,F,R) = (−0.5, −1, 6) µm, e(F,R,R) = (3.5, 9, 6) µm:
    // block 1 (10.00351, 1.00070, 0.99370), block 2 (10.00352, 0.99030,
    // 0.99330). Main (6d877ee) writes one block, X10.01660 Y0.98899
    // Z0.99199, in which Z's command travels 8 µm over its 6 µm band: the
    // tool leaves the path by 1.63 µm inside it (bench/eval judge.py's
    // dead band sampled every 0.1 µm), where the judge's 0.05 mm samples
    // see only its end.
    let map: AxisTableMap = common::map_from(|a, _p, rev| errors_um(a, rev));
    let program = "G21 G61\nG0 X-5 Y-5 Z-5\nG1 X0 Y0 Z0 F6000\nG1 X10 Y1 Z1\nG1 X20 Y0 Z0\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let take_ups: Vec<&str> = out
        .lines()
        .filter(|l| l.contains("(volcomp L5 take-up)"))
        .collect();
    assert_eq!(take_ups.len(), 2, "{out}");
    let q = commands_from(&out, "G1 X10.00350");
    let want = [[10.00351, 1.00070, 0.99370], [10.00352, 0.99030, 0.99330]];
    for (k, w) in want.iter().enumerate() {
        for a in 0..3 {
            assert!((q[k + 1][a] - w[a]).abs() < 1.5e-5, "{q:?}\n{out}");
        }
    }
    // The dead band (judge.py's reading, written here apart from the
    // crate's): each switch's jump is a lag that fades as its own axis'
    // command crosses its band. Sampled every 1/1000 of each block, from
    // the command before the corner (all forward) to 0.05 mm along the
    // next line; the G61 bound of 0.5 µm.
    let (p0, p1, p2) = ([0.0, 0.0, 0.0], [10.0, 1.0, 1.0], [20.0, 0.0, 0.0]);
    let mut rev = [false; 3];
    let mut lags: [[f64; 3]; 3] = [[0.0; 3]; 3];
    let mut worst = 0.0_f64;
    let mut last_q = q[0];
    let mut blocks = q[1..].to_vec();
    let u = [
        10.0 / 102f64.sqrt(),
        -1.0 / 102f64.sqrt(),
        -1.0 / 102f64.sqrt(),
    ];
    // The next line's first 0.05 mm: its command solved in (F, R, R).
    let e_new = error_mm([false, true, true]);
    blocks[2] = [0, 1, 2].map(|k| p1[k] + 0.05 * u[k] - e_new[k]);
    for b in blocks.iter().take(3) {
        let dq = [0, 1, 2].map(|k| b[k] - last_q[k]);
        for a in 0..3 {
            if dq[a] != 0.0 && (dq[a] < 0.0) != rev[a] {
                let before = error_mm(rev);
                rev[a] = dq[a] < 0.0;
                let after = error_mm(rev);
                lags[a] = [0, 1, 2].map(|k| before[k] - after[k]);
            }
        }
        for i in 1..=1000 {
            let lambda = i as f64 / 1000.0;
            let e = error_mm(rev);
            let mut tool = [0, 1, 2].map(|k| last_q[k] + dq[k] * lambda + e[k]);
            for a in 0..3 {
                let own = lags[a][a];
                let f = if own == 0.0 || own * dq[a] < 0.0 {
                    0.0
                } else {
                    (1.0 - dq[a].abs() * lambda / own.abs()).max(0.0)
                };
                for k in 0..3 {
                    tool[k] += lags[a][k] * f;
                }
            }
            let d = to_segment(tool, p0, p1).min(to_segment(tool, p1, p2));
            worst = worst.max(d);
        }
        for a in 0..3 {
            let own = lags[a][a];
            let f = if own == 0.0 || own * dq[a] < 0.0 {
                0.0
            } else {
                (1.0 - dq[a].abs() / own.abs()).max(0.0)
            };
            lags[a] = lags[a].map(|x| x * f);
        }
        last_q = *b;
    }
    assert!(worst * 1e3 <= 0.5, "{} µm\n{out}", worst * 1e3);
}
