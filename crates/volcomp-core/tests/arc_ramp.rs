//! Under G61, a reversal of Z inside an arc taken up on a ramp around it
//! (docs/compensation.md, "A ramp around a reversal inside an arc"),
//! checked against hand values.

use volcomp_core::compensate::PointRecord;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X's table moves the tool in Z so that Z, standing still in the
/// program, is commanded `3 + 0.03·(x − 5)` µm for x < 5 and
/// `3 − 0.12·(x − 5)` µm after (table points every 0.25 mm, both
/// directions): it rises slowly to X 5 and falls four times as fast after
/// it. Z has a 6 µm band (its
/// reverse table), Y none.
fn kink_map() -> AxisTableMap {
    common::map_fine_on(&[0], 200.0, |a, p, rev| match a {
        0 if p < 5.0 => [0.0, 0.0, -(3.0 + 0.03 * (p - 5.0))],
        0 => [0.0, 0.0, -(3.0 - 0.12 * (p - 5.0))],
        2 if rev => [0.0, 0.0, 6.0],
        _ => [0.0; 3],
    })
}

#[test]
fn under_g61_a_z_reversal_inside_an_arc_is_taken_up_on_a_ramp_around_it() {
    // An arc of R100 over the top of its circle, X −20 → 20 (40.3 mm):
    // along it X runs at cos ≥ 0.98 of the path, so Z's command drifts
    // s₁ ≈ 0.03 µm/mm before X 5 and s₂ ≈ 0.12 after (Y's quarter
    // point, X 0, lies outside the ramp). At F6000 on an arc
    // LinuxCNC takes a join as tangent below κ = 0.1·0.5·A/(v/T + A) =
    // 0.495 mrad (tp.c `tpSetupTangent`, `BLEND_ACC_RATIO_TANGENTIAL`); a
    // ramp may use 0.6 of it, on pieces of ℓ = 2·v·T = 0.2 mm, so Z's
    // 6 µm take-up as a cubic step needs L = √(6·6 µm·ℓ/(0.6·κ)) =
    // 4.92 mm by hand. From X 5 on, the held tool would stand off by
    // 0.12·4.92 = 0.59 µm, above the 0.4 µm of any G61 ramp: main 79062eb
    // writes a take-up block there, a stop. Centred on X 5 (a tenth longer,
    // 5.41 mm) it would be off by (0.12 − 0.03)·2.71 = 0.24 µm, above the
    // 0.2 µm such a ramp may leave. Started a = s₂L/(2s₁ + s₂) = 2/3·L =
    // 3.61 mm before X 5, it is off by at most s₁·a = 0.108 µm.
    let map = kink_map();
    let program = "G21 G61\nG0 X-20 Y-2.0204 Z0\nG2 X20 Y-2.0204 I20 J-97.9796 F6000\nM2\n";
    let (out, records, _) = common::compensate_recorded(program, &map);
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 3).collect();
    assert!(!line.is_empty(), "{out}");
    assert!(line.iter().all(|r| !r.take_up), "{out}");
    // Z's command rises no more from the ramp's start, about 3.6 mm
    // before X 5 (held there), then goes down.
    let start = line
        .iter()
        .position(|r| r.target_mm.x > 0.5)
        .expect("a point on the ramp");
    for w in line[start..].windows(2) {
        assert!(
            w[1].command_mm.z <= w[0].command_mm.z + 1e-9,
            "Z turns up at X {}: {out}",
            w[1].target_mm.x
        );
    }
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.2, "{report:?}: {out}");
    // No stop: on an arc a stop at 100 mm/s costs about 2·v/a_t = 0.2 s
    // (a_t = A/2); the ramp far less than a quarter of that on the planner
    // model (LinuxCNC 2.9's planner).
    let (c0, c1) = (common::cutting_s(program), common::cutting_s(&out));
    assert!(c1 < c0 + 0.05, "{c0} s → {c1} s: {out}");
}

