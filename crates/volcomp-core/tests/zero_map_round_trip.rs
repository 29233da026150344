//! A map of zeros changes nothing: with `--no-split` every line of a real
//! program that holds no arc and no canned cycle comes back byte for byte.
//! Arcs are linearised and cycles expanded, so those lines (and the lines
//! volcomp inserts after them, tagged `(volcomp Ln)`) are the only ones that
//! may differ.
//!
//! The programs are the licensed real programs bundled in `tests/corpus/`.

use std::collections::BTreeSet;
use std::io::Cursor;
use std::path::PathBuf;
use volcomp_core::compensate::{compensate_program, survey_style, CompensateOptions, Segmentation};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_gcode::{InterpOptions, MotionKind, MotionSource, Setup, Walker};

const CORPUS: [&str; 11] = [
    "winder__Universal-G-Code-Sender__Gates_combined_R12.nc",
    "winder__Universal-G-Code-Sender__communicator.nc",
    "winder__Universal-G-Code-Sender__ShapeOko_Calibration_Pattern_01b.ngc",
    "winder__Universal-G-Code-Sender__arc_rword_test.gcode",
    "CauldronDevelopmentLLC__CAMotics__tiger.nc",
    "CauldronDevelopmentLLC__CAMotics__cameo.nc",
    "CauldronDevelopmentLLC__CAMotics__flower_mold.nc",
    "CauldronDevelopmentLLC__CAMotics__botomata_bottom.nc",
    "CauldronDevelopmentLLC__CAMotics__vcarve.ngc",
    "MaestroFusion360__easy_gcode_plot__PARALLEL.NC",
    "MaestroFusion360__easy_gcode_plot__BOTTLE.NC",
];

