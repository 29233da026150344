//! Canned cycles kept as cycles, checked on what LinuxCNC's own
//! interpreter makes of the written program: `volcomp compensate` writes
//! the program, `rs274` (LinuxCNC 2.9) turns it into canonical moves, and
//! every hole bottom, R level and peck depth the controller commands is
//! run through the map — evaluated here, independently, from the table
//! this test writes — in the direction the machine moves there. The result
//! must be the nominal point within the print rounding of rs274 (four
//! decimals) and the solver's residual.
//!
//! The map (axis tables, linear between points every 5 mm):
//! * X: `ex = 2 + 0.01·x` µm moving +X, 3 µm more moving −X (backlash);
//!   `ey = 0.5` µm;
//! * Y: `ey = −1 + 0.02·y` µm moving +Y, 2 µm less moving −Y;
//! * Z: `ez = 1 + 0.05·z` µm moving +Z, 4 µm less moving −Z; and a
//!   straightness `ex = 0.1·(−10 − z)` µm below z = −10 mm (0 above), so
//!   a hole that reaches below −10 mm drifts across its stroke by
//!   `0.1 µm/mm · (−10 − Z)`: closed form of the first-order rule of
//!   docs/compensation.md, "Canned cycles".
//!
//! Without rs274 the test is skipped loudly, except when `CI` is set.

use std::path::{Path, PathBuf};

use crate::common;
use crate::rs274;
use common::write;

use rs274::{find_rs274, run_rs274, Kind, RefMotion, Tools};

/// What axis `a`'s table carries at position `p` (mm), moving + (`fwd`)
/// or −: the terms of the map above (µm).
fn table_part(a: usize, p: f64, fwd: bool) -> [f64; 3] {
    match a {
        0 => [2.0 + 0.01 * p + if fwd { 0.0 } else { 3.0 }, 0.5, 0.0],
        1 => [0.0, -1.0 + 0.02 * p - if fwd { 0.0 } else { 2.0 }, 0.0],
        _ => [
            if p < -10.0 { 0.1 * (-10.0 - p) } else { 0.0 },
            0.0,
            1.0 + 0.05 * p - if fwd { 0.0 } else { 4.0 },
        ],
    }
}

/// The deviation of the map (µm) at `q` (mm), moving + (`fwd`) or − per
/// axis: the sum of the three tables.
fn e_um(q: [f64; 3], fwd: [bool; 3]) -> [f64; 3] {
    let mut e = [0.0; 3];
    for a in 0..3 {
        let t = table_part(a, q[a], fwd[a]);
        for i in 0..3 {
            e[i] += t[i];
        }
    }
    e
}

/// The map as an axis-table CSV (every 5 mm; linear in between, so the
/// table is the formula exactly).
fn map_csv() -> String {
    let mut s = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, name) in ["X", "Y", "Z"].into_iter().enumerate() {
        for fwd in [true, false] {
            for k in -40..=80 {
                let p = 5.0 * k as f64;
                let v = table_part(a, p, fwd);
                let dir = if fwd { "forward" } else { "reverse" };
                s.push_str(&format!("{name},{dir},{p},{},{},{}\n", v[0], v[1], v[2]));
            }
        }
    }
    s
}

/// Print rounding of rs274 (four decimals of a mm, with margin) plus the
/// solver's residual and volcomp's own rounding (five decimals): µm. In
/// inch rs274 prints four decimals of an inch, and the check is that fine.
const TOL_UM: f64 = 0.07;

const PROGRAM: &str = "(canned cycles kept as cycles)
G21 G90 G17 G54 F200
G0 X0 Y0 Z10
G98 G81 X10 Y20 Z-5 R2
X30 Y35
G83 X20 Y50 Z-8 R2 Q3
G73 X40 Y40 Z-9 R1 Q2.5
G99 G81 X50 Y10 Z-20 R2
X70 Y30 Z-4 R1
G98 X60 Y50 Z-5 R2
G80
G0 X0 Y60 Z10
G91 G99 G81 X15 Y-10 Z-4 R-8 L3
G90 G80
G0 Z10
M2
";

