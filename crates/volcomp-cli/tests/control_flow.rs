//! A program with parameters, a subroutine and nested loops is compensated
//! as its executed path (docs/gcode.md, "How such programs are written
//! back"), and the flat program it becomes is measured against the
//! original, line by line, through the `(volcomp Ln)` pairing.

use crate::common;
use common::{read, tempdir, text, volcomp, write};

/// `contour error … max <v> µm` of `simulate`'s table.
fn contour_max_um(out: &str) -> f64 {
    let line = out
        .lines()
        .find(|l| l.starts_with("contour error"))
        .unwrap_or_else(|| panic!("no contour line in {out}"));
    let after = line.split("max").nth(1).unwrap();
    after.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn loops_and_calls_are_compensated_as_their_executed_path() {
    let d = tempdir("control-flow");
    // A ripple of 3 µm (own axis) and 1 µm (the others), 40/30/25 mm waves.
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, axis, period) in [(0, "X", 40.0), (1, "Y", 30.0), (2, "Z", 25.0)] {
        for k in -100..=200 {
            let p = f64::from(k) * 2.0;
            let w = (2.0 * std::f64::consts::PI * p / period).sin();
            let mut e = [w; 3];
            e[a] = 3.0 * w;
            csv.push_str(&format!("{axis},both,{p},{},{},{}\n", e[0], e[1], e[2]));
        }
    }
    write(&d, "map.csv", csv);
    let program = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/rs274/ngc_tiled_sub.ngc"),
    )
    .unwrap();
    // In G61: under G64 (a program that sets no mode) no split is made
    // inside a corner's blend zone, which LinuxCNC rounds anyway, and the
    // simulator, which does not blend, sees the map's ripple there.
    write(&d, "p.ngc", format!("G61\n{program}"));
    let off = ["--work-offset", "100,100,0"];
    let o = volcomp(
        &[
            "compensate",
            "p.ngc",
            "--map",
            "map.csv",
            "-o",
            "out.ngc",
            off[0],
            off[1],
        ],
        &d,
    );
    assert!(o.status.success(), "{}", text(&o));
    let out = read(&d, "out.ngc");
    // Flat: no parameter, expression or o-word is left outside comments.
    for line in out.lines() {
        let code = line.split(['(', ';']).next().unwrap();
        assert!(
            !code.contains('#') && !code.contains('[') && !code.trim_start().starts_with('o'),
            "not flat: {line}"
        );
    }
    // The subroutine ran four times (2 × 2 tiles): four plunges.
    assert_eq!(out.matches("F50.").count(), 4, "{out}");
    let before = volcomp(
        &["simulate", "p.ngc", "--map", "map.csv", off[0], off[1]],
        &d,
    );
    assert!(before.status.success(), "{}", text(&before));
    let after = volcomp(
        &[
            "simulate",
            "out.ngc",
            "--reference",
            "p.ngc",
            "--map",
            "map.csv",
            off[0],
            off[1],
        ],
        &d,
    );
    assert!(after.status.success(), "{}", text(&after));
    let (b, a) = (
        contour_max_um(&text(&before)),
        contour_max_um(&text(&after)),
    );
    // Uncompensated the ripple shows (≥ 3 µm somewhere); compensated, only
    // the written resolution (5 decimals in inch, 0.254 µm) remains.
    assert!(b > 3.0, "before {b}");
    assert!(a < 0.5, "after {a}");
}