fn corpus_file(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/corpus")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

use crate::common;
use common::zero_map;

fn setup() -> Setup {
    let mut s = Setup::default();
    for t in 0..=20 {
        s.tool_lengths_mm.insert(t, 50.0);
    }
    s
}

fn options(name: &str) -> InterpOptions {
    InterpOptions {
        // BOTTLE.NC was posted with absolute arc centres and no G90.1.
        absolute_arc_centers: name.ends_with("BOTTLE.NC"),
        ..InterpOptions::default()
    }
}

/// Lines whose motions are arcs or canned-cycle moves.
fn arc_and_cycle_lines(name: &str, bytes: &[u8]) -> BTreeSet<u64> {
    let mut w = Walker::new(Cursor::new(bytes.to_vec()), None, setup(), options(name));
    let mut lines = BTreeSet::new();
    while let Some(ev) = w.next_line().unwrap() {
        if ev
            .motions
            .iter()
            .any(|m| matches!(m.kind, MotionKind::Arc(_)) || m.source == MotionSource::Cycle)
        {
            lines.insert(ev.number);
        }
    }
    lines
}

fn is_inserted_for(line: &[u8], n: u64) -> bool {
    let tag = format!("(volcomp L{n}");
    line.windows(tag.len()).any(|w| w == tag.as_bytes())
        && matches!(
            line.get(
                line.windows(tag.len())
                    .position(|w| w == tag.as_bytes())
                    .unwrap()
                    + tag.len()
            ),
            Some(b')') | Some(b' ')
        )
}

#[test]
fn zero_map_without_splitting_gives_every_line_back_outside_arcs_and_cycles() {
    let map = zero_map();
    let compensate = CompensateOptions {
        segmentation: Segmentation::Off,
        ..CompensateOptions::default()
    };
    let mut checked = 0;
    for name in CORPUS {
        let bytes = corpus_file(name);
        let special = arc_and_cycle_lines(name, &bytes);
        let mut walker = Walker::new(
            Cursor::new(bytes.clone()),
            Some(name.into()),
            setup(),
            options(name),
        );
        let mut out = Vec::new();
        compensate_program(
            &mut walker,
            name,
            &map,
            &survey_style(&bytes[..bytes.len().min(1 << 16)]),
            &compensate,
            &mut out,
            |_| {},
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let original: Vec<&[u8]> = bytes.split_inclusive(|b| *b == b'\n').collect();
        let written: Vec<&[u8]> = out.split_inclusive(|b| *b == b'\n').collect();
        let mut k = 0;
        for (i, line) in original.iter().enumerate() {
            let n = i as u64 + 1;
            assert!(k < written.len(), "{name}: output ends before line {n}");
            if special.contains(&n) {
                k += 1;
                while k < written.len() && is_inserted_for(written[k], n) {
                    k += 1;
                }
                continue;
            }
            assert_eq!(
                String::from_utf8_lossy(written[k]),
                String::from_utf8_lossy(line),
                "{name}:{n} changed under a zero map"
            );
            k += 1;
            checked += 1;
        }
        assert_eq!(k, written.len(), "{name}: extra lines at the end");
    }
    // The eleven programs hold about 160 000 lines outside arcs and cycles.
    assert!(checked > 100_000, "only {checked} lines compared");
}

#[test]
fn inch_program_with_six_decimals_keeps_them() {
    // vcarve.ngc is in inch with 6 decimals (`Y 0.096205`); inch programs
    // were once written with 5 by default, which dropped the sixth digit.
    let program = "G20 G90 G1 F10\nX 0.0238 Y 0.096205 Z-0.012345\nX1.5 Y0.25\n";
    let map = zero_map();
    let options = CompensateOptions {
        segmentation: Segmentation::Off,
        ..CompensateOptions::default()
    };
    assert_eq!(compensate_text_with(program, &map, &options), program);
}

/// A map whose error is `ex_um` in X everywhere (−1000 … 1000 mm).
fn x_shift_map(ex_um: f64) -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for axis in ["X", "Y", "Z"] {
        let ex = if axis == "X" { ex_um } else { 0.0 };
        csv.push_str(&format!(
            "{axis},both,-1000,{ex},0,0\n{axis},both,1000,{ex},0,0\n"
        ));
    }
    AxisTableMap::from_csv(&csv, "shift.csv").unwrap()
}

#[test]
fn a_rewritten_word_never_has_fewer_decimals_than_the_original() {
    // --decimals 3 asks for fewer digits than the program's 6: a word that
    // must change is still written with its own 6 (a shift of 2 µm in X).
    let map = x_shift_map(-2.0);
    let program = "G21 G90 G1 F100 Z0\nX10.123456 Y5.000001\n";
    let text = compensate_text_with(
        program,
        &map,
        &CompensateOptions {
            segmentation: Segmentation::Off,
            decimals: Some(3),
            ..CompensateOptions::default()
        },
    );
    // e_x = −2 µm everywhere, so the command is X + 0.002 mm: 10.125456.
    assert_eq!(text, "G21 G90 G1 F100 Z0\nX10.125456 Y5.000001\n");
}

#[test]
fn polar_moves_are_kept_or_written_back_on_the_compensated_point() {
    // Unchanged under a zero map: the polar words stay as written.
    for program in [
        "G21 G90 G0 Z0\nG1 F100 @10 ^0\n",
        "G21 G90 G0 X5 Y0 Z0\nG91 G1 F100 @5\nG1 ^90\n",
    ] {
        assert_eq!(compensate_text(program, &zero_map()), program);
    }
    // e_x = −2 µm everywhere: the command is the target + 0.002 mm in X, and
    // the polar words give way to that command's X and Y.
    let map = x_shift_map(-2.0);
    // Target (10, 0, 0): X10.0020 Y0.0000.
    assert_eq!(
        compensate_text("G21 G90 G0 Z0\nG1 F100 @10 ^0\n", &map),
        "G21 G90 G0 Z0\nG1 F100 X10.0000 Y0.0000\n".replace("X10.0000", "X10.0020")
    );
    // G91: from the (compensated) start X5.002 to the target (10, 0): the
    // command 10.002 is 5.0000 further, Y stays 0.
    assert_eq!(
        compensate_text("G21 G90 G0 X5 Y0 Z0\nG91 G1 F100 @5\n", &map),
        "G21 G90 G0 X5.0020 Y0 Z0\nG91 G1 F100 X5.0000 Y0.0000\n"
    );
    // G91 `^90` turns the start about the origin: from the compensated start
    // (5.002, 0) it would land on (0, 5.002), not on the command (0.002, 5),
    // although the target (0, 5) needs no correction in Y. So it is rewritten:
    // X 0.002 − 5.002 = −5, Y 5.
    assert_eq!(
        compensate_text("G21 G90 G0 X5 Y0 Z0\nG91 G1 F100 ^90\n", &map),
        "G21 G90 G0 X5.0020 Y0 Z0\nG91 G1 F100 X-5.0000 Y5.0000\n"
    );
}

/// Compensates `program` (named `t.ngc`, default set-up) and returns the
/// written text.
fn compensate_text_with(program: &str, map: &AxisTableMap, options: &CompensateOptions) -> String {
    let mut out = Vec::new();
    compensate_program(
        &mut Walker::new(
            Cursor::new(program.as_bytes().to_vec()),
            None,
            Setup::default(),
            InterpOptions::default(),
        ),
        "t.ngc",
        map,
        &survey_style(program.as_bytes()),
        options,
        &mut out,
        |_| {},
    )
    .unwrap();
    String::from_utf8(out).unwrap()
}

/// [`compensate_text_with`] without splitting.
fn compensate_text(program: &str, map: &AxisTableMap) -> String {
    compensate_text_with(
        program,
        map,
        // The words expected are written with 4 decimals (0.1 µm).
        &CompensateOptions {
            segmentation: Segmentation::Off,
            decimals: Some(4),
            ..CompensateOptions::default()
        },
    )
}
