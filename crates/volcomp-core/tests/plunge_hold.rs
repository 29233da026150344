//! Under G61, a small X/Y reversal inside a plunge held through the
//! plunge's end and on into the line after it (docs/compensation.md, "A
//! hold to the end of a plunge"), checked against hand values.

use volcomp_core::compensate::PointRecord;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// Z's table moves the tool in Y by `−y_um(z)` and X's by `−g(x)`, with
/// `g` 0 up to X 1 and rising 0.1 µm per mm from there (both directions),
/// so Y's command, with Y standing still in the program, is
/// `y_um(z) + g(x)`; Y has a 2 µm band (its reverse table). Z's table
/// points every 0.25 mm; X's at −100, 1 and 100.
fn map_with_y_command(y_um: impl Fn(f64) -> f64) -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for dir in ["forward", "reverse"] {
        for (p, g) in [(-100.0, 0.0), (1.0, 0.0), (100.0, 9.9)] {
            csv.push_str(&format!("X,{dir},{p},0,{},0\n", -g));
        }
        for p in [-100.0, 100.0] {
            let band = if dir == "reverse" { 2.0 } else { 0.0 };
            csv.push_str(&format!("Y,{dir},{p},0,{band},0\n"));
        }
        for k in 0..=400 {
            let p = -50.0 + 0.25 * k as f64;
            csv.push_str(&format!("Z,{dir},{p},0,{},0\n", -y_um(p)));
        }
    }
    AxisTableMap::from_csv(&csv, "test.csv").unwrap()
}

/// Down to Z −1.5 Y's command rises 0.1 µm per mm of depth; from there to
/// Z −2 it turns back by `dip_um` (a table point at each break).
fn y_with_dip_um(dip_um: f64) -> impl Fn(f64) -> f64 {
    move |z| {
        if z >= -1.5 {
            -0.1 * z
        } else if z >= -2.0 {
            0.15 - 2.0 * dip_um * (-z - 1.5)
        } else {
            0.15 - dip_um
        }
    }
}

fn run(program: &str, map: &AxisTableMap) -> (String, Vec<PointRecord>, u64) {
    let (out, records, summary) = common::compensate_recorded(program, map);
    (out, records, summary.small_reversals_held)
}

#[test]
fn under_g61_a_small_y_reversal_in_a_plunge_is_held_to_its_end_and_into_the_next_line() {
    // Y's command turns back by 0.2 µm from Z −1.5 to the plunge's end at
    // Z −2: below the hold's bound (0.4 µm less G61's 0.05 µm contour
    // tolerance), so Y is held at 0.15 µm through the plunge's end. The
    // line along X after it wants −0.05 µm (0.15 − 0.2) at its first
    // target, X 1, and rises 0.1 µm per mm from there: back at the held
    // 0.15 µm at X 3, inside the line, so the hold goes on there too. Y's
    // command never goes down, no take-up is written after the approach,
    // and the tool is off by the dip, 0.2 µm, from the corner (Z −2, X 0)
    // to X 1. Main 79062eb instead takes Y's reversal up inside the
    // plunge (−1.85 µm commanded at Z −1.5, −2.05 at Z −2) and back on a
    // ramp from X 1 to X 3; the hold through the plunge's end alone, not
    // carried on, writes a take-up block at the line's start (Y 0.15 →
    // −1.85 µm) and the same ramp.
    let map = map_with_y_command(y_with_dip_um(0.2));
    let program = "G61\nG0 X0 Y0 Z1\nG1 Z-2 F6000\nG1 X5\nM2\n";
    let (out, records, held) = run(program, &map);
    assert!(held > 0, "{out}");
    let path: Vec<&PointRecord> = records.iter().filter(|r| r.line >= 3).collect();
    assert!(
        path.iter().filter(|r| r.line == 4).all(|r| !r.take_up),
        "{out}"
    );
    for w in path.windows(2) {
        assert!(
            w[1].command_mm.y >= w[0].command_mm.y - 1e-9,
            "Y turns down at {:?}: {out}",
            w[1].target_mm
        );
    }
    // Held at 0.15 µm (where it turned, Z −1.5) to the plunge's end and
    // on at the line's first target.
    let end = path
        .iter()
        .find(|r| r.line == 3 && (r.target_mm.z + 2.0).abs() < 1e-9)
        .unwrap();
    assert!(
        (end.command_mm.y * 1e3 - 0.15).abs() < 0.011,
        "{end:?}: {out}"
    );
    let first = path.iter().find(|r| r.line == 4).unwrap();
    assert!((first.target_mm.x - 1.0).abs() < 1e-9, "{first:?}: {out}");
    assert!(
        (first.command_mm.y * 1e3 - 0.15).abs() < 0.011,
        "{first:?}: {out}"
    );
    let report = common::simulated(&out, program, &map);
    assert!(
        (report.contour_max_um - 0.2).abs() < 0.02,
        "{report:?}: {out}"
    );
}

#[test]
fn under_g61_a_plunge_reversal_over_the_bound_is_not_held() {
    // The same with a 0.5 µm turn back: over the 0.35 µm bound, so Y is not
    // held: its command goes down inside the plunge, as without the rule.
    let map = map_with_y_command(y_with_dip_um(0.5));
    let program = "G61\nG0 X0 Y0 Z1\nG1 Z-2 F6000\nG1 X8\nM2\n";
    let (out, records, held) = run(program, &map);
    assert_eq!(held, 0, "{out}");
    let end = records
        .iter()
        .find(|r| r.line == 3 && (r.target_mm.z + 2.0).abs() < 1e-9)
        .unwrap();
    // In Y's reverse state (its 2 µm band) or forward at −0.35 µm: below
    // where it turned either way.
    assert!(end.command_mm.y * 1e3 < 0.15 - 0.4, "{end:?}: {out}");
}
