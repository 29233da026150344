//! Under G64 P, a small reversal inside a line taken up where its take-up
//! keeps the path tangent, not held to the line's end
//! (docs/compensation.md, "Small reversals held"; compensate/turn_back.rs
//! `holds_at`), checked against hand values.

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

/// Z's command rises 0.3 µm per mm of X to X 20 and falls as fast after.
fn peak_um(x: f64) -> f64 {
    if x <= 20.0 {
        0.3 * x
    } else {
        6.0 - 0.3 * (x - 20.0)
    }
}

#[test]
fn under_g64_p_a_reversal_inside_a_line_is_taken_up_not_held_to_its_end() {
    // Z turns down at X 20, inside the line. Held (solve.rs
    // `hold_small_reversals`, within P0.005 less the 0.1 µm contour
    // tolerance, 4.9 µm), Z's command would stay at 6 µm while its target
    // falls 0.3 µm/mm: the tool off by 0.3·(x − 20) µm, 4.9 µm by X 36.3
    // (by hand), where main 81922d1 still held it. Taken up instead on a
    // ramp (points.rs `plan_ramp`): Z's 2 µm band spread over
    // L = 2 µm / (0.6 · 1 mrad) = 3.3 mm (the planner's tangency tolerance
    // between lines at F6000, tp.c `tpSetupTangent`), over which the tool
    // stands off by what the compensation travels, 0.3 µm/mm · 3.3 mm =
    // 1.0 µm (by hand).
    let map = map_with_z_command(peak_um);
    let program = "G21 G90 G17 G64 P0.005\nG0 X0 Y0 Z0\nG1 X40 F6000\nM2\n";
    let (out, records, summary) = common::compensate_recorded(program, &map);
    assert_eq!(summary.small_reversals_held, 0, "{out}");
    let line: Vec<_> = records.iter().filter(|r| r.line == 3).collect();
    assert!(line.iter().any(|r| r.reversed[2]), "{out}");
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um < 1.1, "{report:?}: {out}");
}