/// X's table moves the tool in Z so that Z, standing still in the
/// program, is commanded `1 + 0.05·(x + 20)` µm up to X −3, falls at
/// 0.05 µm/mm to X 0 and rises at 0.05 µm/mm after it; Y's reverse
/// table steps Z's command up by 0.3 µm (the shop map's straightness
/// switching with an axis' direction) and gives Y a 3 µm band; Z has a
/// 6 µm band, X none.
fn dip_map() -> AxisTableMap {
    common::map_fine_on(&[0], 200.0, |a, p, rev| match (a, rev) {
        (0, _) if p < -3.0 => [0.0, 0.0, -(1.0 + 0.05 * (p + 20.0))],
        (0, _) if p < 0.0 => [0.0, 0.0, -(1.85 - 0.05 * (p + 3.0))],
        (0, _) => [0.0, 0.0, -(1.7 + 0.05 * p)],
        (1, true) => [0.0, 3.0, -0.3],
        (2, true) => [0.0, 0.0, 6.0],
        _ => [0.0; 3],
    })
}

#[test]
fn under_g61_a_turn_of_z_that_the_quarter_point_turns_back_is_held_across_it() {
    // The arc of the test above: Y runs up to X 0 and down after it (its
    // quarter point, an S-curve). Z's command turns down at X −3 by
    // 0.05·3 = 0.15 µm up to X 0, less than its 6 µm band: held at X −3
    // the tool is off by that alone. At the quarter point Y's switch steps
    // Z's command up by 0.3 µm, past the held level (1.7 + 0.3 > 1.85 µm
    // by hand), so the hold ends there, and Z never reverses. Main 81922d1
    // ends a hold only before the S-curve: there Z reverses (a ramp or a
    // take-up block) and its command falls by its band.
    let map = dip_map();
    let program =
        "G21 G61\nG0 X-20 Y-10 Z0\nG1 Y-2.0204 F6000\nG2 X20 Y-2.0204 I20 J-97.9796\nM2\n";
    let (out, records, _) = common::compensate_recorded(program, &map);
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 4).collect();
    assert!(!line.is_empty(), "{out}");
    // (Z's take-up at the arc's start, a corner after the line, is free.)
    assert!(line.iter().skip(1).all(|r| !r.take_up), "{out}");
    for w in line.windows(2) {
        assert!(
            w[1].command_mm.z >= w[0].command_mm.z - 1e-9,
            "Z falls at X {}: {out}",
            w[1].target_mm.x
        );
    }
    // The tool within the hold's 0.15 µm by hand plus the S-curve's own
    // deviation, within the 0.4 µm a G61 run-through may leave.
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.4, "{report:?}: {out}");
}

/// The shop map bench/eval uses (`run.py --maps shop`, written by
/// bench/shop_map.py): bands of 2–9 µm and straightness tables that turn
/// Z's command within tenths of a micrometre of X's quarter points.
fn shop_map() -> AxisTableMap {
    common::data_map("shop_map.csv")
}

#[test]
fn under_g61_a_take_up_ahead_of_a_quarter_point_leaves_room_for_its_s_curve() {
    // bench/eval's g2_d60 at F3000 on the shop map, its G54 offset
    // (250, 200, 150) written into the program. Z's command turns down
    // right after X's S-curve at X 220. Main ba3c40c takes that reversal
    // up on a ramp ahead of the S-curve: Z's carriage stands in its band
    // while its target still rises 0.37 µm, the band is not crossed when
    // the ramp ends, and with X's S-curve beside it the tool is 0.591 µm
    // off (bench/eval/judge.py's own dead-band simulation, and
    // `volcomp simulate`, on main's output). Refused there (0.37 µm is
    // more than the 0.2 µm a centred ramp may leave), the ramp after the
    // S-curve takes it: judge.py 0.322 µm, cutting 4.153 → 4.106 s.
    let map = shop_map();
    let program = "G21 G17 G90 G94 G61\nG0 Z155\nG0 X280 Y200\nG1 Z150 F3000\n\
                   G2 X280 Y200 I-30 J0\nG0 Z155\nM2\n";
    let (out, _, _) = common::compensate_recorded(program, &map);
    let report = common::simulated(&out, program, &map);
    // Within the 0.4 µm a G61 run-through may leave (main: 0.591 µm).
    assert!(report.contour_max_um <= 0.4, "{report:?}: {out}");
    // No stop added: the two take-up blocks main writes (at the plunge's
    // corner and at a quarter point), no more.
    assert!(out.matches("take-up)").count() <= 2, "{out}");
}

