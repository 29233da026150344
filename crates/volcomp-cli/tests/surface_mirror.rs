//! `volcomp surface mirror` as a user meets it: the files it writes, the
//! report, and located refusals of bad input with nothing written.

use std::path::Path;
use volcomp_core::surface::mirror::{read_bspline_toml, write_bspline_toml, NominalSurface};
use volcomp_gcode::Vec3;

use crate::common;
use crate::example_data::{finishing_passes, mirror_nominal, probe_grid, saddle};
use common::{read, tempdir, volcomp, write};

/// The machine's error (µm, positive = material left).
fn error_um(x: f64, y: f64) -> f64 {
    3.0 + 0.002 * (x - 40.0).powi(2) + 0.03 * y
}

/// A probes CSV of a 7 × 5 grid over the nominal surface `n`: each probe
/// centre 0.3 mm (the stock) plus the machine's error `error_um(point)`
/// along the normal.
fn probes(n: &NominalSurface, mut error_um: impl FnMut(Vec3) -> f64) -> String {
    probe_grid(n, (7, 5), |_, _, p| 0.3 + error_um(p) * 1e-3)
}

/// Writes nominal.toml, nominal-grid.csv, probes.csv (7 × 5 grid, no noise)
/// and finish.ngc (tip CL, ball radius 2 mm) to `dir`.
fn write_inputs(dir: &Path) {
    let n = mirror_nominal();
    write(
        dir,
        "nominal.toml",
        write_bspline_toml(n.surface(), "test saddle"),
    );
    let mut grid = String::from("i,j,x_mm,y_mm,z_mm\n");
    for i in 0..=16 {
        for j in 0..=10 {
            let (x, y) = (5.0 * i as f64, 5.0 * j as f64);
            grid.push_str(&format!("{i},{j},{x},{y},{:.9}\n", saddle(x, y)));
        }
    }
    write(dir, "nominal-grid.csv", grid);
    let probes = probes(&n, |p| error_um(p.x, p.y));
    write(
        dir,
        "probes.csv",
        format!("# probed after semi-finishing\n{probes}"),
    );
    let passes = finishing_passes(&n, 2.0, (0..6).map(|pass| (5.0 + 8.0 * pass as f64) / 50.0));
    let prog = format!("%\nO1234 (saddle finishing)\nG21 G90 G17\nG0 Z30.\n{passes}M30\n%\n");
    write(dir, "finish.ngc", prog);
}

const RUN: &[&str] = &[
    "surface",
    "mirror",
    "--nominal",
    "nominal.toml",
    "--measured",
    "probes.csv",
    "--stock",
    "0.3",
    "--finishing",
    "finish.ngc",
    "-o",
    "finish.comp.ngc",
    "--tool-radius",
    "2",
];

