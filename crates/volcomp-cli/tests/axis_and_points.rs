//! Options as users write them: an axis in either case, a flag after the
//! points of `straightness predict`, negative coordinates, and numbers in
//! CSV output without binary rounding noise.

use std::path::Path;

use crate::common;
use common::{read, tempdir, volcomp, write};

fn ok(args: &[&str], dir: &Path) -> String {
    let o = volcomp(args, dir);
    assert!(
        o.status.success(),
        "volcomp {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// An ISO 230-2 test whose mean deviations are not exact binary fractions:
/// two approaches per direction at three targets.
const RUNS: &str = "target_mm,cycle,direction,deviation_um\n\
0,1,up,0.1\n0,2,up,0.2\n0,1,down,-0.034\n0,2,down,-0.034\n\
50,1,up,0.3\n50,2,up,0.4\n50,1,down,0.7\n50,2,down,0.1\n\
100,1,up,-0.2\n100,2,up,-0.1\n100,1,down,0.3\n100,2,down,0.6\n";

#[test]
fn axis_letters_are_accepted_in_either_case_and_means_are_written_cleanly() {
    let dir = tempdir("axis");
    write(&dir, "runs.csv", RUNS);
    ok(
        &[
            "map",
            "iso230-2",
            "runs.csv",
            "--axis",
            "X",
            "-o",
            "upper.csv",
        ],
        &dir,
    );
    ok(
        &[
            "map",
            "iso230-2",
            "runs.csv",
            "--axis",
            "x",
            "-o",
            "lower.csv",
        ],
        &dir,
    );
    let upper = read(&dir, "upper.csv");
    let lower = read(&dir, "lower.csv");
    assert_eq!(upper, lower);
    // Means by hand: x̄↑(0) = (0.1 + 0.2)/2 = 0.15 (0.15000000000000002 in
    // binary), x̄↓(0) = −0.034, x̄↑(100) = −0.15, x̄↓(50) = 0.4.
    for row in [
        "X,forward,0,0.15,0,0,0,0,0",
        "X,reverse,0,-0.034,0,0,0,0,0",
        "X,forward,100,-0.15,0,0,0,0,0",
        "X,reverse,50,0.4,0,0,0,0,0",
    ] {
        assert!(upper.lines().any(|l| l == row), "no row {row} in\n{upper}");
    }
    let o = common::run(&dir, "map iso230-2 runs.csv --axis W -o w.csv");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("`W` is not an axis: write X, Y or Z"), "{err}");
    assert!(!dir.join("w.csv").exists());
}

#[test]
fn straightness_predict_takes_the_flag_after_negative_points() {
    let dir = tempdir("predict");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/runs");
    let mut args = vec!["straightness".to_string(), "fit".into()];
    for f in ["x-4800.csv", "x-7200.csv", "x-9600.csv"] {
        args.push(root.join(f).display().to_string());
    }
    args.extend([
        "--axis".into(),
        "x".into(),
        "-o".into(),
        "model.toml".into(),
    ]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let _ = ok(&args, &dir);
    let before = ok(
        &[
            "straightness",
            "predict",
            "model.toml",
            "--clamp",
            "-5,20",
            "120,-35",
        ],
        &dir,
    );
    let after = ok(
        &[
            "straightness",
            "predict",
            "model.toml",
            "-5,20",
            "120,-35",
            "--clamp",
        ],
        &dir,
    );
    assert_eq!(before, after);
    assert!(
        after.starts_with("x_mm,y_mm,ez_um,z_correction_um\n-5,20,"),
        "{after}"
    );
    // Without --clamp, x = −5 mm lies outside the measured 0 … 200 mm.
    let o = common::run(&dir, "straightness predict model.toml -5,20");
    assert!(!o.status.success());
    let o = common::run(&dir, "straightness predict model.toml 120,35 --clam");
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--clam"));
}