/// The Z reversal value of the map (µm).
const Z_REVERSAL_UM: f64 = 4.0;

/// A nominal hole: in-plane point, R, the feed end levels (pecks, then
/// the bottom), and whether the machine reaches R only from the R it
/// retracted to (moving up, G99): the feed down then starts with the Z
/// reversal in the air, and R cannot be met in the state of a downward
/// arrival — it is left at or above the plane, by at most the reversal.
struct Hole {
    xy: [f64; 2],
    r: f64,
    levels: Vec<f64>,
    r_from_retract: bool,
}

fn holes() -> Vec<Hole> {
    let h = |x: f64, y: f64, r: f64, levels: &[f64], r_from_retract: bool| Hole {
        xy: [x, y],
        r,
        levels: levels.to_vec(),
        r_from_retract,
    };
    vec![
        h(10.0, 20.0, 2.0, &[-5.0], false),
        h(30.0, 35.0, 2.0, &[-5.0], false),
        h(20.0, 50.0, 2.0, &[-1.0, -4.0, -7.0, -8.0], false),
        h(40.0, 40.0, 1.0, &[-1.5, -4.0, -6.5, -9.0], false),
        h(50.0, 10.0, 2.0, &[-20.0], false),
        h(70.0, 30.0, 1.0, &[-4.0], false),
        h(60.0, 50.0, 2.0, &[-5.0], false),
        h(15.0, 50.0, 2.0, &[-2.0], false),
        h(30.0, 40.0, 2.0, &[-2.0], true),
        h(45.0, 30.0, 2.0, &[-2.0], true),
    ]
}

/// The controller's moves with the direction state each ends in (true:
/// the axis last moved +), from rs274's canonical moves; the machine
/// starts at 0, 0, 0 with every axis forward.
fn with_states(moves: &[RefMotion]) -> Vec<(RefMotion, [bool; 3])> {
    let mut at = [0.0; 3];
    let mut fwd = [true; 3];
    moves
        .iter()
        .map(|m| {
            for a in 0..3 {
                let d = m.end[a] - at[a];
                if d.abs() > 1e-9 {
                    fwd[a] = d > 0.0;
                }
            }
            at = m.end;
            (m.clone(), fwd)
        })
        .collect()
}

/// The tool's actual position for command `q` (mm) in state `fwd`.
fn actual(q: [f64; 3], fwd: [bool; 3]) -> [f64; 3] {
    let e = e_um(q, fwd);
    [0, 1, 2].map(|a| q[a] + e[a] * 1e-3)
}

struct Run {
    dir: common::TempDir,
    tools: Tools,
}

fn set_up(name: &str) -> Option<Run> {
    let Some(rs274) = find_rs274() else {
        common::missing(common::RS274, "the kept cycles against rs274");
        return None;
    };
    let dir = common::tempdir(name);
    write(&dir, "map.csv", map_csv());
    write(
        &dir,
        "setup.toml",
        "units = \"mm\"\nstart = [0, 0, 0]\n[work_offsets]\nG54 = [0, 0, 0]\n",
    );
    write(&dir, "tools.tbl", "T1 P1 Z0 D0\n");
    let tools = Tools {
        rs274,
        volcomp: PathBuf::from(env!("CARGO_BIN_EXE_volcomp")),
        dir: dir.to_path_buf(),
        setup: dir.join("setup.toml"),
        tool_table: dir.join("tools.tbl"),
        var_text: "5220 1\n".into(),
    };
    Some(Run { dir, tools })
}