#[test]
fn writes_the_program_the_surface_and_the_report() {
    let dir = tempdir("ok");
    write_inputs(&dir);
    let mut args = RUN.to_vec();
    args.extend([
        "--report",
        "report.json",
        "--baseline",
        "finish.base.ngc",
        "--no-split",
    ]);
    let o = volcomp(&args, &dir);
    let out = common::ok(&o);
    assert!(
        out.contains("tool-radius baseline") && out.contains("mirror, predicted"),
        "{out}"
    );
    // The program: the same lines, only coordinates changed.
    let before = read(&dir, "finish.ngc");
    let after = read(&dir, "finish.comp.ngc");
    assert_ne!(before, after);
    for l in [
        "%",
        "O1234 (saddle finishing)",
        "G21 G90 G17",
        "G0 Z30.",
        "M30",
    ] {
        assert!(after.lines().any(|a| a == l), "{l} kept");
    }
    // The header follows the % and O-number lines; the body is the rest.
    let lines: Vec<&str> = after.lines().collect();
    assert_eq!(lines[2], volcomp_core::io::provenance::FIRST_LINE);
    assert!(after.contains("(method surface mirror)"), "{after}");
    let body = volcomp_core::io::provenance::strip_header(&after);
    let original: Vec<&str> = body.lines().filter(|l| !l.contains("(volcomp L")).collect();
    assert_eq!(original.len(), before.lines().count());
    // The compensated CL points sit below the nominal CL points by the
    // measured error (error field ≥ 3 µm, here at least 2.5 µm lower).
    let n = mirror_nominal();
    let first_cut = original
        .iter()
        .zip(before.lines())
        .find(|(a, b)| a.starts_with('X') && *a != b)
        .unwrap();
    let z = |l: &str| -> f64 { l.split('Z').nth(1).unwrap().trim().parse().unwrap() };
    assert!(z(first_cut.1) - z(first_cut.0) > 0.0025, "{first_cut:?}");
    // The surface files: a grid and a B-spline that reads back as a nominal.
    let grid = read(&dir, "probes.compensated.csv");
    assert!(grid.contains("i,j,x_mm,y_mm,z_mm,offset_um"));
    assert_eq!(
        grid.lines().filter(|l| !l.starts_with('#')).count(),
        1 + 41 * 41
    );
    let toml = read(&dir, "probes.compensated.toml");
    let s = read_bspline_toml(&toml, "c.toml").unwrap();
    let (u, v) = (0.5, 0.5);
    let p = s.point(u, v);
    let q = n.point(u, v);
    let expected = error_um(q.x, q.y);
    assert!(
        ((q.z - p[2]) * 1e3 - expected).abs() < 0.3,
        "{} vs {expected}",
        (q.z - p[2]) * 1e3
    );
    // The report.
    let report: serde_json::Value = serde_json::from_str(&read(&dir, "report.json")).unwrap();
    assert_eq!(report["points"], 35);
    assert_eq!(report["probe_points"].as_array().unwrap().len(), 35);
    let mean = report["before"]["mean_um"].as_f64().unwrap();
    assert!(mean > 3.0 && mean < 8.0, "{mean}");
    assert!(report["baseline"]["mean_um"].as_f64().unwrap().abs() < 1e-9);
    assert!(dir.join("finish.base.ngc").exists());
    // JSON on stdout; feed moves split every 2 mm by default.
    let mut args = RUN.to_vec();
    args.extend(["--json", "--surface-out", "out/s"]);
    std::fs::create_dir_all(dir.join("out")).unwrap();
    let o = volcomp(&args, &dir);
    let j = common::json(&o);
    assert!(j["finishing"]["moved"].as_u64().unwrap() >= 6 * 41);
    assert!(dir.join("out/s.csv").exists() && dir.join("out/s.toml").exists());
}

#[test]
fn a_grid_nominal_and_an_interpolated_fit_work_too() {
    let dir = tempdir("grid");
    write_inputs(&dir);
    let o = common::run(&dir, "surface mirror --nominal nominal-grid.csv --measured probes.csv --stock 0.3 --fit interpolate --report r.csv");
    let out = common::ok(&o);
    assert!(out.contains("interpolation"), "{out}");
    let grid = read(&dir, "probes.compensated.csv");
    // The grid nominal's own nodes.
    assert_eq!(
        grid.lines().filter(|l| !l.starts_with('#')).count(),
        1 + 17 * 11
    );
    let r = read(&dir, "r.csv");
    assert!(r.lines().any(|l| l.starts_with("row,id,i,j,")));
    assert_eq!(
        r.lines()
            .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
            .count(),
        35
    );
}

fn refused(dir: &Path, args: &[&str], expect: &[&str]) {
    let o = volcomp(args, dir);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{args:?} should fail");
    for e in expect {
        assert!(err.contains(e), "{args:?}: `{e}` not in\n{err}");
    }
    for f in [
        "finish.comp.ngc",
        "probes.compensated.csv",
        "probes.compensated.toml",
    ] {
        assert!(!dir.join(f).exists(), "{f} written despite {args:?}");
    }
}

