//! Writes the example inputs in `examples/data/` that the commands of the
//! README and `docs/*.md` run on (the doc-test `tests/docs_commands.rs` runs
//! them there):
//!
//! ```sh
//! cargo run -p volcomp-cli --example example_data -- examples/data
//! ```
//!
//! Everything is synthetic and deterministic (no random generator): a part
//! program, a set-up, the example axis-table map, an ISO 230-2 test, straightness
//! runs at three feed rates along X and Y, and a free-form surface with its
//! probe points and ball-end finishing program. The truths are stated next to
//! each generator so that a user can check what the commands find.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use volcomp_core::surface::bspline::{self, Parameterization};
use volcomp_core::surface::mirror::{write_bspline_toml, MaterialSide, NominalSurface};
use volcomp_gcode::Vec3;

fn main() {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "examples/data".into()),
    );
    write_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("wrote the example data to {}", dir.display());
}

/// Every example file, by path relative to the data folder. The doc-test
/// compares `examples/data/` with this, so the committed files cannot drift
/// from their generator.
pub fn files() -> Vec<(String, String)> {
    let mut out = vec![
        (
            "map.csv".to_string(),
            volcomp_core::example::example_map().to_csv(),
        ),
        ("machine.toml".into(), MACHINE.into()),
        ("part.ngc".into(), part_program()),
        ("runs.csv".into(), iso230_2_runs()),
    ];
    for (axis, length) in [('x', 200.0), ('y', 150.0)] {
        for (j, feed) in [4800.0, 7200.0, 9600.0].into_iter().enumerate() {
            out.push((
                format!("runs/{axis}-{feed}.csv"),
                straightness_run(axis, length, feed, 1.3 * j as f64),
            ));
        }
    }
    // Measurement runs of a known machine for `volcomp map build` (docs/build.md).
    out.extend(volcomp_core::example::build::files());
    out.push(("face.ngc".into(), face_program()));
    let nominal = mirror_nominal();
    out.push((
        "face.toml".into(),
        write_bspline_toml(
            nominal.surface(),
            "volcomp example: saddle z = 0.003·((x − 40)² − (y − 25)²) over 80 × 50 mm",
        ),
    ));
    out.push(("probes.csv".into(), probes(&nominal)));
    out.push(("finish.ngc".into(), finishing_program(&nominal)));
    // Ballbar traces of a known machine in three planes (docs/ballbar.md).
    out.extend(volcomp_core::example::ballbar::files());
    // A probing campaign on a synthetic machine (docs/probing.md).
    for (name, text) in volcomp_core::example::probe::example_files() {
        out.push((format!("probing/{name}"), text));
    }
    out
}

