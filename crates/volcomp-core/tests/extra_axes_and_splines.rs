//! Compensation of moves with extra axes (A … W) and of splines, under a
//! map of zeros so that every expected number is derived by hand: a split
//! G1 carries its share of the extra axes on every segment (G90: the
//! interpolated value; G91: equal increments), and a spline becomes G1
//! segments ending exactly on its end point, with its block's other words
//! kept and its spline words gone.

use volcomp_core::compensate::{CompensateOptions, Segmentation};
use volcomp_core::model::axis_table::AxisTableMap;

use crate::common;

fn compensate(program: &str, segment_mm: f64) -> String {
    compensate_with(
        program,
        &common::zero_map(),
        Segmentation::MaxLength(segment_mm),
    )
}

fn compensate_with(program: &str, map: &AxisTableMap, segmentation: Segmentation) -> String {
    // The words expected below are written with 4 decimals (0.1 µm).
    let options = CompensateOptions {
        segmentation,
        decimals: Some(4),
        ..CompensateOptions::default()
    };
    common::compensate_text(program, "t.ngc", map, &options).unwrap()
}

#[test]
fn a_split_g1_carries_its_share_of_a_on_every_segment() {
    // X0 → X20 with A0 → A40, in 5 mm segments: A10, A20, A30, A40.
    let out = compensate("G21 G90 F100\nG0 X0 Y0 Z0 A0\nG1 X20 A40\nM2\n", 5.0);
    let lines: Vec<&str> = out.lines().collect();
    let i = lines.iter().position(|l| l.starts_with("G1 X5")).unwrap();
    assert_eq!(lines[i], "G1 X5.0000 A10.0000");
    assert_eq!(lines[i + 1], "X10.0000 A20.0000 (volcomp L3)");
    assert_eq!(lines[i + 2], "X15.0000 A30.0000 (volcomp L3)");
    assert_eq!(lines[i + 3], "X20.0000 A40.0000 (volcomp L3)");
}

#[test]
fn split_a_words_are_in_the_program_frame_under_g92() {
    // At A30, G92 A0: A40 in the program is A70 on the machine; the split
    // segments write program values A10 … A40.
    let out = compensate(
        "G21 G90 F100\nG0 X0 Y0 Z0 A30\nG92 A0\nG1 X20 A40\nM2\n",
        5.0,
    );
    let a: Vec<&str> = out
        .lines()
        .filter(|l| l.contains("X") && l.contains('A') && !l.starts_with("G0"))
        .collect();
    assert_eq!(a.len(), 4, "{out}");
    for (k, l) in a.iter().enumerate() {
        assert!(l.contains(&format!("A{}.0000", 10 * (k + 1))), "{l}");
    }
}

#[test]
fn incremental_extra_axes_are_split_into_increments_that_add_up() {
    // G91: X20 C-30 in four segments: C-7.5 each, summing to C-30.
    let out = compensate("G21 G90 F100\nG0 X0 Y0 Z0\nG91 G1 X20 C-30 B1\nM2\n", 5.0);
    let segs: Vec<&str> = out.lines().filter(|l| l.contains("X5.0000")).collect();
    assert_eq!(segs.len(), 4, "{out}");
    for s in &segs {
        assert!(s.contains("C-7.5000") && s.contains("B0.2500"), "{s}");
    }
}

#[test]
fn an_arc_with_a_moves_a_linearly_over_its_chords() {
    // A half circle of radius 10 with A 0 → 180: at every chord end the A
    // value is 180 · (chord end angle / π), within the rounding of 4 decimals.
    let out = compensate(
        "G21 G90 F100\nG0 X10 Y0 Z0 A0\nG3 X-10 Y0 I-10 J0 A180\nM2\n",
        1000.0,
    );
    let mut n = 0;
    for l in out
        .lines()
        .filter(|l| l.contains('A') && !l.starts_with("G0"))
    {
        let num = |c: char| -> f64 {
            let i = l.find(c).unwrap() + 1;
            let t: String = l[i..]
                .chars()
                .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-')
                .collect();
            t.parse().unwrap()
        };
        let (x, a) = (num('X'), num('A'));
        let y = if l.contains('Y') { num('Y') } else { 0.0 };
        let angle = y.atan2(x).to_degrees().rem_euclid(360.0);
        assert!((a - angle).abs() < 2e-3, "{l}: angle {angle}");
        n += 1;
    }
    assert!(n > 100, "{out}");
    assert!(out.contains("X-10.0000 Y0.0000 A180.0000") || out.contains("X-10.0000 A180.0000"));
}