#[test]
fn under_g61_a_z_take_up_right_after_a_quarter_point_s_curve_is_spread_across_it() {
    // bench/eval's g2_d40 at F6000 on the shop map, its G54 offset
    // (250, 200, 150) written into the program. At X's quarter point
    // (X 270) Z's straightness switches with X's direction, and Z's
    // command, rising into the point, turns down right where X's S-curve
    // ends. Main 8453e54 writes a take-up block there (`G1 Y199.77722
    // Z149.99441`, a stop: four take-up blocks, 2.234 s cutting on the
    // planner model, both read from the base binary's output by CLI).
    let map = shop_map();
    let program = "G21 G17 G90 G94 G61\nG0 Z155\nG0 X267.3205 Y210\nG1 Z150 F6000\n\
                   G2 X267.3205 Y210 I-17.3205 J-10\nG0 Z155\nM2\n";
    let (out, _, summary) = common::compensate_recorded(program, &map);
    // No take-up block within a millimetre of X's quarter point.
    let near_quarter = out.lines().filter(|l| l.contains("take-up)")).any(|l| {
        let word = |c: char| {
            l.split_whitespace()
                .find_map(|w| w.strip_prefix(c).and_then(|v| v.parse::<f64>().ok()))
        };
        // (A take-up block there moves Y by its rounding and Z, no X.)
        word('X').is_none_or(|x| (x - 270.0).abs() < 1.0)
            && word('Y').is_some_and(|y| (y - 200.0).abs() < 1.0)
    });
    assert!(!near_quarter, "{out}");
    assert!(out.matches("take-up)").count() <= 3, "{out}");
    assert!(summary.take_ups_folded >= 1, "{summary:?}");
    // The stop gone: faster than main's 2.234 s.
    let cut = common::cutting_s(&out);
    assert!(cut < 2.20, "{cut}");
    // Z's carriage stands across the S-curve while its target steps there
    // (0.28 µm) and falls after it, beside X's S-curve (0.34 µm): 0.446 µm
    // by the rule's bound, 0.434 µm by bench/eval/judge.py on the eval's
    // output. The row's largest stays where main has it, 0.501 µm by
    // `volcomp simulate` at the plunge's corner (base binary, by CLI).
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.505, "{report:?}: {out}");
}

