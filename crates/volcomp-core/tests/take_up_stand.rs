//! Under G61, an axis that a take-up block leaves ahead of its new target
//! stands on the line after it until the target catches up
//! (docs/compensation.md, "An axis left ahead by a take-up block stands"),
//! checked end to end (compensate, then the dead-band simulation) against
//! hand values.

use volcomp_core::compensate::PointRecord;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// Z, standing still in the program, is commanded `0.2·x` µm along X and
/// `−0.2·y` µm along Y (X's and Y's tables move the tool in Z), so it
/// reverses downward at the corner X 0 Y 0 of an X line and a Y line; Y's
/// table moves the tool in X by `−0.05·y` µm, so X's command rises
/// 0.05 µm/mm along Y. Z has a 6 µm band, and its reverse table also moves
/// X by 0.3 µm: Z's switch moves X's command back by 0.3 µm. Tables every
/// 0.25 mm (X, Y) and at ±100 (Z).
fn corner_map() -> AxisTableMap {
    common::map_fine_on(&[0, 1], 100.0, |a, p, rev| match (a, rev) {
        (0, _) => [0.0, 0.0, -0.2 * p],
        (1, _) => [-0.05 * p, 0.0, 0.2 * p],
        (_, true) => [0.3, 0.0, 6.0],
        (_, false) => [0.0; 3],
    })
}

#[test]
fn under_g61_an_axis_a_take_up_leaves_ahead_stands_until_its_target_catches_up() {
    // By hand: Z's take-up at the corner (a G61 stop) moves X's target
    // back to −0.3 µm; X, moving forward, cannot follow without reversing,
    // so its command stays at 0 and the tool starts the Y line 0.3 µm off.
    // X's target rises 0.05 µm/mm: it is back at the command (plus the
    // 0.01 µm margin) at Y (0.3 + 0.01)/0.05 = 6.2 mm. Standing to there,
    // the offset fades from 0.3 µm to 0 over 6.2 mm instead of the whole
    // 20 mm: the contour's mean square over the 40 mm of both lines is
    // 0.3²·6.2/3/40 µm², RMS 0.0681 µm, against 0.3²·20/3/40, 0.1225 µm,
    // on main 81922d1 (which writes no target between the corner and
    // Y 20). The largest offset stays 0.3 µm, at the corner.
    let map = corner_map();
    let program = "G21 G61\nG0 X-20 Y0 Z0\nG1 X0 F6000\nG1 Y20\nM2\n";
    let (out, records, _) = common::compensate_recorded(program, &map);
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 4).collect();
    assert!(line[0].take_up, "{out}");
    assert!(line.iter().skip(1).all(|r| !r.take_up), "{out}");
    // The target inserted where X's target catches up, X standing to it,
    // then Y 20.
    assert_eq!(line.len(), 2, "{out}");
    assert!((line[0].target_mm.y - 6.2).abs() < 1e-9, "{out}");
    assert!((line[0].command_mm.x * 1e3 - 0.01).abs() < 0.006, "{out}");
    assert!((line[1].command_mm.x * 1e3 - 0.7).abs() < 0.006, "{out}");
    let report = common::simulated(&out, program, &map);
    let rms = (0.09f64 * 6.2 / 3.0 / 40.0).sqrt();
    assert!(
        (report.contour_rms_um - rms).abs() < 0.003,
        "{rms}: {report:?}: {out}"
    );
    assert!(
        (report.contour_max_um - 0.3).abs() < 0.011,
        "{report:?}: {out}"
    );
}
