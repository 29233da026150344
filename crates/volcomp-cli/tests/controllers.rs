//! `volcomp map export` and `--controller`: a machine whose controller
//! applies a pitch table volcomp exported, compensated for the rest only.

use std::path::Path;

use crate::common;
use common::{json, ok, read, refused, tempdir, text, volcomp, write};

/// Axis tables of a machine with large pitch errors (a slope of 20 µm/m
/// and a 200 mm ball-screw wave of ±3 µm on X, similar on Y and Z) and
/// small straightness (≤ 1.2 µm), one table for both directions, every 25 mm.
fn write_map(dir: &Path) {
    let mut s = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    let tau = std::f64::consts::TAU;
    for (axis, len) in [("X", 600), ("Y", 400), ("Z", 300)] {
        for k in 0..=(len / 25) {
            let p = 25.0 * k as f64;
            let pitch = 0.02 * p + 3.0 * (tau * p / 200.0).sin();
            let straight = 1.2 * (p / len as f64) * (1.0 - p / len as f64) * 4.0;
            let (ex, ey, ez) = match axis {
                "X" => (pitch, straight, -0.5 * straight),
                "Y" => (0.5 * straight, pitch, straight),
                _ => (straight, -straight, pitch),
            };
            s.push_str(&format!("{axis},both,{p},{ex:.4},{ey:.4},{ez:.4}\n"));
        }
    }
    write(dir, "m.csv", s);
}

// Exact path (G61): these tests measure what the compensation leaves, so
// every reversal is taken up exactly rather than folded as G64 allows
// (docs/compensation.md, "Reversals by path-control mode").
const PART: &str = "G21 G90 G17 G61\nG0 X0 Y0 Z10\nG1 Z0 F500\nG1 X200 Y0\nG1 X200 Y150\nG2 X100 Y250 I-100 J0\nG1 X0 Y250\nG1 X0 Y0\nG0 Z10\nM2\n";

/// The Siemens EEC tables the hybrid tests export.
const EEC: &str = "eec/%_N_AX_EEC_INI";

/// A fresh folder `name` with the map (m.csv) and [`PART`] (part.ngc).
#[track_caller]
fn machine(name: &str) -> common::TempDir {
    let dir = tempdir(name);
    write_map(&dir);
    write(&dir, "part.ngc", PART);
    dir
}

/// `volcomp simulate PROGRAM` of [`PART`] at the tests' work offset, as JSON;
/// with `controller`, on a machine whose controller applies that file.
fn simulate(dir: &Path, program: &str, controller: Option<&str>) -> serde_json::Value {
    let mut args = vec![
        "simulate",
        program,
        "--map",
        "m.csv",
        "--work-offset",
        "100,100,50",
        "--json",
    ];
    if program != "part.ngc" {
        args.extend(["--reference", "part.ngc"]);
    }
    if let Some(c) = controller {
        args.extend(["--controller", c]);
    }
    json(&volcomp(&args, dir))
}

#[test]
fn only_the_residual_is_compensated_on_a_machine_with_a_pitch_table() {
    let dir = machine("hybrid");
    // The controller's table: Siemens EEC every 10 mm at its 1 µm resolution.
    ok(&common::run(
        &dir,
        "map export m.csv --to siemens-eec --step 10 -o eec",
    ));
    let comp = |out: &str, controller: bool| {
        let mut a = vec![
            "compensate",
            "part.ngc",
            "--map",
            "m.csv",
            "--work-offset",
            "100,100,50",
            "--decimals",
            "6",
            "--segment-length",
            "0.5",
            // Arcs linearised to 1 nm: the default 0.1 µm contour
            // tolerance (arcs as arcs or chords) would be most of what is
            // left of a residual this small.
            "--arcs-as-lines",
            "--chord-tolerance",
            "0.000001",
            "-o",
            out,
        ];
        if controller {
            a.extend(["--controller", EEC]);
        }
        ok(&volcomp(&a, &dir));
    };
    comp("hybrid.ngc", true);
    comp("twice.ngc", false);
    // The machine is the map with the controller's table active.
    let before = simulate(&dir, "part.ngc", Some(EEC));
    let hybrid = simulate(&dir, "hybrid.ngc", Some(EEC));
    let twice = simulate(&dir, "twice.ngc", Some(EEC));
    for key in [
        "point_rms_um",
        "point_max_um",
        "contour_rms_um",
        "contour_max_um",
    ] {
        let (b, h) = (before[key].as_f64().unwrap(), hybrid[key].as_f64().unwrap());
        assert!(
            h <= 0.01 * b,
            "{key}: {h} µm after is not 99 % below {b} µm"
        );
    }
    // Compensating the whole map on that machine removes the pitch error
    // twice: the error along the path grows (the tool lands off by −c, the
    // controller's own correction).
    for key in ["point_rms_um", "contour_rms_um", "contour_max_um"] {
        let (b, t) = (before[key].as_f64().unwrap(), twice[key].as_f64().unwrap());
        assert!(
            t > 2.0 * b,
            "{key}: compensated twice {t} µm, uncompensated {b} µm"
        );
    }
    // The header names the controller table it was made for.
    let h = read(&dir, "hybrid.ngc");
    assert!(
        h.contains("(ctrl %_N_AX_EEC_INI)") && h.contains("(ctrl sha256 "),
        "{}",
        &h[..400]
    );
}

