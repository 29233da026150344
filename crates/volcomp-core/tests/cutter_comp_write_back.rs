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

/// Under the bundled example map, the compensated tool-centre path, run on
/// the machine and paired with the original (`--reference`), is at least
/// five times closer to LinuxCNC's tool-centre path than the original run
/// uncompensated (the criterion of the library's front-door example).
#[test]
fn compensation_shrinks_the_contour_error_of_a_compensated_path() {
    use std::path::Path;
    use volcomp_core::prelude::*;
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data");
    let model = load_model(&data.join("map.csv"), &LoadOptions::default())
        .unwrap()
        .into_model();
    let machine = MachineSetup::from_setup_toml(
        "units = \"mm\"\nstart = [10, 10, 10]\n[tool_diameters]\n3 = 6\n[tools]\n3 = 50\n",
        "s.toml",
    )
    .unwrap();
    let program = b"G21 G90 F600\nT3 M6\nG43 H3\nG0 X40 Y20 Z20\nG42 D3 G1 X60 Y20\nY60\nG2 X100 Y60 R20\nG1 Y20\nX60\nG40 G0 X40 Y10\nM2\n";
    let mut compensated = Vec::new();
    Compensator::new(model.as_ref())
        .setup(machine.clone())
        .run(program.as_slice(), &mut compensated)
        .unwrap();
    let before = Simulation::new(model.as_ref())
        .setup(machine.clone())
        .run(program.as_slice())
        .unwrap();
    let after = Simulation::new(model.as_ref())
        .setup(machine)
        .reference(program.as_slice())
        .run(compensated.as_slice())
        .unwrap();
    assert!(before.contour_max_um > 1.0, "{before:?}");
    assert!(
        after.contour_max_um < before.contour_max_um / 5.0,
        "before {:.3} µm, after {:.3} µm",
        before.contour_max_um,
        after.contour_max_um
    );
}

/// After G40 the machine stands at the tool-centre point, and LinuxCNC's G53
/// move keeps the programmed point of the axes it does not name (the
/// interpreter's G53 here goes from the tool centre X9 Y10 to X10 Y10, as
/// rs274 does on LinuxCNC's mmount.ngc): the G53 line written as it was
/// would leave X at the tool centre, so it gains an X word (Y is where it
/// was and stays unwritten).
#[test]
fn a_g53_move_after_g40_keeps_the_programmed_point() {
    let program =
        "G21 G90 F100\nG0 X0 Y-5 Z5\nG41.1 D2 G1 X0 Y0\nX10\nY10\nG0 Z6\nG40\nG53 G0 Z0\nM2\n";
    let text = compensate(program);
    let g53 = text.lines().find(|l| l.contains("G53")).unwrap();
    assert!(g53.contains("X10") && !g53.contains('Y'), "{text}");
    let end = |p: &str| {
        let mut w = Walker::new(
            Cursor::new(p.as_bytes().to_vec()),
            None,
            Setup::default(),
            InterpOptions::default(),
        );
        let mut last = None;
        while let Some(ev) = w.next_line().unwrap() {
            if let Some(m) = ev.motions.last() {
                last = Some(m.end);
            }
        }
        last.unwrap()
    };
    let (a, b) = (end(program), end(&text));
    assert_eq!([a.x, a.y, a.z], [10.0, 10.0, 0.0]);
    assert_eq!([b.x, b.y, b.z], [10.0, 10.0, 0.0], "{text}");
}
