//! Under G61, a line that runs tangentially into an arc turning an axis the
//! line does not move: the axis stands still along the line, so its motor
//! crosses its dead band there with the tool on the path, free of time
//! (docs/compensation.md, "A line into an arc that reverses an axis";
//! compensate/mod.rs `Tail::line_s_curve`). Checked end to end on the
//! contour of examples/data/part.ngc (a 60 × 40 mm rectangle with R5
//! corners) with the demo's example map, in machine coordinates (the
//! demo's G54 of 250, 200, 150 mm added by hand).

use volcomp_core::example::example_map;

use crate::common;

/// part.ngc's contour at F6000 under G61: four lines, each into an R5
/// corner arc that turns the axis the line holds still (Y after the X
/// lines, X after the Y lines).
const CONTOUR: &str = "G21 G17 G90 G94 G61\nG0 Z155\nG0 X225 Y180\nG1 Z145 F6000\n\
     G1 X275 Y180\nG3 X280 Y185 R5\nG1 Y215\nG3 X275 Y220 R5\nG1 X225\n\
     G3 X220 Y215 R5\nG1 Y185\nG3 X225 Y180 R5\nG0 Z155\nM2\n";

#[test]
fn under_g61_a_line_into_an_arc_that_turns_a_still_axis_takes_it_up_on_the_line() {
    let map = example_map();
    let (out, records, summary) = common::compensate_recorded(CONTOUR, &map);
    // Each corner arc turns the axis its line holds still. At the first,
    // Y already moves the way the arc moves it (the approach left it so);
    // along the last line the map's own X correction turns X's command
    // before the corner (a ramp on the line). The second and third lines
    // cross X's and Y's bands on their ends. main 39b6a5a wrote an
    // S-curve across each join instead, its part after the join a segment
    // of its own: none taken up ahead.
    assert!(summary.take_ups_idle >= 2, "{summary:?}\n{out}");
    // Every line's last point is its own end, solved in the state the arc
    // runs in: the record of each line ends at the corner (within the
    // few µm of the compensation), so the metric pairs the take-up with
    // the line it runs on.
    for (line, end) in [
        (5_u64, [275.0, 180.0]),
        (7, [280.0, 215.0]),
        (9, [225.0, 220.0]),
    ] {
        let last = records
            .iter()
            .rfind(|r| r.line == line)
            .unwrap_or_else(|| panic!("no point of line {line}\n{out}"));
        let off = (last.target_mm.x - end[0]).hypot(last.target_mm.y - end[1]);
        assert!(
            off < 1e-9,
            "line {line} ends its records at {:?}\n{out}",
            last.target_mm
        );
    }
    // The time on the planner model (LinuxCNC 2.9's planner to the ms):
    // the original passes each join at the R5 arc's own limit
    // (√(a_n·5 mm) = 65.8 mm/s); main 39b6a5a slowed to 39 mm/s into
    // each S-curve (+3.9 % cutting time on this contour); the take-up on
    // the line costs nothing but the compensation's own few µm.
    let ratio = common::cutting_s(&out) / common::cutting_s(CONTOUR);
    assert!(ratio < 1.012, "{ratio}\n{out}");
    // The dead-band simulation (a second method: simulate/) finds the
    // tool within G61's 0.5 µm (issue 24's goal) everywhere.
    let report = common::simulated(&out, CONTOUR, &map);
    assert!(report.contour_max_um <= 0.5, "{report:?}\n{out}");
    eprintln!("ratio {ratio} report {report:?}");
}