#[test]
fn compensating_twice_worsens_the_positioning_axis() {
    // Along X alone at Y = Z = 0 (machine 100, 50): the straightness there
    // is ≤ 1.2 µm, the pitch error up to 12 µm + 3 µm. Uncompensated on the
    // machine with its pitch table the X error is the table's residual
    // (≤ 0.5 µm rounding + interpolation); compensated for the whole map it
    // is the pitch error itself.
    let dir = tempdir("twice-x");
    write_map(&dir);
    let mut part = String::from("G21 G90\nG0 X0 Y0 Z0\n");
    for k in 1..=8 {
        part.push_str(&format!("G1 X{} F500\n", 50 * k));
    }
    part.push_str("M2\n");
    write(&dir, "part.ngc", part);
    common::run_all(
        &dir,
        &[
            "map export m.csv --to siemens-eec --step 10 -o eec",
            "compensate part.ngc --map m.csv --work-offset 100,100,50 --decimals 6 -o twice.ngc",
        ],
    );
    let before = simulate(&dir, "part.ngc", Some(EEC));
    let twice = simulate(&dir, "twice.ngc", Some(EEC));
    let (b, t) = (
        before["point_max_um"].as_f64().unwrap(),
        twice["point_max_um"].as_f64().unwrap(),
    );
    // The last stop, machine X = 500 (a table point): E_XX = 0.02·500 +
    // 3·sin(5π) = 10 µm, which the double compensation leaves in full (the
    // straightness there, ≤ 1.5 µm in all, is in both). Uncompensated, the
    // X error is the table's rounding (≤ 0.5 µm) and the straightness:
    // E_YX(500) = 4.8·(5/6)(1/6) = 0.67, E_XY(100) = 0.45, E_XZ(50) = 0.67 µm.
    assert!(t > 9.0 && b < 1.5, "twice {t} µm, uncompensated {b} µm");
}

#[test]
fn controller_compensates_positioning_is_the_ideal_table() {
    let dir = machine("ideal");
    ok(&common::run(&dir, "compensate part.ngc --map m.csv --work-offset 100,100,50 --decimals 6 --controller-compensates positioning -o rest.ngc"));
    let t = read(&dir, "rest.ngc");
    assert!(t.contains("the controller compensates the positioning errors"));
    let o = common::run(&dir, "compensate part.ngc --map m.csv --controller nothing.txt --controller-compensates positioning -o x.ngc");
    refused(&o);
}

