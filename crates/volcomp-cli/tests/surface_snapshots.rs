//! Snapshots of what `volcomp surface mirror` writes for a person to read:
//! the summary on standard output and the head of the per-point CSV report,
//! for the documented command (README.md) on the bundled example data
//! (examples/data). A change to either shows as a snapshot diff to review.

use std::path::{Path, PathBuf};

use crate::common;
use common::{read, tempdir};

fn example_data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data")
}

/// A copy of the example inputs the command reads, in a fresh directory.
fn inputs(name: &str) -> common::TempDir {
    let dir = tempdir(name);
    for f in ["face.toml", "probes.csv", "finish.ngc"] {
        std::fs::copy(example_data().join(f), dir.join(f)).unwrap();
    }
    dir
}

/// The README's command, with the report as CSV.
const RUN: &str = "surface mirror --nominal face.toml --measured probes.csv --stock 0.2 \
    --finishing finish.ngc -o finish.comp.ngc --tool-radius 3 --report report.csv";

#[test]
fn summary_of_the_documented_run() {
    let dir = inputs("summary");
    let o = common::run(&dir, RUN);
    common::ok(&o);
    assert_eq!(String::from_utf8_lossy(&o.stderr), "");
    insta::assert_snapshot!("mirror_summary", String::from_utf8_lossy(&o.stdout));
}

#[test]
fn report_csv_header_and_first_rows() {
    let dir = inputs("report");
    let o = common::run(&dir, RUN);
    common::ok(&o);
    let report = read(&dir, "report.csv");
    // The `#` summary lines, the column header and the first three points.
    let head: Vec<&str> = report
        .lines()
        .scan(0, |rows, l| {
            *rows += usize::from(!l.starts_with('#'));
            (*rows <= 4).then_some(l)
        })
        .collect();
    insta::assert_snapshot!("mirror_report_csv_head", head.join("\n"));
}
