//! Under G61, a reversal smaller than its axis' band held where its take-up
//! would be a stop on a path that runs on (docs/compensation.md, "Small
//! reversals held where G61 would stop"), checked against hand values.

use volcomp_core::compensate::PointRecord;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X's table moves the tool in Z by `−z_um(x)` (both directions), so Z's
/// command, with Z standing still in the program, is `z_um(x)`; Z has a
/// 2 µm band (its reverse table). Table points every 0.25 mm.
fn map_with_z_command(z_um: impl Fn(f64) -> f64) -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for dir in ["forward", "reverse"] {
        for k in 0..=400 {
            let p = -50.0 + 0.25 * k as f64;
            csv.push_str(&format!("X,{dir},{p},0,0,{}\n", -z_um(p)));
        }
        for (name, ez) in [("Y", 0.0), ("Z", if dir == "reverse" { 2.0 } else { 0.0 })] {
            for p in [-100.0, 100.0] {
                csv.push_str(&format!("{name},{dir},{p},0,0,{ez}\n"));
            }
        }
    }
    AxisTableMap::from_csv(&csv, "test.csv").unwrap()
}

/// Z's command rises 0.1 µm per mm of X, dips by 0.2 µm between X 10 and
/// X 10.5 and rises again at 0.4 µm per mm back to the line (1 µm at
/// X 11).
fn dip_um(x: f64) -> f64 {
    if x <= 10.0 {
        0.1 * x
    } else if x <= 10.5 {
        1.0 - 0.4 * (x - 10.0)
    } else if x <= 11.0 {
        0.8 + 0.4 * (x - 10.5)
    } else {
        1.0 + 0.1 * (x - 11.0)
    }
}

fn run(program: &str, map: &AxisTableMap) -> (String, Vec<PointRecord>, u64) {
    let (out, records, summary) = common::compensate_recorded(program, map);
    (out, records, summary.small_reversals_held)
}

#[test]
fn under_g61_a_dip_smaller_than_the_band_is_held_instead_of_a_take_up_block() {
    // At F6000 a smooth ramp of Z's 2 µm band needs L = √(6·2 µm·ℓ/(0.6·κ))
    // with ℓ = 2·v·T = 0.2 mm and κ = 0.1·A/(v/T + A) = 0.99 mrad (tp.c
    // `tpSetupTangent`): 2.0 mm by hand, and the line ends 1.6 mm after Z
    // turns down at X 10, so no ramp fits: the take-up would be a block, a
    // stop under G61 (and another where Z turns up again at X 10.5). The
    // dip (0.2 µm) is below the bound (0.4 µm less G61's 0.05 µm contour
    // tolerance), and Z's target is back where it turned at X 11, inside
    // the line: held, Z's command never goes down, no take-up is written,
    // and the tool is off by the dip, 0.2 µm, at X 10.5.
    let map = map_with_z_command(dip_um);
    let program = "G61\nG0 X0 Y0 Z0\nG1 X11.6 F6000\nM2\n";
    let (out, records, held) = run(program, &map);
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 3).collect();
    assert!(held > 0, "{out}");
    assert!(line.iter().all(|r| !r.take_up), "{out}");
    for w in line.windows(2) {
        assert!(
            w[1].command_mm.z >= w[0].command_mm.z - 1e-9,
            "Z turns down at X {}: {out}",
            w[1].target_mm.x
        );
    }
    // Held at 1 µm (where it turned, X 10) through the dip, to X 11 where
    // the target is back there.
    let dip: Vec<&&PointRecord> = line
        .iter()
        .filter(|r| (10.0..=11.0).contains(&r.target_mm.x))
        .collect();
    assert!(dip.len() >= 2, "{out}");
    for r in dip {
        assert!((r.command_mm.z * 1e3 - 1.0).abs() < 0.011, "{r:?}: {out}");
    }
    let report = common::simulated(&out, program, &map);
    assert!(
        (report.contour_max_um - 0.2).abs() < 0.02,
        "{report:?}: {out}"
    );
}