#[test]
fn exports_refuse_what_the_controller_cannot_hold() {
    let dir = tempdir("limits");
    write_map(&dir);
    // 600 mm every 0.1 mm is 6001 points: more than MD38000 = 5000.
    let e = refused(&common::run(
        &dir,
        "map export m.csv --to siemens-eec --step 0.1 -o eec",
    ));
    assert!(e.contains("6001 interpolation points"), "{e}");
    // Siemens needs a step; axis tables have no squareness for Klipper.
    let o = common::run(&dir, "map export m.csv --to siemens-eec -o eec");
    assert!(text(&o).contains("--step"), "{}", text(&o));
    let o = common::run(&dir, "map export m.csv --to klipper -o k");
    assert!(text(&o).contains("no squareness"), "{}", text(&o));
    // Fanuc: a step is required; the tape is read back as a controller.
    let o = common::run(&dir, "map export m.csv --to fanuc -o f");
    assert!(text(&o).contains("parameter 3624"), "{}", text(&o));
    ok(&common::run(
        &dir,
        "map export m.csv --to fanuc --step 25 -o f",
    ));
    // LinuxCNC via map export: the tables as comp files, within 256 points.
    ok(&common::run(
        &dir,
        "map export m.csv --to linuxcnc --type 1 --units mm -o lc",
    ));
    let x = read(&dir, "lc/x.comp");
    assert_eq!(x.lines().count(), 25);
    // Heidenhain: the tables and their assignment, read back as a controller.
    ok(&common::run(
        &dir,
        "map export m.csv --to heidenhain -o tnc",
    ));
    write(&dir, "part.ngc", PART);
    ok(&common::run(
        &dir,
        "map export m.csv --to siemens-cec --step 25 -o cec",
    ));
    for c in [
        "tnc/VOLCOMP.CMA",
        "f/pitch.tap",
        "lc/comp.ini",
        "cec/%_N_NC_CEC_INI",
    ] {
        simulate(&dir, "part.ngc", Some(c));
    }
}

#[test]
fn an_etalon_file_becomes_a_model() {
    let dir = tempdir("etalon");
    // C0Y = −12 µrad (S_xy = 12), EXX 5 µm at 100 mm, EYY −4 µm at 200 mm;
    // C0B (rotary axis B) is reported as not used.
    let etalon = "[C0Y]\nVALUE = -0.000012\n[C0B]\nVALUE = 0.0000223\n[EXX]\nGridpoints = {\n 0 0\n 100 0.005\n}\n[EYY]\nGridpoints = {\n 0 0\n 200 -0.004\n}\n[EZZ]\nGridpoints = {\n 0 0\n 100 0\n}\n";
    write(&dir, "machine.etalon", etalon);
    let o = common::run(&dir, "map import machine.etalon --from etalon -o m.toml");
    ok(&o);
    assert!(
        text(&o).contains("not used (rotary axes or zero): C0B"),
        "{}",
        text(&o)
    );
    assert!(text(&o).contains("EYX"), "{}", text(&o));
    // At (50, 100, 0): e_x = 2.5 + 12·100·10⁻³ = 3.7 µm, e_y = −2 µm.
    let v = json(&common::run(&dir, "map eval m.toml --at 50,100,0 --json"));
    let e = &v["deviation_um"];
    assert!((e[0].as_f64().unwrap() - 3.7).abs() < 1e-9, "{v}");
    assert!((e[1].as_f64().unwrap() - -2.0).abs() < 1e-9, "{v}");
}

#[test]
fn an_isg_volumetric_compensation_leaves_nothing() {
    // The controller applies the whole map through the ISG volumetric
    // compensation (volcomp.csv + volcomp.lis exported from it): the
    // machine's error is then only the export's rounding (10⁻⁴ µm), and the
    // map has one table for both directions, so no reversal is left either.
    let dir = machine("isg-volcomp");
    ok(&common::run(&dir, "map export m.csv --to isg-csv -o isg"));
    let before = simulate(&dir, "part.ngc", None);
    let with = simulate(&dir, "part.ngc", Some("isg/volcomp.lis"));
    let (b, w) = (
        before["point_max_um"].as_f64().unwrap(),
        with["point_max_um"].as_f64().unwrap(),
    );
    assert!(
        b > 5.0 && w < 0.001,
        "without {b} µm, with the ISG compensation {w} µm"
    );
}

