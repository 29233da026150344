//! Compensated lines stay within LinuxCNC's 252 characters ("Command too
//! long", `Interp::read_text`, src/emc/rs274ngc/interp_read.cc), and values
//! computed from expressions are written like the program's numbers, not
//! with 17 digits. Checked against LinuxCNC's `rs274` when it is installed.

use crate::common;

use volcomp_core::compensate::Compensator;
use volcomp_core::model::axis_table::AxisTableMap;

/// A map of small ripples, so every coordinate is rewritten.
fn ripple_map() -> AxisTableMap {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for axis in ["X", "Y", "Z"] {
        for k in -20..=20 {
            let p = f64::from(k) * 10.0;
            let e = 3.0 * (p / 7.0).sin();
            csv.push_str(&format!("{axis},both,{p},{e:.4},{e:.4},{e:.4}\n"));
        }
    }
    AxisTableMap::from_csv(&csv, "ripple.csv").unwrap()
}

fn compensate(program: &str) -> String {
    let map = ripple_map();
    let mut out = Vec::new();
    Compensator::new(&map)
        .file_name("p.ngc")
        .run(program.as_bytes(), &mut out)
        .unwrap_or_else(|e| panic!("{e}"));
    String::from_utf8(out).unwrap()
}

/// rs274's error on `program`, `None` when it accepts it; skipped (`Some(None)`
/// never) when rs274 is not installed.
fn rs274_refusal(program: &str) -> Option<Option<String>> {
    common::rs274_refusal(program, "the line lengths on rs274")
}

#[test]
fn a_long_comment_moves_to_its_own_line_and_every_line_stays_within_252() {
    // 252 characters: within the limit as written; the compensated
    // coordinates (five decimals instead of one) push it past.
    let words = "G1 X10.5 Y20.5 Z-1.5 ";
    let comment = format!("({})", "n".repeat(252 - words.len() - 2));
    let line = format!("{words}{comment}");
    assert_eq!(line.len(), 252);
    let program = format!("G21 G90 G17\nG0 X0 Y0 Z5\nF100\n{line}\nG0 Z5\nM2\n");
    if let Some(verdict) = rs274_refusal(&program) {
        assert_eq!(verdict, None, "rs274 refuses the original");
    }
    let out = compensate(&program);
    for l in out.lines() {
        assert!(l.len() <= 252, "a line of {} characters: {l}", l.len());
    }
    // The comment stands alone, just before the block that had it.
    let lines: Vec<&str> = out.lines().collect();
    let at = lines
        .iter()
        .position(|l| *l == comment)
        .expect("the comment on its own line");
    assert!(lines[at + 1].starts_with("G1 X"), "{}", lines[at + 1]);
    if let Some(verdict) = rs274_refusal(&out) {
        assert_eq!(
            verdict, None,
            "rs274 refuses the compensated program:\n{out}"
        );
    }
}

#[test]
fn computed_values_are_written_with_the_programs_decimals() {
    let program = "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z-1 F[1000/3]\nG1 X[10/3] S[2/3]\nM2\n";
    let out = compensate(program);
    // F, S: the value to 5 decimals (mm), not the 17 digits of 1000/3.
    assert!(out.contains("F333.33333"), "{out}");
    assert!(!out.contains("333.333333"), "{out}");
    assert!(out.contains("S0.66667"), "{out}");
    if let Some(verdict) = rs274_refusal(&out) {
        assert_eq!(
            verdict, None,
            "rs274 refuses the compensated program:\n{out}"
        );
    }
}