/// Writes [`files`] under `dir`.
pub fn write_all(dir: &Path) -> Result<(), String> {
    for (name, text) in files() {
        let path = dir.join(&name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
        }
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

/// The set-up of `part.ngc` on the example machine (mm).
const MACHINE: &str = "\
# volcomp set-up: where part.ngc sits on the example machine (mm)
units = \"mm\"
start = [0, 0, 250]
[work_offsets]
G54 = [250.0, 200.0, 150.0]
[tools]
1 = 75.0
[reference]
G28 = [0, 0, 250]
G30 = [0, 0, 250]
";

/// A small part in G54: a face pass, a 60 × 40 mm rectangle with rounded
/// corners and a Ø30 circle, in mm. With G54 = (250, 200, 150) every point
/// lies inside the example map (X 0 … 600, Y 0 … 400, Z 0 … 300 mm).
fn part_program() -> String {
    let mut s = String::from(
        "%\n(volcomp example part: rectangle 60 x 40 with R5 corners, circle D30)\n\
         G21 G90 G17 G54\nG0 X-40 Y-30 Z10\nG1 Z-2 F300\n",
    );
    // Face pass (zig-zag) over the rectangle.
    for k in 0..5 {
        let y = -20.0 + 10.0 * k as f64;
        let (a, b) = if k % 2 == 0 {
            (-30.0, 30.0)
        } else {
            (30.0, -30.0)
        };
        let _ = writeln!(s, "G1 X{a} Y{y} F600\nX{b}");
    }
    s.push_str("G0 Z5\nG0 X-25 Y-20\nG1 Z-5 F300\n");
    // Rectangle with R5 corners, climb milling (counter-clockwise).
    s.push_str(
        "G1 X25 Y-20 F500\nG3 X30 Y-15 R5\nG1 Y15\nG3 X25 Y20 R5\nG1 X-25\n\
         G3 X-30 Y15 R5\nG1 Y-15\nG3 X-25 Y-20 R5\nG0 Z5\n",
    );
    // Circle D30 around the origin, two depths.
    s.push_str("G0 X15 Y0\nG1 Z-3 F300\nG2 X15 Y0 I-15 J0 F500\nG1 Z-6\nG2 X15 Y0 I-15 J0\n");
    s.push_str("G0 Z10\nM2\n%\n");
    s
}

/// An ISO 230-2 bidirectional test of X: targets every 50 mm over 0 … 600
/// mm, five cycles. Truth: positioning slope 8 µm/m, ball-screw waviness
/// 1.2 µm at a 100 mm period, reversal value 2.5 µm (the reverse approach
/// lies above), repeatability scatter ±0.3 µm.
fn iso230_2_runs() -> String {
    let mut s = String::from(
        "# volcomp example: ISO 230-2 bidirectional positioning test of X (laser), deviation = actual − target\n\
         target_mm,cycle,direction,deviation_um\n",
    );
    for cycle in 1..=5 {
        for (dir, backlash, order) in [("up", 0.0, false), ("down", 2.5, true)] {
            let targets: Vec<f64> = (0..=12).map(|i| 50.0 * i as f64).collect();
            let targets: Vec<f64> = if order {
                targets.into_iter().rev().collect()
            } else {
                targets
            };
            for p in targets {
                let scatter = 0.3 * ((p * 0.37 + cycle as f64 * 2.1 + backlash).sin());
                let e = 0.008 * p + 1.2 * (2.0 * PI * p / 100.0 + 0.4).sin() + backlash + scatter;
                let _ = writeln!(s, "{p},{cycle},{dir},{e:.3}");
            }
        }
    }
    s
}

/// A straightness run (Z deviation of the tool, µm) along `axis` at `feed`
/// mm/min: geometric truth (a 10 mm lead of 0.4 µm, a bow of 0.3 µm and a
/// slope of 2 µrad) plus a 150 Hz vibration of 0.15 µm, whose wavelength
/// changes with the feed rate, and a small deterministic scatter.
fn straightness_run(axis: char, length_mm: f64, feed: f64, phase: f64) -> String {
    let lambda = feed / 60.0 / 150.0;
    let upper = axis.to_ascii_uppercase();
    let mut s = format!(
        "# volcomp example straightness run: Z deviation along {upper}, actual − commanded\n\
         # axis = {upper}\n# feed_mm_per_min = {feed}\nposition_mm,displacement_um\n"
    );
    let n = (length_mm / 0.25).round() as usize;
    for i in 0..=n {
        let x = i as f64 * 0.25;
        let u = (x - length_mm / 2.0) / (length_mm / 2.0);
        let geometric = 0.4 * (2.0 * PI * x / 10.0 + 0.5).sin() + 0.3 * (1.0 - u * u) + 2e-3 * x;
        let scatter = 0.01 * ((i as f64 * 12.9898 + phase * 78.233).sin() * 43758.5453).fract();
        let z = geometric + 0.15 * (2.0 * PI * x / lambda + phase).sin() + scatter;
        let _ = writeln!(s, "{x:.3},{z:.5}");
    }
    s
}

/// A face-milling pass over X 20 … 180, Y 20 … 130 mm at Z 0 (machine
/// coordinates with `--work-offset 0,0,0`), inside the straightness runs.
fn face_program() -> String {
    let mut s = String::from("(volcomp example: face pass for the straightness model)\nG21 G90 G17 G54\nG0 X20 Y20 Z5\nG1 Z0 F400\n");
    for k in 0..12 {
        let y = 20.0 + 10.0 * k as f64;
        let (a, b) = if k % 2 == 0 {
            (20.0, 180.0)
        } else {
            (180.0, 20.0)
        };
        let _ = writeln!(s, "G1 X{a} Y{y} F1200\nX{b}");
    }
    s.push_str("G0 Z5\nM2\n");
    s
}

/// z = 0.003·((x − 40)² − (y − 25)²) over 80 × 50 mm, exact as a bicubic.
pub fn saddle(x: f64, y: f64) -> f64 {
    0.003 * ((x - 40.0).powi(2) - (y - 25.0).powi(2))
}

/// The saddle as a bicubic B-spline nominal surface, material below.
pub fn mirror_nominal() -> NominalSurface {
    let mut pts = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            let (x, y) = (80.0 * i as f64 / 3.0, 50.0 * j as f64 / 3.0);
            pts.push([x, y, saddle(x, y)]);
        }
    }
    let s = bspline::interpolate(&pts, 4, 4, 3, 3, &Parameterization::Uniform)
        .expect("interpolate the saddle");
    NominalSurface::new(s, MaterialSide::Below, "example").expect("a valid nominal surface")
}