/// Compensates `program` (written as `name.ngc`) with `extra` options and
/// runs the output through rs274: the output text and the controller's
/// moves.
fn compensate_and_run(
    run: &Run,
    name: &str,
    program: &str,
    extra: &[&str],
) -> (String, Vec<RefMotion>) {
    let input = run.dir.join(format!("{name}.ngc"));
    std::fs::write(&input, program).unwrap();
    let out_name = format!("{name}.out.ngc");
    let mut args = vec![
        "compensate",
        input.to_str().unwrap(),
        "--map",
        "map.csv",
        "--setup",
        "setup.toml",
        "-o",
        &out_name,
    ];
    args.extend_from_slice(extra);
    let o = common::volcomp(&args, &run.dir);
    common::ok(&o);
    let out_path = run.dir.join(&out_name);
    let text = std::fs::read_to_string(&out_path).unwrap();
    // rs274 accepts both the written program and its input.
    let accepted = |program: &Path, work: String| {
        let r = run_rs274(&run.tools, program, &run.dir.join(work)).unwrap();
        assert!(r.rejected.is_none(), "{:?}\n{text}", r.rejected);
        r.motions
    };
    let ours = accepted(&out_path, format!("{name}-rs274"));
    accepted(&input, format!("{name}-rs274-in"));
    (text, ours)
}

fn near(a: f64, b: f64, tol_um: f64) -> bool {
    (a - b).abs() <= tol_um * 1e-3
}

/// Checks every nominal hole's feed ends and R level on the controller's
/// moves, the cycle plane's axes being `ax` (first, second, normal: XY is
/// `[0, 1, 2]`); returns, per hole, the index of its first feed move.
fn check_holes(
    moves: &[(RefMotion, [bool; 3])],
    holes: &[Hole],
    ax: [usize; 3],
    text: &str,
) -> Vec<usize> {
    let n = ax[2];
    let mut firsts = Vec::new();
    for (k, hole) in holes.iter().enumerate() {
        // The controller's feed moves at this hole (within 50 µm).
        let at_hole: Vec<usize> = (0..moves.len())
            .filter(|&i| {
                let (m, _) = &moves[i];
                m.kind == Kind::Feed
                    && (m.end[ax[0]] - hole.xy[0]).abs() < 0.05
                    && (m.end[ax[1]] - hole.xy[1]).abs() < 0.05
            })
            .collect();
        assert!(!at_hole.is_empty(), "hole {k}: no feed move\n{text}");
        for level in &hole.levels {
            // The feed that ends nearest the nominal level is the one
            // aimed at it.
            let i = *at_hole
                .iter()
                .min_by(|a, b| {
                    let d = |i: usize| (moves[i].0.end[n] - level).abs();
                    d(**a).total_cmp(&d(**b))
                })
                .unwrap();
            let (m, fwd) = &moves[i];
            assert!(!fwd[n], "hole {k}: the feed to {level} does not move down");
            let p = actual(m.end, *fwd);
            let mut t = [0.0; 3];
            (t[ax[0]], t[ax[1]], t[n]) = (hole.xy[0], hole.xy[1], *level);
            for a in 0..3 {
                // rs274 prints four decimals of the program's unit: in inch
                // that is 2.54 µm, so the check is as fine as the print.
                assert!(
                    near(p[a], t[a], TOL_UM.max(m.tol[a] * 1e3 + 0.01)),
                    "hole {k} level {level}: axis {a} actual {:.6} vs nominal {:.6} (command {:?})\n{text}",
                    p[a],
                    t[a],
                    m.end
                );
            }
        }
        // R: where the first feed of the hole starts.
        let first = at_hole[0];
        let (start, fwd) = &moves[first - 1];
        let p = actual(start.end, *fwd);
        let tol_um = TOL_UM.max(start.tol[n] * 1e3 + 0.01);
        let ok = if hole.r_from_retract {
            p[n] >= hole.r - tol_um * 1e-3 && p[n] <= hole.r + (Z_REVERSAL_UM + tol_um) * 1e-3
        } else {
            near(p[n], hole.r, tol_um)
        };
        assert!(
            ok,
            "hole {k}: R actual {:.6} vs nominal {} (command {:?}, {fwd:?})\n{text}",
            p[n], hole.r, start.end
        );
        firsts.push(first);
    }
    firsts
}