#[test]
fn under_g61_a_z_take_up_inside_an_arc_away_from_its_s_curves_is_spread_on_a_ramp_of_its_own() {
    // bench/eval's g2_d60 at F6000 on the shop map, its G54 offset
    // (250, 200, 150) written into the program. At X 270 (program X 20, a
    // point of X's tables, 41° before Y's quarter point) Z's command,
    // rising with X's straightness in Z, turns down: Z reverses with no
    // S-curve near. Main 6d877ee writes a take-up block there (`G1
    // Y177.63742 Z149.99350`, a stop: three take-up blocks, 2.640 s
    // cutting on the planner model, contour RMS 0.097 µm and max 0.369 µm
    // by `volcomp simulate --reference --chord-tolerance 0.0001`, the
    // reading of `common::simulated`; all read from the base binary's
    // output by CLI), so this test fails on main.
    let map = shop_map();
    let program = "G21 G17 G90 G94 G61\nG0 Z155\nG0 X280 Y200\nG1 Z150 F6000\n\
                   G2 X280 Y200 I-30 J0\nG0 Z155\nM2\n";
    let (out, _, summary) = common::compensate_recorded(program, &map);
    // The only take-up blocks left are the plunge's, at the circle's start.
    let word = |l: &str, c: char| {
        l.split_whitespace()
            .find_map(|w| w.strip_prefix(c).and_then(|v| v.parse::<f64>().ok()))
    };
    let away = out
        .lines()
        .filter(|l| l.contains("take-up)"))
        .any(|l| word(l, 'Y').is_some_and(|y| (y - 200.0).abs() > 1.0));
    assert!(!away, "{out}");
    assert!(out.matches("take-up)").count() <= 2, "{out}");
    assert!(summary.take_ups_folded >= 1, "{summary:?}");
    // The stop gone: faster than main's 2.640 s by more than the ~0.1 s a
    // stop at 100 mm/s costs at 1,000 mm/s² (v/a).
    let cut = common::cutting_s(&out);
    assert!(cut < 2.55, "{cut}");
    // The ramp leaves the tool within the 0.2 µm a centred ramp may: the
    // contour's largest stays main's (at the plunge's corner) and its RMS
    // below main's (the lane's: 0.091 µm, by the same CLI reading).
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.370, "{report:?}: {out}");
    assert!(report.contour_rms_um < 0.097, "{report:?}: {out}");
}

#[test]
fn under_g61_a_z_take_up_inside_an_arc_whose_ramp_reaches_an_s_curve_is_spread_across_it() {
    // bench/eval's spiral_arcs12 (set b), its first two half circles, at
    // F6000 on the shop map with its G54 offset (250, 200, 150) written
    // in. On the first (radius 4 mm, 12.6 mm long) Z's command turns at X
    // 250.55 (45 % of the way), 0.55 mm before Y's quarter point and its
    // S-curve: a ramp of its own (5.3 mm) would run into that S-curve, so
    // main 621cc8b writes a take-up block there (`G1 X250.55026
    // Z149.99965`, a stop: two take-up blocks, 0.913 s cutting on the
    // planner model against the original's 0.735 s; contour RMS 0.112 µm,
    // max 0.390 µm by `volcomp simulate --reference --chord-tolerance
    // 0.0001`, the reading of `common::simulated`; all read from main's
    // binary by CLI), so this test fails on main.
    let map = shop_map();
    let program = "G21 G17 G90 G94 G61\nG0 Z155\nG0 X254 Y200\nG1 Z150 F6000\n\
                   G2 X246 Y200 I-4 J0\nG2 X255.5 Y200 I4.75 J0\nG0 Z155\nM2\n";
    let (out, _, summary) = common::compensate_recorded(program, &map);
    // The only take-up block left is the plunge's, at the first circle's
    // start (X 254).
    let word = |l: &str, c: char| {
        l.split_whitespace()
            .find_map(|w| w.strip_prefix(c).and_then(|v| v.parse::<f64>().ok()))
    };
    let away = out
        .lines()
        .filter(|l| l.contains("take-up)"))
        .any(|l| word(l, 'X').is_none_or(|x| (x - 254.0).abs() > 0.1));
    assert!(!away, "{out}");
    assert!(out.matches("take-up)").count() <= 1, "{out}");
    assert!(summary.take_ups_folded >= 1, "{summary:?}");
    // The stop gone: faster than main's 0.913 s by more than the ~0.1 s a
    // stop at 100 mm/s costs at 1,000 mm/s² (v/a).
    let cut = common::cutting_s(&out);
    assert!(cut < 0.82, "{cut}");
    // The ramp crosses the S-curve within the G61 goal: the contour's
    // largest stays main's (the lane's by the same CLI reading: 0.390
    // µm, RMS 0.122 µm, the ramp standing the tool off where the block
    // kept it on the path).
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.395, "{report:?}: {out}");
}
