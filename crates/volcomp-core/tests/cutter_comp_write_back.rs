//! Cutter radius compensation written back (docs/gcode.md, "Cutter radius
//! compensation", "Writing back"): under a map of zeros and without
//! splitting, the written program is the tool-centre path as G0/G1/G2/G3
//! moves under G40, with no G41/G42 or D word left for the controller to offset
//! again. The expected moves are derived by hand for a 2 mm tool on the
//! left of a counter-clockwise square (the same program as the
//! interpreter's test `cutter_comp.rs`).

use std::io::Cursor;
use volcomp_core::compensate::{CompensateOptions, Segmentation};
use volcomp_gcode::{InterpOptions, Setup, Walker};

use crate::common;

fn compensate(program: &str) -> String {
    let options = CompensateOptions {
        segmentation: Segmentation::Off,
        ..CompensateOptions::default()
    };
    common::compensate_text(program, "t.ngc", &common::zero_map(), &options).unwrap()
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
    // from (-1,0) to (0,1) (written as arc pieces, or linearised with
    // `arcs_as_arcs` off: its points lie 1 mm from (0,0));
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
/// uncompensated (the criterion of the library's front-door example). In
/// G61, so every take-up is exact: under G64 the folds may leave up to the
/// reversal value at a corner, by design (docs/compensation.md).
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
    let program = b"G21 G90 G61 F600\nT3 M6\nG43 H3\nG0 X40 Y20 Z20\nG42 D3 G1 X60 Y20\nY60\nG2 X100 Y60 R20\nG1 Y20\nX60\nG40 G0 X40 Y10\nM2\n";
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

/// The words of a written line: `(letter, value)` outside comments.
fn words(line: &str) -> Vec<(char, f64)> {
    let code = line.split('(').next().unwrap().to_ascii_uppercase();
    let mut out = Vec::new();
    let b = code.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        if c.is_ascii_alphabetic() {
            let s = i + 1;
            let mut e = s;
            while e < b.len() && (b[e].is_ascii_digit() || b[e] == b'.' || b[e] == b'-') {
                e += 1;
            }
            out.push((c, code[s..e].parse().unwrap()));
            i = e;
        } else {
            i += 1;
        }
    }
    out
}

/// Every written arc: `(clockwise, centre, radius at start, radius at end)`,
/// the centre from incremental I, J (LinuxCNC's default G91.1) added to the
/// arc's start, the point the lines before it end at (G90).
fn written_arcs(text: &str) -> Vec<(bool, (f64, f64), f64, f64)> {
    let (mut x, mut y) = (0.0, 0.0);
    let mut arcs = Vec::new();
    for line in text.lines() {
        let w = words(line);
        let get = |l: char| w.iter().find(|(c, _)| *c == l).map(|(_, v)| *v);
        let (nx, ny) = (get('X').unwrap_or(x), get('Y').unwrap_or(y));
        let g = |v: f64| w.iter().any(|(c, n)| *c == 'G' && *n == v);
        if g(2.0) || g(3.0) {
            let c = (x + get('I').unwrap(), y + get('J').unwrap());
            arcs.push((
                g(2.0),
                c,
                (x - c.0).hypot(y - c.1),
                (nx - c.0).hypot(ny - c.1),
            ));
        }
        (x, y) = (nx, ny);
    }
    arcs
}

/// A 40 × 40 mm square with corners rounded to 5 mm, cut counter-clockwise
/// with a 2 mm tool: with G41 (tool on the left, inside) a pocket, with
/// G42 (outside) a boss. The tool centre runs on the offset path: straight
/// sides 1 mm inside (outside), and the corners' offset arcs about the
/// same centres (±15, ±15) with radius 5 − 1 = 4 mm (5 + 1 = 6 mm),
/// counter-clockwise; the sides meet the arcs tangentially, so there is no
/// corner arc. Under a map of zeros every one of them is written as one
/// G3 with those centres and radii (to the written 0.1 µm), and the program
/// keeps one block per move: nothing is split.
#[test]
fn tool_centre_arcs_of_a_rounded_square_are_written_as_arcs() {
    let contour = "G1 X15 Y-20\nG3 X20 Y-15 I0 J5\nG1 X20 Y15\nG3 X15 Y20 I-5 J0\n\
                   G1 X-15 Y20\nG3 X-20 Y15 I0 J-5\nG1 X-20 Y-15\nG3 X-15 Y-20 I5 J0\n\
                   G1 X0 Y-20\n";
    let centres = [(15.0, -15.0), (15.0, 15.0), (-15.0, 15.0), (-15.0, -15.0)];
    for (side, start_y, radius) in [("G41.1", -10.0, 4.0), ("G42.1", -30.0, 6.0)] {
        let program = format!(
            "G21 G90 G17 F500\nG0 X0 Y{start_y} Z1\nG1 Z-1\n{side} D2 G1 X0 Y-20\n{contour}G40 G1 X0 Y{start_y}\nG0 Z1\nM2\n"
        );
        let text = compensate(&program);
        let arcs = written_arcs(&text);
        assert_eq!(arcs.len(), 4, "{side}:\n{text}");
        for ((cw, c, r0, r1), expected) in arcs.iter().zip(centres) {
            assert!(!cw, "{side}: a G2 in\n{text}");
            assert!(
                (c.0 - expected.0).abs() < 1e-9 && (c.1 - expected.1).abs() < 1e-9,
                "{side}: centre {c:?}, expected {expected:?}\n{text}"
            );
            assert!(
                (r0 - radius).abs() < 1e-9 && (r1 - radius).abs() < 1e-9,
                "{side}: radii {r0}, {r1}, expected {radius}\n{text}"
            );
        }
        // One written move per move of the input: the rapid, the plunge,
        // the entry, 4 sides, 4 arcs, the last half side, the exit and
        // the retract.
        let moves = |t: &str| {
            t.lines()
                .filter(|l| words(l).iter().any(|(c, _)| matches!(c, 'X' | 'Y' | 'Z')))
                .count()
        };
        assert_eq!(moves(&program), 14);
        assert_eq!(moves(&text), 14, "{side}:\n{text}");
        assert_eq!(
            text.lines().filter(|l| !l.starts_with('(')).count(),
            program.lines().count(),
            "{side}:\n{text}"
        );
        // The entry (down for G41, up for G42: its offset line is x = 1
        // either way) meets the first side's offset line y = −20 ± 1 in a
        // concave corner; that side ends where the offset arc starts, and
        // the arc ends on the next side's offset line x = 20 ∓ 1.
        let xy = xy_moves(&text);
        let off = if side == "G41.1" { 1.0 } else { -1.0 };
        assert_eq!(xy[1], (1.0, -20.0 + off), "{side}:\n{text}");
        assert_eq!(xy[2], (15.0, -20.0 + off), "{side}:\n{text}");
        assert_eq!(xy[3], (20.0 - off, -15.0), "{side}:\n{text}");
    }
}
