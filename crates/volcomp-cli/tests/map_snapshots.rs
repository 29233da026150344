//! Snapshots of `volcomp map` output a person reads: the evaluation table
//! and a located error in a bad map file (caret under the bad field).
//! The numbers are also checked against a hand calculation, so a snapshot
//! accepted by mistake would still fail.

use crate::common;
use common::{tempdir, write};

/// Axis tables over 0…100 mm, linear from zero: X gives (2, 1, 0) µm at
/// 100 mm, Y (0, 4, 0), Z (0, 0, −6); the reverse X table is twice the forward.
const MAP: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um
X,forward,0,0,0,0
X,forward,100,2,1,0
X,reverse,0,0,0,0
X,reverse,100,4,2,0
Y,both,0,0,0,0
Y,both,100,0,4,0
Z,both,0,0,0,0
Z,both,100,0,0,-6
";

#[test]
fn eval_of_axis_tables() {
    let dir = tempdir("eval_tables");
    write(&dir, "m.csv", MAP);
    let o = common::run(&dir, "map eval m.csv --at 50,25,100");
    common::ok(&o);
    let text = String::from_utf8(o.stdout).unwrap();
    // By hand: X half way (1, 0.5, 0), Y a quarter (0, 1, 0), Z at its end
    // (0, 0, −6): e = (1, 1.5, −6), |e| = √39.25 = 6.2650 µm.
    assert!(
        text.contains("+1.0000  +1.5000  -6.0000 µm   |e| 6.2650 µm"),
        "{text}"
    );
    insta::assert_snapshot!("eval_axis_tables", text);
    // Reverse X: twice the forward table.
    let o = common::run(&dir, "map eval m.csv --at 50,25,100 --direction rff");
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("  X table  +2.0000  +1.0000  +0.0000 µm"),
        "{text}"
    );
    insta::assert_snapshot!("eval_axis_tables_reverse_x", text);
}

#[test]
fn bad_map_csv_points_at_the_field() {
    let dir = tempdir("bad_csv");
    write(
        &dir,
        "m.csv",
        MAP.replace("X,forward,100,2,1,0", "X,forward,1OO,2,1,0"),
    );
    let o = common::run(&dir, "map eval m.csv --at 0,0,0");
    assert_eq!(o.status.code(), Some(2));
    let text = String::from_utf8(o.stderr).unwrap();
    // Row 3 of the file, field 3 (position_mm).
    assert!(text.contains("m.csv:3:3:"), "{text}");
    insta::assert_snapshot!("bad_map_csv", text);
}

#[test]
fn unknown_model_kind_lists_the_known_ones() {
    let dir = tempdir("unknown_kind");
    write(&dir, "m.toml", "# a model\nmodel = \"thermal-9\"\n");
    let o = common::run(&dir, "map eval m.toml --at 0,0,0");
    assert_eq!(o.status.code(), Some(2));
    let text = String::from_utf8(o.stderr).unwrap();
    // Row 2, column 9: the opening quote of the value.
    assert!(text.contains("m.toml:2:9:"), "{text}");
    assert!(
        text.contains("\"kinematic-21\", \"straightness\""),
        "{text}"
    );
    insta::assert_snapshot!("unknown_model_kind", text);
}
