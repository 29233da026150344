//! Under G61, a reversal inside a line taken up on a ramp centred on it
//! (docs/compensation.md, "A ramp centred on a reversal along a line"),
//! checked against hand values.

use volcomp_core::compensate::PointRecord;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X's table moves the tool in Z by `−(3 − 0.15·|x|)` µm (both directions,
/// table points every 0.25 mm): Z, standing still in the program, is
/// commanded `3 − 0.15·|x|` µm, rising at 0.15 µm/mm to X 0 and falling
/// after it. Z has a 6 µm band (its reverse table), as the shop map's.
fn peak_map() -> AxisTableMap {
    common::map_fine_on(&[0], 100.0, |a, p, rev| match a {
        0 => [0.0, 0.0, -(3.0 - 0.15 * p.abs())],
        2 if rev => [0.0, 0.0, 6.0],
        _ => [0.0; 3],
    })
}

#[test]
fn under_g61_a_reversal_inside_a_line_is_taken_up_on_a_ramp_centred_on_it() {
    // At F6000 (v = 100 mm/s, T = 1 ms, A = 1000 mm/s²) LinuxCNC's planner
    // takes a join as tangent where the path turns by less than
    // κ = 0.1·A/(v/T + A) = 0.990 mrad (tp.c `tpSetupTangent`); a ramp may
    // use 0.6 of it, on pieces of ℓ = 2·v·T = 0.2 mm. Z's 6 µm take-up as
    // two parabolas needs L = √(4·6 µm·ℓ/(0.6·κ)) = 2.84 mm by hand. From
    // the reversal (X 0) on, the held tool would stand off by 0.15·2.84 =
    // 0.43 µm, above the 0.4 µm a G61 ramp may leave, so main 82b9f92
    // writes a take-up block there: a stop, +0.13 s of 0.50 s (planner
    // model, release build). Centred, the ramp (a tenth longer, 3.13 mm)
    // starts 1.56 mm before X 0: the tool, held at the ramp start's level,
    // is off by at most 0.15·1.56 = 0.235 µm (at X 0), and the ramp is
    // taken where its dead-band reading stays within 0.2 µm.
    let map = peak_map();
    let program = "G21 G61\nG0 X-20 Y0 Z0\nG1 X20 F6000\nM2\n";
    let (out, records, _) = common::compensate_recorded(program, &map);
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 3).collect();
    assert!(line.iter().all(|r| !r.take_up), "{out}");
    // Z's command: rising no more from the ramp's start (held there), then
    // down its band: 6 µm below the target at X 20 (3 − 3 − 6 = −6 µm).
    let start = line
        .iter()
        .position(|r| r.target_mm.x > -1.7)
        .expect("a point on the ramp");
    assert!(line[start].target_mm.x < -1.4, "{out}");
    for w in line[start..].windows(2) {
        assert!(
            w[1].command_mm.z <= w[0].command_mm.z + 1e-9,
            "Z turns up at X {}: {out}",
            w[1].target_mm.x
        );
    }
    let last = line.last().unwrap();
    assert!(
        (last.command_mm.z * 1e3 + 6.0).abs() < 0.011,
        "{last:?}: {out}"
    );
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.235 + 0.01, "{report:?}: {out}");
    // No stop: a stop at 100 mm/s costs v/a = 0.1 s (slowing down and
    // speeding up again at A); the centred ramp costs far less than half
    // of that on the planner model (LinuxCNC 2.9's planner).
    let (c0, c1) = (common::cutting_s(program), common::cutting_s(&out));
    assert!(c1 < c0 + 0.05, "{c0} s → {c1} s: {out}");
}
