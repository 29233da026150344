//! `volcomp ballbar`: the test's program against LinuxCNC's `rs274` (its
//! arcs are the trace's nominal circle), and bad input named by file, line
//! and column.
//!
//! Without `rs274` the rs274 check prints a skip message, except when `CI`
//! is set: there it fails.

use crate::common;
use crate::rs274;

use common::{stderr, tempdir, volcomp, write};
use std::path::Path;
use std::process::{Command, Stdio};

/// The canonical calls of `program`: `(name, numbers)` for each traverse and arc.
fn canon(exe: &Path, program: &Path, dir: &Path) -> Vec<(String, Vec<f64>)> {
    let out_path = dir.join("canon.txt");
    let out = Command::new(exe)
        .current_dir(dir)
        .env("HOME", dir)
        .arg("-g")
        .arg(program)
        .arg(&out_path)
        .stdin(Stdio::null())
        .output()
        .expect("run rs274");
    let text = std::fs::read_to_string(&out_path).unwrap_or_default();
    assert!(
        out.status.success() && !text.contains("ABORT"),
        "rs274 refused {}: {}\n{text}",
        program.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    text.lines()
        .filter_map(|l| {
            let name = ["STRAIGHT_TRAVERSE(", "ARC_FEED(", "STRAIGHT_FEED("]
                .into_iter()
                .find(|n| l.contains(n))?;
            let i = l.find(name)? + name.len();
            let nums = l[i..]
                .trim_end_matches(')')
                .split(',')
                .filter_map(|v| v.trim().parse().ok())
                .collect();
            Some((name.trim_end_matches('(').to_string(), nums))
        })
        .collect()
}

/// The test's program, for every plane and direction, is accepted by
/// rs274, and its arcs are the nominal circle: every centre the pivot,
/// every end on the radius, each run turning feed-in + 360° + feed-out in
/// its sense, the plane's third axis at the pivot's.
#[test]
fn the_test_program_is_the_nominal_circle_for_rs274() {
    let Some(exe) = rs274::find_rs274() else {
        common::missing(common::RS274, "the ballbar test program on rs274");
        return;
    };
    let d = tempdir("ballbar-rs274");
    write(&d, "map.csv", "axis,direction,position_mm,ex_um,ey_um,ez_um\nX,both,0,0,0,0\nX,both,500,0,0,0\nY,both,0,0,0,0\nY,both,500,0,0,0\nZ,both,0,0,0,0\nZ,both,500,0,0,0\n");
    let (c, r) = ([250.0, 200.0, 150.0], 75.0);
    for (plane, (u, v)) in [("XY", (0, 1)), ("YZ", (1, 2)), ("ZX", (2, 0))] {
        for (direction, senses) in [("both", vec![1.0, -1.0]), ("cw", vec![-1.0])] {
            let p = d.join(format!("{plane}-{direction}.ngc"));
            let o = volcomp(
                &[
                    "ballbar",
                    "predict",
                    "map.csv",
                    "--centre-mm",
                    "250,200,150",
                    "--radius-mm",
                    "75",
                    "--plane",
                    plane,
                    "--direction",
                    direction,
                    "--start-deg",
                    "30",
                    "--overshoot-deg",
                    "90",
                    "--step-deg",
                    "1",
                    "--write-program",
                    p.to_str().unwrap(),
                ],
                &d,
            );
            common::ok(&o);
            let calls = canon(&exe, &p, &d);
            let w = 3 - u - v;
            // The rapid to the feed-in arc's start (30° − 90° in the first run's sense).
            let start = (30.0 - senses[0] * 90.0_f64).to_radians();
            let last_rapid = calls
                .iter()
                .rev()
                .find(|(n, _)| n == "STRAIGHT_TRAVERSE")
                .unwrap();
            let mut at = [last_rapid.1[0], last_rapid.1[1], last_rapid.1[2]];
            assert!(
                (at[u] - (c[u] + r * start.cos())).abs() < 1e-4,
                "{plane} {at:?}"
            );
            assert!(
                (at[v] - (c[v] + r * start.sin())).abs() < 1e-4,
                "{plane} {at:?}"
            );
            let arcs: Vec<&Vec<f64>> = calls
                .iter()
                .filter(|(n, _)| n == "ARC_FEED")
                .map(|(_, a)| a)
                .collect();
            assert_eq!(arcs.len(), 3 * senses.len(), "{plane} {direction}");
            for (k, a) in arcs.iter().enumerate() {
                // ARC_FEED(first_end, second_end, first_axis, second_axis, rotation, axis_end, …):
                // first and second are the plane's u and v.
                let sense = senses[k / 3];
                assert_eq!(a[4], sense, "{plane} arc {k}");
                assert!(
                    (a[2] - c[u]).abs() < 1e-4 && (a[3] - c[v]).abs() < 1e-4,
                    "{plane} centre {a:?}"
                );
                assert!((a[5] - c[w]).abs() < 1e-4, "{plane} third axis {a:?}");
                assert!(
                    ((a[0] - c[u]).hypot(a[1] - c[v]) - r).abs() < 1e-4,
                    "{plane} radius {a:?}"
                );
                let a0 = (at[v] - c[v]).atan2(at[u] - c[u]).to_degrees();
                let a1 = (a[1] - c[v]).atan2(a[0] - c[u]).to_degrees();
                let mut swept = (sense * (a1 - a0)).rem_euclid(360.0);
                if swept < 1e-6 {
                    swept = 360.0;
                }
                let want = if k % 3 == 1 { 360.0 } else { 90.0 };
                assert!(
                    (swept - want).abs() < 1e-3,
                    "{plane} {direction} arc {k}: {swept}°"
                );
                at[u] = a[0];
                at[v] = a[1];
            }
        }
    }
}

#[test]
fn a_bad_trace_is_named_by_file_line_and_column() {
    let d = tempdir("ballbar-bad");
    write(
        &d,
        "t.csv",
        "# plane = XY\n# radius_mm = 100\ndirection,angle_deg,deviation_um\nccw,0,1\nccw,1,one\n",
    );
    let o = common::run(&d, "ballbar fit t.csv");
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("t.csv:5:3"), "{e}");
    write(&d, "u.csv", "direction,angle_deg,deviation_um\nccw,0,1\n");
    let o = common::run(&d, "ballbar fit u.csv");
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("--trace-plane"), "{e}");
    let o = common::run(&d, "ballbar predict u.csv --centre-mm 1,2,3 --step-deg 7");
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("--step-deg"), "{e}");
}