#[test]
fn under_g61_a_dip_the_move_ends_in_is_taken_up_not_held() {
    // The same dip with the line ending at X 10.8, before Z's target comes
    // back (at X 11): a hold would carry the reversal into whatever follows
    // (here the program's end), so Z is taken up where it turns down (X 10)
    // and again where it turns up (X 10.5), as without the rule. (On an arc
    // the hold may end with the move where the rest of it is shorter than
    // the ramp: the next test; not on a line, where it cost accuracy.)
    let map = map_with_z_command(dip_um);
    let program = "G61\nG0 X0 Y0 Z0\nG1 X10.8 F6000\nM2\n";
    let (out, records, held) = run(program, &map);
    assert_eq!(held, 0, "{out}");
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 3).collect();
    assert_eq!(line.iter().filter(|r| r.take_up).count(), 2, "{out}");
    // Z's command at the end: the target (0.92 µm), Z forward again.
    let last = line.last().unwrap();
    assert!(
        (last.command_mm.z * 1e3 - dip_um(10.8)).abs() < 0.011,
        "{last:?}: {out}"
    );
}

/// Z's command rises 0.1 µm per mm of X, dips by 0.2 µm between X 9.25
/// and X 9.75 and rises again at 0.4 µm per mm, back where it turned
/// (0.925 µm) at X 10.25 (table points every 0.25 mm: the breaks lie on
/// them).
fn dip_at_join_um(x: f64) -> f64 {
    if x <= 9.25 {
        0.1 * x
    } else if x <= 9.75 {
        0.925 - 0.4 * (x - 9.25)
    } else if x <= 10.25 {
        0.725 + 0.4 * (x - 9.75)
    } else {
        0.925 + 0.1 * (x - 10.25)
    }
}

#[test]
fn under_g61_a_dip_across_a_tangent_join_is_held_across_it() {
    // A G2 R100 arc from X 0 to X 10 and the line that leaves it along its
    // end tangent: the centre is at (5, −√(100² − 5²)), so the end tangent
    // is (√(100² − 5²), −5)/100 = (0.99875, −0.05) and the line to
    // (14.99375, −0.25) follows it (a join the planner takes as tangent).
    // Z turns down at X 9.25, 0.75 mm before the arc's end: less than the
    // 1.4 mm a smooth ramp of Z's 2 µm band needs on an arc at F6000
    // (L = √(6·2 µm·ℓ/(0.6·κ)), ℓ = 0.2 mm, κ = 0.2·A/(v/T + A) =
    // 1.98 mrad, tp.c `tpSetupTangent`), so no ramp fits in the arc, and
    // main b110b8c writes two take-up blocks (X 9.25, X 9.75), stops of the
    // planner under G61: +35.8 % cutting time (release build, planner
    // model). The hold instead ends with the arc, and the line, where Z's
    // target is back at X 10.25, holds it to there: no take-up, Z's
    // command never goes down, the tool off by the dip, 0.2 µm, at X 9.75.
    let map = map_with_z_command(dip_at_join_um);
    let program = "G61\nG0 X-5 Y0 Z0\nG1 X0 F6000\nG2 X10 Y0 R100\nG1 X14.99375 Y-0.25\nM2\n";
    let (out, records, held) = run(program, &map);
    assert!(held > 0, "{out}");
    let path: Vec<&PointRecord> = records.iter().filter(|r| r.line >= 4).collect();
    assert!(path.iter().all(|r| !r.take_up), "{out}");
    for w in path.windows(2) {
        assert!(
            w[1].command_mm.z >= w[0].command_mm.z - 1e-9,
            "Z turns down at X {}: {out}",
            w[1].target_mm.x
        );
    }
    let report = common::simulated(&out, program, &map);
    assert!(
        (report.contour_max_um - 0.2).abs() < 0.02,
        "{report:?}: {out}"
    );
    // No stop added: the planner model (LinuxCNC 2.9's planner) runs the
    // output as fast as the original, within 1 %.
    let (c0, c1) = (common::cutting_s(program), common::cutting_s(&out));
    assert!(c1 <= c0 * 1.01, "{c0} s → {c1} s: {out}");
}
