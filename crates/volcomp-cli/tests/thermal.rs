//! `volcomp thermal …` as a user meets it: example → fit → predict → the
//! predicted model drives `compensate`; bad input is located.

use crate::common;
use common::{ok, read, tempdir, write};

#[test]
fn example_fit_predict_compensate_plot() {
    let d = tempdir("flow");
    ok(&common::run(&d, "thermal example -o ex"));
    let out = ok(&common::run(&d, "thermal fit --measurements ex/measurements_train.csv --temperatures ex/temperatures_train.csv --artifact ex/artifact.csv --ranges-mm 0:600,0:400,0:300 --bands bands.csv -o thermal.toml"));
    // The bands: 3 lines × 41 points × 3 components, each a 95 % interval
    // around the estimate with a positive spread.
    let bands = read(&d, "bands.csv");
    let rows: Vec<&str> = bands.lines().skip(1).collect();
    assert_eq!(rows.len(), 3 * 41 * 3);
    for r in rows {
        let f: Vec<f64> = r.split(',').skip(3).map(|v| v.parse().unwrap()).collect();
        let (est, std, lo, hi) = (f[0], f[1], f[2], f[3]);
        assert!(lo <= est + 1e-9 && est <= hi + 1e-9 && std >= 0.0, "{r}");
    }
    // Order 2 on the seed chain with the probe at the measuring point: the
    // rotations of Y about Z and every rotation of Z act on nothing the probe sees.
    assert!(out.contains("rank 25 of 33"), "{out}");
    assert!(
        out.contains("ECY.P1, ECY.P2, EAZ.P1, EAZ.P2, EBZ.P1, EBZ.P2, ECZ.P1, ECZ.P2"),
        "{out}"
    );
    ok(&common::run(&d, "thermal predict --model thermal.toml --temperatures ex/temperatures_check.csv --cycle 6 -o predicted.toml"));
    assert!(d.join("predicted.csv").exists());
    write(
        &d,
        "p.ngc",
        "G21 G90 G17\nG0 X10 Y10 Z50\nG1 X500 Y300 Z100 F1000\nM2\n",
    );
    common::run_all(
        &d,
        &[
            "compensate --map predicted.toml -o out.ngc p.ngc",
            "thermal plot --model thermal.toml -o t.svg",
        ],
    );
    assert!(read(&d, "t.svg").contains("<svg"));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_inputs_are_located() {
    let d = tempdir("bad");
    ok(&common::run(&d, "thermal example -o ex"));
    write(&d, "a.csv", "sphere,distance_mm\n1,0\n2,50\n3,x\n");
    let o = common::run(&d, "thermal fit --measurements ex/measurements_train.csv --temperatures ex/temperatures_train.csv --artifact a.csv --ranges-mm 0:600,0:400,0:300 -o t.toml");
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("a.csv:4:2:") && e.contains("help:"), "{e}");
    // Missing temperatures for a measured cycle.
    write(
        &d,
        "t.csv",
        "cycle,time_h,bed_C,column_C,ambient_C\n0,0,20,20,20\n",
    );
    let o = common::run(&d, "thermal fit --measurements ex/measurements_train.csv --temperatures t.csv --artifact ex/artifact.csv --ranges-mm 0:600,0:400,0:300 -o t.toml");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("no temperatures for measurement cycle 1"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
