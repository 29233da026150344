//! `volcomp straightness` as a user meets it: fit, plot, table, predict, the
//! model as a `--map`, and located refusals of bad runs.

use std::f64::consts::PI;
use std::path::Path;

use crate::common;
use common::{read, tempdir, volcomp, write};

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Geometric truth along X over 0 … 200 mm: a 10 mm lead (0.4 µm), a bow
/// and 2 µrad of slope.
fn geometric_um(x: f64) -> f64 {
    let u = (x - 100.0) / 100.0;
    0.4 * (2.0 * PI * x / 10.0 + 0.5).sin() + 0.3 * (1.0 - u * u) + 2e-3 * x
}

/// Writes a run at `feed` with a 150 Hz vibration of 0.15 µm (phase
/// `phase`) and a small deterministic "noise".
fn write_run(dir: &Path, name: &str, feed: f64, phase: f64) -> String {
    let lambda = feed / 60.0 / 150.0;
    let mut s = format!("# volcomp straightness run\n# axis = X\n# feed_mm_per_min = {feed}\nposition_mm,displacement_um\n");
    for i in 0..801 {
        let x = i as f64 * 0.25;
        let noise = 0.01 * ((i as f64 * 12.9898 + phase * 78.233).sin() * 43758.5453).fract();
        let z = geometric_um(x) + 0.15 * (2.0 * PI * x / lambda + phase).sin() + noise;
        s.push_str(&format!("{x:.3},{z:.5}\n"));
    }
    std::fs::write(dir.join(name), s).unwrap();
    name.to_string()
}

fn write_runs(dir: &Path) -> Vec<String> {
    let mut names = Vec::new();
    for (j, feed) in [4800.0, 7200.0, 9600.0].into_iter().enumerate() {
        for r in 0..2 {
            let phase = 1.3 * j as f64 + 2.1 * r as f64;
            names.push(write_run(dir, &format!("x-{feed}-{r}.csv"), feed, phase));
        }
    }
    names
}