#[test]
fn bad_input_is_refused_with_its_location_and_nothing_is_written() {
    let dir = tempdir("bad");
    write_inputs(&dir);
    let probes = read(&dir, "probes.csv");
    let with = |name: &str, content: String| {
        std::fs::write(dir.join(name), content).unwrap();
    };
    // RUN with `--measured` replaced and the flag/value pairs of `extra`
    // replacing RUN's own.
    let run = |measured: &str, extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = RUN.iter().map(|s| s.to_string()).collect();
        v[5] = measured.into();
        for pair in extra.chunks(2) {
            match v.iter().position(|a| a == pair[0]) {
                Some(k) => v[k + 1] = pair[1].into(),
                None => v.extend(pair.iter().map(|s| s.to_string())),
            }
        }
        v
    };
    let call = |measured: &str, extra: &[&str], expect: &[&str]| {
        let v = run(measured, extra);
        let refs: Vec<&str> = v.iter().map(String::as_str).collect();
        refused(&dir, &refs, expect);
    };
    // NaN: file, row, column.
    let lines: Vec<&str> = probes.lines().collect();
    let mut nan = lines.clone();
    let bad_row = lines[5].replacen(&lines[5].split(',').nth(4).unwrap().to_string(), "NaN", 1);
    nan[5] = &bad_row;
    with("nan.csv", nan.join("\n"));
    call("nan.csv", &[], &["nan.csv:6:5:", "not a finite number"]);
    // A point 1 mm off.
    let mut far = lines.clone();
    let f: Vec<String> = lines[4].split(',').map(String::from).collect();
    let z: f64 = f[5].parse::<f64>().unwrap() + 1.0;
    let far_row = format!("{},{},{},{},{},{z}", f[0], f[1], f[2], f[3], f[4]);
    far[4] = &far_row;
    with("far.csv", far.join("\n"));
    call(
        "far.csv",
        &[],
        &["far.csv:5:1:", "from the nominal surface"],
    );
    // Too few points.
    with("few.csv", lines[..10].join("\n"));
    call("few.csv", &[], &["too few", "4 × 4"]);
    // Coordinates in mm, header says inches.
    with(
        "inch.csv",
        probes.replace("x_mm,y_mm,z_mm", "x_in,y_in,z_in"),
    );
    call(
        "inch.csv",
        &[],
        &["would if its coordinates were millimetres"],
    );
    // No unit at all.
    with("nounit.csv", probes.replace("x_mm,y_mm,z_mm", "x,y,z"));
    call(
        "nounit.csv",
        &[],
        &["nounit.csv:2:4:", "does not say its unit"],
    );
    // A stock the curvature does not allow (concave radius ≈ 167 mm).
    call("probes.csv", &["--stock", "200"], &["concave radius"]);
    // A tool radius far too large, and a CL point that is not the program's.
    call("probes.csv", &["--tool-radius", "500"], &["concave radius"]);
    call(
        "probes.csv",
        &["--cl-point", "center"],
        &["touches the nominal surface"],
    );
    // The finishing program needs -o and --tool-radius.
    let o = common::run(&dir, "surface mirror --nominal nominal.toml --measured probes.csv --stock 0.3 --finishing finish.ngc");
    assert!(!o.status.success());
    // The input is never overwritten.
    let mut v = RUN.to_vec();
    v[11] = "finish.ngc";
    refused(&dir, &v, &["refusing to write"]);
}

/// Probes whose error is a constant undercut plus unstructured noise
/// (σ ≈ 0.5 µm, a fixed pseudo-random sequence): no surface predicts the
/// error between probes, so the leave-one-out prediction of any fit is worse
/// than not compensating. The default warns and writes; `--refuse-worse`
/// refuses and writes nothing.
#[test]
fn warns_or_refuses_when_compensation_is_predicted_worse() {
    let dir = tempdir("worse");
    write_inputs(&dir);
    let n = mirror_nominal();
    let mut state: u64 = 12345;
    let mut uniform = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    // Uniform on ±0.87 µm: σ = 0.5 µm.
    write(
        &dir,
        "noise.csv",
        probes(&n, |_| 3.0 + 0.87 * (2.0 * uniform() - 1.0)),
    );
    let mut args = RUN.to_vec();
    args[5] = "noise.csv";
    args.push("--refuse-worse");
    let o = volcomp(&args, &dir);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("worse than not compensating") && err.contains("nothing was written"),
        "{err}"
    );
    assert!(!dir.join("finish.comp.ngc").exists());
    assert!(!dir.join("noise.compensated.csv").exists());
    args.pop();
    let o = volcomp(&args, &dir);
    common::ok(&o);
    let err = common::stderr(&o);
    assert!(
        err.contains("warning") && err.contains("worse than not compensating"),
        "{err}"
    );
    assert!(dir.join("finish.comp.ngc").exists());
    // The JSON summary says so too.
    std::fs::remove_file(dir.join("finish.comp.ngc")).unwrap();
    args.push("--json");
    let o = volcomp(&args, &dir);
    let out = common::ok(&o);
    assert!(
        out.contains("\"compensation_predicted_worse\":true"),
        "{out}"
    );
}
