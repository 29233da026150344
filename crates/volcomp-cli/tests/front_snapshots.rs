//! Snapshots of what a person reads from `volcomp simulate` (its table) and
//! `volcomp compensate` (a refusal with its caret). The figures are also
//! checked against a hand calculation, so a snapshot accepted by mistake
//! would still fail.

use crate::common;
use common::{stderr, tempdir, write};

/// Every X position is 3 µm off in +Y; Y and Z have no error.
const MAP: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um
X,both,0,0,3,0
X,both,100,0,3,0
Y,both,0,0,0,0
Y,both,100,0,0,0
Z,both,0,0,0,0
Z,both,100,0,0,0
";

#[test]
fn simulate_table() {
    let dir = tempdir("snap_simulate");
    write(&dir, "m.csv", MAP);
    write(&dir, "p.ngc", "G21 G90\nG0 X10 Y10 Z10\nG1 X60 F100\nM2\n");
    let text = common::ok(&common::run(
        &dir,
        "simulate p.ngc --map m.csv --work-offset 0,0,0",
    ));
    // By hand: the tool runs 3 µm off in Y along the whole feed move, so the
    // point error at its end and the contour error everywhere are 3 µm.
    let three = text.matches("3.000 µm").count();
    assert_eq!(three, 4, "point and contour RMS and max are 3 µm:\n{text}");
    assert!(text.contains("feed length         50.000 mm"), "{text}");
    insta::assert_snapshot!("simulate_table", text);
}

#[test]
fn compensate_refusal_with_caret() {
    let dir = tempdir("snap_refusal");
    write(&dir, "m.csv", MAP);
    write(&dir, "p.ngc", "G21 G90\nG0 X10 Y10 Z10\nG41 D1\nM2\n");
    let o = common::run(
        &dir,
        "compensate p.ngc --map m.csv --work-offset 0,0,0 -o out.ngc",
    );
    let msg = stderr(&o);
    // A refused program (docs/errors.md, "Exit codes"), located at line 3,
    // column 5 (the D word: tool 1 has no diameter in the set-up, which
    // cutter radius compensation needs), nothing written.
    assert_eq!(o.status.code(), Some(3), "{msg}");
    assert!(msg.contains("p.ngc:3:5:"), "{msg}");
    assert!(!dir.join("out.ngc").exists());
    insta::assert_snapshot!("compensate_refusal_with_caret", msg);
}