#[test]
fn fanuc_bidirectional_tables_hold_the_reversal() {
    let dir = tempdir("fanuc-bidirectional");
    // The map of write_map with a reversal of 8 µm (+ 2 µm along X) on
    // every axis: the reverse table is the forward one shifted.
    write_map(&dir);
    let both = read(&dir, "m.csv");
    let mut s = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for line in both.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let p: f64 = f[2].parse().unwrap();
        let mut v: Vec<f64> = f[3..].iter().map(|x| x.parse().unwrap()).collect();
        s.push_str(&format!(
            "{},forward,{},{},{},{}\n",
            f[0], f[2], v[0], v[1], v[2]
        ));
        let a = "XYZ".find(f[0]).unwrap();
        v[a] += 8.0 + 2.0 * p / 600.0;
        s.push_str(&format!(
            "{},reverse,{},{},{},{}\n",
            f[0], f[2], v[0], v[1], v[2]
        ));
    }
    write(&dir, "m.csv", s);
    write(&dir, "part.ngc", PART);
    let export = |out: &str, mode: &str| {
        let o = volcomp(
            &[
                "map",
                "export",
                "m.csv",
                "--to",
                "fanuc",
                "--step",
                "25",
                "--fanuc-bidirectional",
                mode,
                "-o",
                out,
            ],
            &dir,
        );
        ok(&o);
        std::fs::read_to_string(dir.join(out).join("pitch.tap")).unwrap()
    };
    let auto = export("auto", "auto");
    assert!(
        auto.contains("N3605 A1 P00000001 A2 P00000001 A3 P00000001\n"),
        "{auto}"
    );
    // X: points 0 … 24 (+), 25 … 49 (−); Y 50 … 66, 67 … 83; Z 84 … 96, 97 … 109.
    assert!(auto.contains("N3626 A1 P25 A2 P67 A3 P97\n"), "{auto}");
    let off = export("off", "off");
    assert!(!off.contains("N3605") && !off.contains("N3626"), "{off}");
    // One table with the mean reversal in 1851 (side: away from the
    // reference return), shifted by half of it.
    assert!(off.contains("N1851 A1 P9 A2 P9 A3 P9\n"), "{off}");
    // The machine as the controller leaves it: with one table per
    // direction only the rounding and the straightness are left; with one
    // table and 1851, half the reversal's variation along the axis (±1 µm)
    // too: no longer half the reversal (4 µm), as with the mean alone.
    let sim = |c: &str| {
        simulate(&dir, "part.ngc", Some(c))["point_max_um"]
            .as_f64()
            .unwrap()
    };
    let (b, u) = (sim("auto/pitch.tap"), sim("off/pitch.tap"));
    assert!(b < 2.5 && u < 2.5, "bidirectional {b} µm, one table {u} µm");
}

#[test]
fn a_sign_check_comes_with_the_tables_whose_sign_no_vendor_settles() {
    let dir = tempdir("signcheck");
    // X: forward error 0 → 10 µm over 0 … 100 mm (1 µm per 10 mm), reverse
    // 4 µm above; Y and Z without error.
    let mut s = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for k in 0..=10 {
        let p = 10 * k;
        s.push_str(&format!(
            "X,forward,{p},{k},0,0\nX,reverse,{p},{},0,0\n",
            k + 4
        ));
        s.push_str(&format!("Y,both,{p},0,0,0\nZ,both,{p},0,0,0\n"));
    }
    write(&dir, "m.csv", s);
    let o = common::run(
        &dir,
        "map export m.csv --to fanuc --step 10 --fanuc-bidirectional on -o f",
    );
    ok(&o);
    assert!(text(&o).contains("with sign_check.txt"), "{}", text(&o));
    // By hand: the + table changes most between its inner points 10 and
    // 90 mm (kept 5 mm from the ends for the approach): the error grows by
    // 9 − 1 = 8 µm, the 1 µm table removes all of it; a table of the wrong
    // sign would read 8 + 8 = 16 µm. The − table the same way down.
    let t = read(&dir, "f/sign_check.txt");
    assert!(t.contains("from A = 10 mm to B = 90 mm (+ travel)"), "{t}");
    assert!(t.contains("compensation off: 8 um"), "{t}");
    assert!(t.contains("compensation on:  0 um"), "{t}");
    assert!(t.contains("near 16 um"), "{t}");
    assert!(t.contains("from A = 90 mm to B = 10 mm (- travel)"), "{t}");
    let nc = read(&dir, "f/signcheck.nc");
    assert!(nc.contains("G53 X5\nG53 X10\nM00"), "{nc}");
    assert!(nc.contains("G53 X95\nG53 X90\nM00"), "{nc}");
    // LinuxCNC's sign is documented: no check.
    ok(&common::run(
        &dir,
        "map export m.csv --to linuxcnc --type 1 --units mm -o l",
    ));
    assert!(!dir.join("l/sign_check.txt").exists());
}
