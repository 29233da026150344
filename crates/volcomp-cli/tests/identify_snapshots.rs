//! Snapshots of the identification commands' human-readable output: the
//! `straightness fit` summary, its option refusals (the CLI names its
//! flags), and what `thermal fit` and `thermal predict` print. Inputs are
//! synthetic and deterministic; review a changed snapshot with
//! `cargo insta review` before accepting it.

use std::f64::consts::PI;
use std::path::Path;

use crate::common;
use common::{stderr, tempdir, volcomp};

/// A run along X over 0 … 200 mm at `feed`: a 10 mm lead (0.4 µm), a bow,
/// 2 µrad of slope, a 150 Hz vibration of 0.15 µm and a small
/// deterministic "noise" (as in the straightness command tests).
fn write_run(dir: &Path, feed: f64, repeat: usize, phase: f64) -> String {
    let lambda = feed / 60.0 / 150.0;
    let mut s = format!("# axis = X\n# feed_mm_per_min = {feed}\nposition_mm,displacement_um\n");
    for i in 0..801 {
        let x = i as f64 * 0.25;
        let u = (x - 100.0) / 100.0;
        let geometric = 0.4 * (2.0 * PI * x / 10.0 + 0.5).sin() + 0.3 * (1.0 - u * u) + 2e-3 * x;
        let noise = 0.01 * ((i as f64 * 12.9898 + phase * 78.233).sin() * 43758.5453).fract();
        let z = geometric + 0.15 * (2.0 * PI * x / lambda + phase).sin() + noise;
        s.push_str(&format!("{x:.3},{z:.5}\n"));
    }
    let name = format!("x-{feed}-{repeat}.csv");
    std::fs::write(dir.join(&name), s).unwrap();
    name
}

fn write_runs(dir: &Path) -> Vec<String> {
    let mut names = Vec::new();
    for (j, feed) in [4800.0, 7200.0, 9600.0].into_iter().enumerate() {
        for r in 0..2 {
            names.push(write_run(dir, feed, r, 1.3 * j as f64 + 2.1 * r as f64));
        }
    }
    names
}

#[test]
fn straightness_fit_summary() {
    let d = tempdir("snap-straightness");
    let runs = write_runs(&d);
    let mut args = vec!["straightness", "fit"];
    args.extend(runs.iter().map(String::as_str));
    args.extend(["-o", "model.toml"]);
    let o = volcomp(&args, &d);
    common::ok(&o);
    insta::assert_snapshot!("straightness_fit_summary", stderr(&o));

    let o = common::run(&d, "straightness predict model.toml 52.5,0 100,0 150.25,0");
    insta::assert_snapshot!("straightness_predict", common::ok(&o));
}

#[test]
fn straightness_option_refusals_name_the_flags() {
    let d = tempdir("snap-straightness-options");
    let runs = write_runs(&d);
    let mut text = String::new();
    for extra in [
        &["--harmonics", "0"][..],
        &["--axis", "Y"],
        &["--cutoff", "thresholds", "--p-t", "0.9"],
    ] {
        let mut args = vec!["straightness", "fit"];
        args.extend(runs.iter().map(String::as_str));
        args.extend(extra);
        let o = volcomp(&args, &d);
        assert_eq!(o.status.code(), Some(2));
        text.push_str(&format!("$ … {}\n{}", extra.join(" "), stderr(&o)));
    }
    insta::assert_snapshot!("straightness_option_refusals", text);
}

#[test]
fn thermal_fit_and_predict_output() {
    let d = tempdir("snap-thermal");
    common::ok(&common::run(&d, "thermal example -o ex"));
    let fit = common::ok(&common::run(&d, "thermal fit --measurements ex/measurements_train.csv --temperatures ex/temperatures_train.csv --artifact ex/artifact.csv --ranges-mm 0:600,0:400,0:300 -o ex/thermal.toml"));
    insta::assert_snapshot!("thermal_fit", fit);
    // What was written is said on standard error (quiet under --quiet).
    let predict = common::run(&d, "thermal predict --model ex/thermal.toml --temperatures ex/temperatures_check.csv --cycle 6 -o ex/predicted.toml");
    let predict = stderr(&predict);
    insta::assert_snapshot!("thermal_predict", predict);
    // Outside the axis ranges: the library speaks of the axis ranges, the
    // CLI of its flag.
    let o = common::run(&d, "thermal fit --measurements ex/measurements_train.csv --temperatures ex/temperatures_train.csv --artifact ex/artifact.csv --ranges-mm 0:60,0:400,0:300 -o ex/narrow.toml");
    assert_eq!(o.status.code(), Some(2));
    insta::assert_snapshot!("thermal_fit_outside_ranges", stderr(&o));
}
