//! Under G61, two axes reversing together inside a line, one's switch
//! moving the other's error, taken up on a staged ramp (docs/compensation.md,
//! "A staged ramp for the cross lag"), checked end to end (compensate, then
//! the dead-band simulation and the planner model) against hand values.

use volcomp_core::compensate::PointRecord;
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

/// X's table moves the tool in Y by `−(1 − 0.03·|x|)` µm and in Z by
/// `−(3 − 0.03·|x|)` µm (both directions, table points every 0.25 mm):
/// Y and Z, standing still in the program, are commanded `1 − 0.03·|x|`
/// and `3 − 0.03·|x|` µm, rising at 0.03 µm/mm to X 0 and falling after
/// it, so both reverse downward at X 0. Z has a 6 µm band, Y a 2 µm band,
/// and Y's reverse table also moves Z by 0.6 µm (`cross_um`): Y's switch
/// moves Z's error, as the shop map's Y switch moves Z by 0.357 µm.
fn two_peaks_map(cross_um: f64) -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for dir in ["forward", "reverse"] {
        let rev = dir == "reverse";
        for k in 0..=400 {
            let p = -50.0 + 0.25 * k as f64;
            let drop = 0.03 * p.abs();
            csv.push_str(&format!(
                "X,{dir},{p},0,{},{}\n",
                -(1.0 - drop),
                -(3.0 - drop)
            ));
        }
        for p in [-100.0, 100.0] {
            let (y, z) = if rev { (2.0, cross_um) } else { (0.0, 0.0) };
            csv.push_str(&format!("Y,{dir},{p},0,{y},{z}\n"));
        }
        for p in [-100.0, 100.0] {
            csv.push_str(&format!(
                "Z,{dir},{p},0,0,{}\n",
                if rev { 6.0 } else { 0.0 }
            ));
        }
    }
    AxisTableMap::from_csv(&csv, "test.csv").unwrap()
}

#[test]
fn under_g61_two_axes_whose_switches_cross_are_taken_up_one_after_the_other() {
    // By hand, at F6000 (v = 100 mm/s, T = 1 ms, A = 1000 mm/s²): a join
    // is tangent below κ = 0.1·A/(v/T + A) = 0.990 mrad (tp.c
    // `tpSetupTangent`), a ramp uses 0.6 of it on pieces of ℓ = 2·v·T =
    // 0.2 mm, and a step of |Δ| as two parabolas needs
    // L = √(4·|Δ|·ℓ/(0.6·κ)).
    // - One step for both (Δ = (0, −2, −6.6) µm): Y's switch moves Z by
    //   0.6 µm while Z still stands in its band, which leaves the tool off
    //   by up to 0.6·6/6.6 = 0.55 µm at any ramp length (ramp_band.rs,
    //   `a_cross_lag_is_carried_until_the_standing_axis_crosses_its_band`):
    //   over the 0.2 µm a centred ramp may leave, refused (a stop).
    // - Staged: Z first (Y's switch moves Z by 0.6 µm, Z's moves Y by 0),
    //   on a step of its own lag, 6 µm: L_Z = √(4·6·0.2/0.594) = 2.8427 mm;
    //   then Y with its lag (0, 2, 0.6) µm: L_Y = √(4·2·0.2/0.594) =
    //   1.6412 mm. The ramp is 1.1·(L_Z + L_Y) = 4.9322 mm, Z's step its
    //   first L_Z/(L_Z + L_Y) = 0.63397; before X 0 lie Z's step and a
    //   third of Y's: (0.63397 + 0.36603/3)·4.9322 = 3.7285 mm. So the
    //   ramp runs from X −3.7285 to X 1.2037, Z's step ends at X −0.6017.
    // - Z stands (its target rising, its command going down its band)
    //   from the ramp's start at most to X 0: the tool is off by at most
    //   0.03·3.7285 = 0.112 µm. Y follows its target up to its step, then
    //   stands to the ramp's end at most: 0.03·(1.2037 − 0) = 0.036 µm
    //   after X 0, and Z, on its new flank by then, follows Y's 0.6 µm as
    //   Y's band is crossed.
    let map = two_peaks_map(0.6);
    let program = "G21 G61\nG0 X-20 Y0 Z0\nG1 X20 F6000\nM2\n";
    let (out, records, _) = common::compensate_recorded(program, &map);
    let line: Vec<&PointRecord> = records.iter().filter(|r| r.line == 3).collect();
    assert!(line.iter().all(|r| !r.take_up), "{out}");
    let at = |x: f64| {
        line.iter()
            .find(|r| (r.target_mm.x - x).abs() < 1e-3)
            .unwrap_or_else(|| panic!("no point at X {x}: {out}"))
    };
    let um = |mm: f64| mm * 1e3;
    // The ramp's start and end, where the hand values put them.
    let start = at(-3.7285);
    let end = at(1.2037);
    // Up to Z's step's end Y's command follows its target up (the old
    // way), Z's goes down.
    let z_end = -0.6017;
    let first: Vec<&&PointRecord> = line
        .iter()
        .filter(|r| r.target_mm.x >= start.target_mm.x - 1e-9 && r.target_mm.x <= z_end)
        .collect();
    assert!(first.len() >= 10, "{out}");
    for w in first.windows(2) {
        assert!(w[1].command_mm.y >= w[0].command_mm.y - 1e-9, "{out}");
        assert!(w[1].command_mm.z <= w[0].command_mm.z + 1e-9, "{out}");
    }
    // Z has come down its 6 µm, less its target's rise over its step
    // (0.03·3.127 mm): 5.906 µm; Y has risen with its target, 0.094 µm.
    let last_z = first.last().unwrap();
    let dx = last_z.target_mm.x - start.target_mm.x;
    assert!(
        (um(start.command_mm.z - last_z.command_mm.z) - (6.0 - 0.03 * dx)).abs() < 0.02,
        "{last_z:?} from {start:?}: {out}"
    );
    assert!(
        (um(last_z.command_mm.y - start.command_mm.y) - 0.03 * dx).abs() < 0.02,
        "{last_z:?} from {start:?}: {out}"
    );
    // At the ramp's end both are on their new flanks: Y at its target less
    // its 2 µm band, Z less its 6 µm band and Y's 0.6 µm on it.
    let x = end.target_mm.x;
    assert!(
        (um(end.command_mm.y) - (1.0 - 0.03 * x - 2.0)).abs() < 0.011,
        "{end:?}: {out}"
    );
    assert!(
        (um(end.command_mm.z) - (3.0 - 0.03 * x - 6.0 - 0.6)).abs() < 0.011,
        "{end:?}: {out}"
    );
    let report = common::simulated(&out, program, &map);
    assert!(report.contour_max_um <= 0.112 + 0.01, "{report:?}: {out}");
    // No stop: a stop at 100 mm/s costs v/a = 0.1 s; the ramp far less
    // than half of that on the planner model (LinuxCNC 2.9's planner).
    let (c0, c1) = (common::cutting_s(program), common::cutting_s(&out));
    assert!(c1 < c0 + 0.05, "{c0} s → {c1} s: {out}");
}