#[test]
fn fit_plot_table_predict_and_compensate() {
    let dir = tempdir("fit");
    let runs = write_runs(&dir);
    let mut args: Vec<&str> = vec!["straightness", "fit"];
    args.extend(runs.iter().map(String::as_str));
    args.extend(["-o", "model.toml", "--plot", "fit.svg"]);
    let o = volcomp(&args, &dir);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    // The rejected line at each feed rate is the 150 Hz column mode (to the
    // spectrum's resolution, v/l ≤ 0.8 Hz).
    let hz: Vec<f64> = err
        .split(" Hz")
        .filter_map(|s| s.rsplit(' ').next()?.parse().ok())
        .collect();
    assert_eq!(hz.len(), 3, "{err}");
    assert!(hz.iter().all(|f| (f - 150.0).abs() < 1.0), "{hz:?}");
    assert!(err.contains("wrote model.toml"), "{err}");
    let model = read(&dir, "model.toml");
    assert!(model.contains("kind = \"straightness\""));
    assert!(model.contains("beta_zx_urad = "));
    let svg = read(&dir, "fit.svg");
    assert!(svg.contains("<svg") && svg.contains("cut-off"));

    // The same identification as a PNG through `plot`.
    let mut args: Vec<&str> = vec!["straightness", "plot"];
    args.extend(runs.iter().map(String::as_str));
    args.extend(["-o", "fit.png"]);
    let o = volcomp(&args, &dir);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let png = std::fs::read(dir.join("fit.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");

    // Predictions follow the truth up to a constant: compare differences.
    let o = common::run(&dir, "straightness predict model.toml 52.5,0 100,0");
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    let rows: Vec<Vec<f64>> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    let predicted = rows[0][2] - rows[1][2];
    let truth = geometric_um(52.5) - geometric_um(100.0);
    assert!((predicted - truth).abs() < 0.03, "{predicted} vs {truth}");
    assert_eq!(rows[0][3], -rows[0][2]);
    let o = common::run(&dir, "straightness predict model.toml 250,0");
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("--clamp"), "{}", text(&o.stderr));

    // The correction table.
    let o = common::run(
        &dir,
        "straightness table model.toml --step 0.5 -o table.csv",
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let table = read(&dir, "table.csv");
    assert!(table.contains("base_axis,position_mm,ez_um,z_correction_um"));
    assert_eq!(table.lines().filter(|l| l.starts_with("X,")).count(), 401);

    // The model compensates a program: a Z correction follows the lead.
    write(
        &dir,
        "p.ngc",
        "G21 G90\nG0 X20 Y0 Z5\nG1 Z0 F500\nG1 X180 F7200\nG0 Z5\nM2\n",
    );
    let o = volcomp(
        &[
            "compensate",
            "p.ngc",
            "--map",
            "model.toml",
            "--work-offset",
            "0,0,0",
            "--decimals",
            "5",
            // Fixed 1 mm segments: every one shows the lead's correction.
            "--segment-length",
            "1",
            "-o",
            "p.comp.ngc",
        ],
        &dir,
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let comp = read(&dir, "p.comp.ngc");
    let zs: Vec<f64> = comp
        .lines()
        .filter(|l| l.contains("(volcomp L4)"))
        .filter_map(|l| l.split_whitespace().find_map(|w| w.strip_prefix('Z')))
        .map(|z| z.parse().unwrap())
        .collect();
    assert!(zs.len() > 100, "{comp}");
    let (lo, hi) = zs
        .iter()
        .fold((f64::MAX, f64::MIN), |a, &z| (a.0.min(z), a.1.max(z)));
    // Lead 0.8 µm P-V plus part of the bow and slope: about a micrometre.
    assert!(
        hi - lo > 0.5e-3 && hi - lo < 2e-3,
        "Z corrections {lo} … {hi}"
    );
}

#[test]
fn bad_runs_are_refused_with_file_row_and_column() {
    let dir = tempdir("bad");
    let runs = write_runs(&dir);
    // A NaN on one row.
    let good = std::fs::read_to_string(dir.join(&runs[0])).unwrap();
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    lines[10] = "1.500,NaN".into();
    write(&dir, "nan.csv", lines.join("\n"));
    let o = volcomp(
        &["straightness", "fit", "nan.csv", &runs[2], &runs[4]],
        &dir,
    );
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("nan.csv:11:2:") && e.contains("help:"), "{e}");
    // A missing sample.
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    lines.remove(20);
    write(&dir, "gap.csv", lines.join("\n"));
    let o = volcomp(&["straightness", "fit", "gap.csv", &runs[2]], &dir);
    let e = text(&o.stderr);
    assert!(e.contains("gap.csv:21:1: unequal sampling"), "{e}");
    // One feed rate only.
    let o = volcomp(&["straightness", "fit", &runs[0], &runs[1]], &dir);
    let e = text(&o.stderr);
    assert!(
        e.contains("one feed rate, 4800 mm/min") && e.contains("another feed rate"),
        "{e}"
    );
    // A single run.
    let o = volcomp(&["straightness", "fit", &runs[0]], &dir);
    assert!(text(&o.stderr).contains("only one run"));
    // Bad options.
    let o = volcomp(
        &["straightness", "fit", &runs[0], &runs[2], "--taper", "0.8"],
        &dir,
    );
    assert!(text(&o.stderr).contains("taper"));
    let o = volcomp(
        &["straightness", "plot", &runs[0], &runs[2], "-o", "x.pdf"],
        &dir,
    );
    assert!(text(&o.stderr).contains(".svg or .png"));
    // A model that is not one.
    write(
        &dir,
        "m.toml",
        "kind = \"straightness\"\nformat_version = 1\n",
    );
    let o = common::run(&dir, "straightness table m.toml");
    assert!(
        text(&o.stderr).starts_with("error: m.toml:1:1: missing field `offset_um`"),
        "{}",
        text(&o.stderr)
    );
}