#[test]
fn a_spline_becomes_g1_segments_and_keeps_its_other_words() {
    let out = compensate(
        "G21 G90\nG0 X0 Y0 Z0\nG5.1 I0 J10 X20 Y0 F300 (curve)\nG1 X30\nM2\n",
        1000.0,
    );
    assert!(!out.contains("G5"), "{out}");
    assert!(out.contains("F300 (curve)"), "{out}");
    let seg: Vec<&str> = out.lines().filter(|l| l.contains("spline)")).collect();
    assert!(seg.len() > 10);
    // Control points (0,0), (0,10), (20,0): x = 20u², y = 20u(1 − u).
    // Every written point lies on the curve to the written resolution.
    let curve: Vec<(f64, f64)> = (0..=20_000)
        .map(|k| {
            let u = k as f64 / 20_000.0;
            (20.0 * u * u, 20.0 * u * (1.0 - u))
        })
        .collect();
    let (mut x, mut y) = (0.0, 0.0);
    for l in &seg {
        let num = |c: char| -> Option<f64> {
            let i = l.find(c)? + 1;
            let t: String = l[i..]
                .chars()
                .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-')
                .collect();
            t.parse().ok()
        };
        x = num('X').unwrap_or(x);
        y = num('Y').unwrap_or(y);
        let dist = |u: f64| (20.0 * u * u - x).hypot(20.0 * u * (1.0 - u) - y);
        let k = (0..curve.len())
            .min_by(|a, b| {
                let da = (curve[*a].0 - x).hypot(curve[*a].1 - y);
                let db = (curve[*b].0 - x).hypot(curve[*b].1 - y);
                da.total_cmp(&db)
            })
            .unwrap();
        // Refine around the nearest sample (ternary search).
        let (mut lo, mut hi) = ((k as f64 - 1.0) / 20_000.0, (k as f64 + 1.0) / 20_000.0);
        for _ in 0..100 {
            let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
            if dist(m1) < dist(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        let d = dist(0.5 * (lo + hi));
        assert!(d < 1e-4, "{l}: {d} mm from the curve");
    }
    assert!(seg.last().unwrap().starts_with("X20.0000 Y0.0000"));
}

#[test]
fn nurbs_control_point_lines_lose_their_spline_words() {
    let out = compensate(
        "G21 G90 F100\nG0 X0 Y0 Z0\nG5.2 X0 Y10 P1 L3 M8\nX10 Y10 P1\nX10 Y0 P1\nG5.3\nM2\n",
        1000.0,
    );
    assert!(!out.contains("G5") && !out.contains('P'), "{out}");
    assert!(out.lines().any(|l| l.trim() == "M8"), "{out}");
    assert!(
        out.contains("X10.0000 Y0.0000 (volcomp L6 spline)"),
        "{out}"
    );
}

#[test]
fn a_program_stop_on_a_spline_block_runs_after_its_segments() {
    let out = compensate("G21 G90 F100\nG0 X0 Y0 Z0\nG5.1 I0 J10 X20 Y0 M2\n", 1000.0);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(*lines.last().unwrap(), "M2", "{out}");
    assert!(
        lines[lines.len() - 2].starts_with("X20.0000 Y0.0000"),
        "{out}"
    );
}

/// A map that shifts every point by +5 µm in X: every compensated X
/// command is the target less 5 µm.
fn shift_map() -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    csv.push_str("X,both,-10000,5,0,0\nX,both,10000,5,0,0\n");
    for axis in ["Y", "Z"] {
        csv.push_str(&format!(
            "{axis},both,-10000,0,0,0\n{axis},both,10000,0,0,0\n"
        ));
    }
    AxisTableMap::from_csv(&csv, "shift.csv").unwrap()
}

#[test]
fn spindle_synchronised_moves_are_written_as_they_are_and_followed_in_g91() {
    // G33 is sent as written (its pitch ties Z to the spindle). Under G91
    // it moves from where the compensated rapid left the machine
    // (X9.995), so the next increment to the nominal X11 - 5 µm is 1.
    let program =
        "G21 G90\nG0 X10 Y0 Z0\nS100 M3\nG91 G33 Z-5 K1\nG1 X1 F100\nG90 G33.1 Z-8 K1\nM2\n";
    let out = compensate_with(program, &shift_map(), Segmentation::Off);
    let lines: Vec<&str> = out.lines().filter(|l| !l.starts_with('(')).collect();
    assert_eq!(lines[1], "G0 X9.9950 Y0 Z0", "{out}");
    assert_eq!(lines[3], "G91 G33 Z-5 K1", "{out}");
    assert!(
        lines[4] == "G1 X1 F100" || lines[4] == "G1 X1.0000 F100",
        "{out}"
    );
    assert_eq!(lines[5], "G90 G33.1 Z-8 K1", "{out}");
}

#[test]
fn in_lathe_diameter_mode_compensated_x_words_are_diameters() {
    // G7: X40 is the radius 20; the +5 µm map makes the command 19.995,
    // written as the diameter 39.9900; under G91 the increment to the
    // nominal radius 18 (diameter 36, X-4) is written doubled too, and G8
    // writes radii again.
    let program = "G21 G18 G90 F100\nG0 X50 Y0 Z0\nG7 G1 X40 Z-1\nG91 X-4\nG90 G8 X30\nM2\n";
    let out = compensate_with(program, &shift_map(), Segmentation::Off);
    let lines: Vec<&str> = out.lines().filter(|l| !l.starts_with('(')).collect();
    assert_eq!(lines[1], "G0 X49.9950 Y0 Z0", "{out}");
    assert_eq!(lines[2], "G7 G1 X39.9900 Z-1", "{out}");
    assert!(lines[3] == "G91 X-4" || lines[3] == "G91 X-4.0000", "{out}");
    assert_eq!(lines[4], "G90 G8 X29.9950", "{out}");
}
