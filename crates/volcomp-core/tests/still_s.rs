//! Under G61, a still axis' take-up inside a line written as an S of two
//! arcs in the plane of the line and that axis (docs/compensation.md, "A
//! still axis' take-up inside a line: an S of two arcs";
//! compensate/still_s.rs), checked against hand values.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X's table moves the tool in Z by `−(20 − 0.5·|x|)` µm (both
/// directions, table points every 0.25 mm): Z, standing still in the
/// program, is commanded `20 − 0.5·|x|` µm, rising at 0.5 µm/mm to X 0
/// and falling after it. Z has a 6 µm band (its reverse table).
fn steep_peak_map() -> AxisTableMap {
    common::map_fine_on(&[0], 100.0, |a, p, rev| match a {
        0 => [0.0, 0.0, -(20.0 - 0.5 * p.abs())],
        2 if rev => [0.0, 0.0, 6.0],
        _ => [0.0; 3],
    })
}

#[test]
fn under_g61_a_still_axis_turning_inside_a_line_is_taken_up_on_an_s_of_two_arcs() {
    let map = steep_peak_map();
    let program = "G21 G61\nG0 X-3 Y0 Z0\nG1 X-1.5 F6000\nG1 X1.5\nM2\n";
    let (out, records, summary) = common::compensate_recorded(program, &map);
    // By hand. At F6000 (v = 100 mm/s) LinuxCNC runs an arc of radius R at
    // no more than √(a_n·R), a_n = 1000·√(1 − 0.5²) = 866.0 mm/s²
    // (blendmath.c `pmCircleActualMaxVel`): R ≥ v²/a_n = 11.547 mm, taken
    // 1.2 times, 13.856 mm. Two arcs of that radius offset the path by
    // Z's band h = 6 µm over L = √(4Rh − h²) = 0.5766 mm of X. The
    // slopes before and after X 0 are equal (0.5 µm/mm), so the S starts
    // L/2 = 0.2883 mm before it, and the tool, standing in Z while the
    // motor crosses the band, is off by at most L·s₁s₂/(s₁ + s₂) =
    // 0.5766·0.25 = 0.144 µm, at X 0: within the 0.2 µm of a centred
    // ramp, and over the span from the S's start to the next point well
    // within 1 % of the 20 µm the machine leaves there uncompensated. A
    // centred linear ramp (3.1 mm, compensate/ramp_centre.rs) would leave
    // 0.5·1.56 = 0.78 µm: main bba33eb writes a take-up block, a stop
    // (v/a ≈ 0.1 s).
    let r = 1.2 * 100.0f64.powi(2) / (1000.0 * 0.75f64.sqrt());
    let h = 0.006;
    let l = (4.0 * r * h - h * h).sqrt();
    assert!((l - 0.5766).abs() < 1e-4);
    assert_eq!(summary.take_ups, 0, "{out}");
    assert!(
        records.iter().filter(|r| r.line == 4).all(|r| !r.take_up),
        "{out}"
    );
    // The S in the plane of X and Z (G18), the program's plane after it.
    let lines: Vec<&str> = out.lines().collect();
    let g18 = lines
        .iter()
        .position(|l| l.starts_with("G18"))
        .unwrap_or_else(|| panic!("no plane switch: {out}"));
    assert!(
        lines[g18 + 1].starts_with("G2") || lines[g18 + 1].starts_with("G3"),
        "{out}"
    );
    assert!(
        lines[g18 + 2].starts_with("G2") || lines[g18 + 2].starts_with("G3"),
        "{out}"
    );
    assert!(lines[g18 + 3].starts_with("G17"), "{out}");
    // Its ends, from the records: the S's start in place of X 0's point,
    // its end reversing Z.
    let line: Vec<_> = records.iter().filter(|r| r.line == 4).collect();
    let end = line
        .iter()
        .position(|r| r.reversed[2])
        .unwrap_or_else(|| panic!("no reversal of Z: {out}"));
    let (x0, x1) = (line[end - 1].target_mm.x, line[end].target_mm.x);
    assert!((x0 + l / 2.0).abs() < 1e-6, "S from X {x0}: {out}");
    assert!((x1 - l / 2.0).abs() < 1e-6, "S to X {x1}: {out}");
    // Z's command across the S: down by the band and the target's own
    // change from X −L/2 to X L/2 (none: the peak is symmetric).
    let dz_um = (line[end].command_mm.z - line[end - 1].command_mm.z) * 1e3;
    assert!((dz_um + 6.0).abs() < 0.011, "{dz_um} µm: {out}");
    // The dead-band simulation (a second method: simulate/): within the
    // hand bound and the segmentation's contour tolerance (0.05 µm).
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.144 + 0.05, "{report:?}: {out}");
    // No stop: a take-up block at X 0 stops the tool there, about v/a =
    // 0.077 s at the 77 mm/s it reaches from the stop at X −1.5 (√(2·A·1.5
    // mm)). The S costs only its arcs' tangential acceleration, half of A
    // (blendmath.h `BLEND_ACC_RATIO_TANGENTIAL`), which the short line is
    // still accelerating through: 9 ms on the planner model.
    let (c0, c1) = (common::cutting_s(program), common::cutting_s(&out));
    assert!(c1 < c0 + 0.02, "{c0} s → {c1} s: {out}");
}

#[test]
fn under_cutter_radius_compensation_no_s_changes_the_plane() {
    // LinuxCNC refuses a plane change while cutter radius compensation is
    // on (interp_check.cc): the take-up stays a block there.
    let map = steep_peak_map();
    let program = "G21 G61\nG0 X-20 Y-5 Z0\nG41 D0\nG1 X-19 Y-5 F6000\nG1 X20\nG40\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    assert!(!out.lines().any(|l| l.starts_with("G18")), "{out}");
}