#[test]
fn holes_kept_as_cycles_land_on_the_map_at_bottom_r_and_pecks() {
    let Some(run) = set_up("kept") else { return };
    // The drilling holes held to the contour tolerance (0.1 µm), as the
    // boring cycles are: the deep hole's 1 µm drift then expands it.
    let (text, moves) =
        compensate_and_run(&run, "holes", PROGRAM, &["--drill-tolerance-um", "0.1"]);
    let moves = with_states(&moves);
    let holes = holes();
    let firsts = check_holes(&moves, &holes, [0, 1, 2], &text);
    let body: Vec<&str> = text.lines().filter(|l| !l.starts_with('(')).collect();
    // Written as moves: the deep hole (line 8), whose stroke the map bends
    // by the closed form 0.1 µm/mm · (−10 − (−20)) = 1 µm, and the G98
    // hole of line 10, which as a cycle would move up from where the
    // written run restarted after line 8 (its R) instead of traversing at
    // the initial level.
    let expanded: Vec<&&str> = body
        .iter()
        .filter(|l| l.contains("cycle expanded"))
        .collect();
    assert_eq!(expanded.len(), 2, "{text}");
    assert!(expanded[0].contains("(volcomp L8 cycle expanded"), "{text}");
    assert!(
        expanded[1].contains("(volcomp L10 cycle expanded: written as a cycle"),
        "{text}"
    );
    let drift: f64 = expanded[0]
        .split("moves the tool ")
        .nth(1)
        .and_then(|s| s.split(" um").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{}", expanded[0]));
    assert!((drift - 1.0).abs() < 0.005, "{drift}");
    // Every other hole is one cycle block, the L3 repeats three.
    let cycles = |l: &&&str| ["G81", "G83", "G73"].iter().any(|c| l.contains(c));
    assert_eq!(body.iter().filter(cycles).count(), 8, "{text}");
    assert_eq!(text.matches("(volcomp L13 cycle)").count(), 2, "{text}");
    // (The first rapid's approach line is tagged with its own line number.)
    assert!(
        !body
            .iter()
            .any(|l| l.contains("L3") && !l.contains("approach")),
        "{text}"
    );
    // The hole after the expanded one states its cycle and R again.
    let after = body
        .iter()
        .find(|l| l.contains("G81 X69.9") || l.contains("G81 X70"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(after.contains('R') && after.contains('Z'), "{after}");
    // G98: the first hole returns to the level the machine really stood
    // at before the cycle (the compensated Z10), which the map puts at
    // 10 mm; G99: the fourth returns to its own R.
    // (The last such level before the first hole: the first rapid's
    // approach comes before it.)
    let initial = moves[..firsts[0]]
        .iter()
        .rev()
        .find(|(m, _)| m.end[2] > 9.0)
        .map(|(m, _)| m.end[2])
        .unwrap();
    let (ret, fwd) = &moves[firsts[0] + 1];
    assert!(
        (ret.end[2] - initial).abs() < 1e-9,
        "{:?} vs {initial}",
        ret.end
    );
    assert!(
        near(actual(ret.end, *fwd)[2], 10.0, TOL_UM),
        "{:?}",
        ret.end
    );
    let r6 = moves[firsts[5] - 1].0.end[2];
    let (ret, _) = &moves[firsts[5] + 1];
    assert_eq!(ret.kind, Kind::Rapid);
    assert!((ret.end[2] - r6).abs() < 1e-9, "{:?} vs {r6}", ret.end);
}

#[test]
fn cycles_in_the_xz_and_yz_planes_and_in_inch_are_kept_and_land() {
    // G18: the plane is Z, X and the hole axis Y; G19: Y, Z and the hole
    // axis X. In inch (G20) every number is inches; the test's nominal
    // points are in mm. The map's Y and X tables carry no straightness, so
    // every stroke stays straight and every hole is kept.
    let Some(run) = set_up("planes") else { return };
    let program = "G20 G90 G54 F10
G0 X0 Y0.4 Z0
G18 G98 G81 Z0.8 X1 Y-0.2 R0.08
Z1.2 X1.4
G83 Z0.4 X0.6 Y-0.3 R0.1 Q0.15
G80
G0 Y0 X0.5 Z0
G19 G99 G81 Y1 Z0.6 X-0.2 R0.3
G91 Y0.4 Z0.2 X-0.5 R-0.2 L2
G90 G80 G17
M2
";
    let (text, moves) = compensate_and_run(&run, "planes", program, &[]);
    let moves = with_states(&moves);
    let inch = 25.4;
    let h = |a: f64, b: f64, r: f64, levels: &[f64], r_from_retract| Hole {
        xy: [a * inch, b * inch],
        r: r * inch,
        levels: levels.iter().map(|l| l * inch).collect(),
        r_from_retract,
    };
    // G18: (Z, X) in the plane.
    let xz = [
        h(0.8, 1.0, 0.08, &[-0.2], false),
        h(1.2, 1.4, 0.08, &[-0.2], false),
        h(0.4, 0.6, 0.1, &[-0.05, -0.2, -0.3], false),
    ];
    check_holes(&moves, &xz, [2, 0, 1], &text);
    // G19: (Y, Z) in the plane; in G91 the initial level is X0.5 (where
    // the run began), R = 0.5 − 0.2 and the bottom 0.3 − 0.5.
    let yz = [
        h(1.0, 0.6, 0.3, &[-0.2], false),
        h(1.4, 0.8, 0.3, &[-0.2], true),
        h(1.8, 1.0, 0.3, &[-0.2], true),
    ];
    check_holes(&moves, &yz, [1, 2, 0], &text);
    assert!(!text.contains("cycle expanded"), "{text}");
    assert_eq!(text.matches("(volcomp L9 cycle)").count(), 1, "{text}");
}

#[test]
fn a_drilled_hole_is_kept_within_the_drill_tolerance_a_bored_one_within_the_contour_tolerance() {
    let Some(run) = set_up("drill") else { return };
    // The deep hole of PROGRAM (the map bends its stroke by the closed form
    // 0.1 µm/mm · 10 mm = 1 µm) drilled with G81 and bored with G85, each
    // alone, with the defaults: 1 µm is inside the drill tolerance (5 µm)
    // and outside the contour tolerance (0.1 µm).
    let program = |g: &str| {
        format!("G21 G90 G17 G54 F200\nG0 X0 Y0 Z10\nG99 {g} X50 Y10 Z-20 R2\nG80\nG0 Z10\nM2\n")
    };
    let (drilled, moves) = compensate_and_run(&run, "drilled", &program("G81"), &[]);
    assert!(!drilled.contains("cycle expanded"), "{drilled}");
    assert_eq!(
        drilled
            .lines()
            .filter(|l| !l.starts_with('(') && l.contains("G81"))
            .count(),
        1,
        "{drilled}"
    );
    // Its bottom still lands on the nominal point (the stroke's drift is
    // above it, in the hole).
    let moves = with_states(&moves);
    let bottom = moves
        .iter()
        .filter(|(m, _)| m.kind == Kind::Feed)
        .min_by(|a, b| a.0.end[2].total_cmp(&b.0.end[2]))
        .unwrap();
    let p = actual(bottom.0.end, bottom.1);
    for (a, t) in [50.0, 10.0, -20.0].iter().enumerate() {
        assert!(
            near(p[a], *t, TOL_UM.max(bottom.0.tol[a] * 1e3 + 0.01)),
            "axis {a}: {} vs {t}\n{drilled}",
            p[a]
        );
    }
    let (bored, _) = compensate_and_run(&run, "bored", &program("G85"), &[]);
    let expanded: Vec<&str> = bored
        .lines()
        .filter(|l| l.contains("cycle expanded"))
        .collect();
    assert_eq!(expanded.len(), 1, "{bored}");
    assert!(
        expanded[0].contains("above the 0.100 um tolerance"),
        "{bored}"
    );
}
