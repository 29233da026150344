//! Cutter radius compensation written back (docs/gcode.md, "Cutter radius
//! compensation", "Writing back"): under a map of zeros and without
//! splitting, the written program is the tool-centre path as G0/G1 moves
//! under G40, with no G41/G42 or D word left for the controller to offset
//! again. The expected moves are derived by hand for a 2 mm tool on the
//! left of a counter-clockwise square (the same program as the
//! interpreter's test `cutter_comp.rs`).

use std::io::Cursor;
use volcomp_core::compensate::{compensate_program, survey_style, CompensateOptions, Segmentation};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_gcode::{InterpOptions, Setup, Walker};

fn zero_map() -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for axis in ["X", "Y", "Z"] {
        csv.push_str(&format!(
            "{axis},both,-10000,0,0,0\n{axis},both,10000,0,0,0\n"
        ));
    }
    AxisTableMap::from_csv(&csv, "zero.csv").unwrap()
}

fn compensate(program: &str) -> String {
    let bytes = program.as_bytes().to_vec();
    let mut walker = Walker::new(
        Cursor::new(bytes.clone()),
        Some("t.ngc".into()),
        Setup::default(),
        InterpOptions::default(),
    );
    let options = CompensateOptions {
        segmentation: Segmentation::Off,
        ..CompensateOptions::default()
    };
    let mut out = Vec::new();
    compensate_program(
        &mut walker,
        "t.ngc",
        &zero_map(),
        &survey_style(&bytes),
        &options,
        &mut out,
        |_| {},
    )
    .unwrap();
    String::from_utf8(out).unwrap()
}

/// The (x, y) of every written move line, in order (a line with X or Y).
fn xy_moves(text: &str) -> Vec<(f64, f64)> {
    let (mut x, mut y) = (0.0, 0.0);
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.split('(').next().unwrap().to_ascii_uppercase();
        let word = |l: char| -> Option<f64> {
            let i = code.find(l)?;
            let rest = &code[i + 1..];
            let end = rest
                .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
                .unwrap_or(rest.len());
            rest[..end].parse().ok()
        };
        let (nx, ny) = (word('X'), word('Y'));
        if nx.is_some() || ny.is_some() {
            x = nx.unwrap_or(x);
            y = ny.unwrap_or(y);
            out.push((x, y));
        }
    }
    out
}

#[test]
fn tool_centre_path_is_written_under_g40() {
    let text =
        compensate("G21 G90 F100\nG0 X0 Y-5\nG41.1 D2 G1 X0 Y0\nX10\nY10\nG40 G1 X20 Y20\nM2\n");
    let upper = text.to_ascii_uppercase();
    for gone in ["G41", "D2"] {
        assert!(!upper.contains(gone), "{gone} left in:\n{text}");
    }
    let moves = xy_moves(&text);
    // Rapid to (0,-5); entry to (-1,0); the convex corner's arc about (0,0)
    // from (-1,0) to (0,1), linearised: its points lie 1 mm from (0,0);
    // the side to the concave corner (9,1); up to (9,10); exit to (20,20).
    assert_eq!(moves[0], (0.0, -5.0), "{text}");
    assert_eq!(moves[1], (-1.0, 0.0), "{text}");
    let n = moves.len();
    assert_eq!(
        &moves[n - 3..],
        &[(9.0, 1.0), (9.0, 10.0), (20.0, 20.0)],
        "{text}"
    );
    let arc = &moves[2..n - 3];
    assert!(!arc.is_empty(), "{text}");
    assert_eq!(*arc.last().unwrap(), (0.0, 1.0));
    for (x, y) in arc {
        assert!(
            (x.hypot(*y) - 1.0).abs() < 1e-4,
            "({x}, {y}) off the corner arc"
        );
    }
}