/// The semi-finishing error (µm, positive = material left): 3 µm plus a
/// bowl along x and a slope along y.
fn semi_finishing_error_um(x: f64, y: f64) -> f64 {
    3.0 + 0.002 * (x - 40.0).powi(2) + 0.03 * y
}

/// 9 × 7 probe points after semi-finishing with 0.2 mm stock, on the
/// surface (probe radius already compensated), with ±0.05 µm scatter.
fn probes(n: &NominalSurface) -> String {
    let points = probe_grid(n, (9, 7), |i, j, p| {
        let scatter_um = 0.05 * ((i * 7 + j) as f64 * 1.618).sin();
        0.2 + (semi_finishing_error_um(p.x, p.y) + scatter_um) * 1e-3
    });
    format!(
        "# volcomp example: probed after semi-finishing with 0.2 mm stock (surface points, mm)\n\
         {points}"
    )
}

/// Probe points on an `ni` × `nj` grid over the 80 × 50 mm surface `n`
/// (2 mm in from its edges), each `height_mm(i, j, point)` off the surface
/// along its normal: a header line and one row `P{i}{j},i,j,x,y,z` each.
pub fn probe_grid(
    n: &NominalSurface,
    (ni, nj): (usize, usize),
    mut height_mm: impl FnMut(usize, usize, Vec3) -> f64,
) -> String {
    let mut s = String::from("id,i,j,x_mm,y_mm,z_mm\n");
    for i in 0..ni {
        for j in 0..nj {
            let (u, v) = (
                (2.0 + 76.0 * i as f64 / (ni - 1) as f64) / 80.0,
                (2.0 + 46.0 * j as f64 / (nj - 1) as f64) / 50.0,
            );
            let p = n.point(u, v);
            let q = p + n.normal(u, v) * height_mm(i, j, p);
            let _ = writeln!(s, "P{i}{j},{i},{j},{:.6},{:.6},{:.6}", q.x, q.y, q.z);
        }
    }
    s
}

/// Ball-end finishing (radius 3 mm, CL point at the tip): eight passes along
/// x over the saddle.
fn finishing_program(n: &NominalSurface) -> String {
    let passes = finishing_passes(n, 3.0, (0..8).map(|pass| (3.0 + 6.2 * pass as f64) / 50.0));
    format!(
        "%\nO1234 (volcomp example: saddle finishing, ball end R3, CL at the tip)\nG21 G90 G17 G54\nG0 Z30.\n\
         {passes}M30\n%\n"
    )
}

/// Finishing passes along x over the surface `n`, one at each surface
/// parameter `v` of `vs`, with a ball end of radius `r_mm` (CL point at the
/// tip): 41 points a pass at F600, each pass ending with a retract to Z30.
pub fn finishing_passes(n: &NominalSurface, r_mm: f64, vs: impl Iterator<Item = f64>) -> String {
    let mut s = String::new();
    for v in vs {
        for k in 0..=40 {
            let u = k as f64 / 40.0;
            let c = n.point(u, v) + n.normal(u, v) * r_mm - Vec3::new(0.0, 0.0, r_mm);
            if k == 0 {
                let _ = writeln!(s, "G0 X{:.4} Y{:.4}\nG1 Z{:.4} F600.", c.x, c.y, c.z);
            } else {
                let _ = writeln!(s, "X{:.4} Y{:.4} Z{:.4}", c.x, c.y, c.z);
            }
        }
        s.push_str("G0 Z30.\n");
    }
    s
}
