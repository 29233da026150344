//! `compensate` in a rotated coordinate system (G10 L2 … R): the corrected
//! axis points are written back through the inverse rotation as program
//! words. Checked by reading the output back (`volcomp moves`, which agrees
//! with rs274 on rotated programs: fixture `rotated_g10_r.ngc`) and applying
//! the map by hand: the machine then lands on the nominal points.

use std::collections::BTreeMap;
use std::path::Path;

use crate::common;
use common::{read, tempdir, volcomp, write};

/// A map with a pitch error on X of 2 µm per mm (e_x = 0.002·x mm) and a
/// Z error growing with Y by 1 µm per mm (e_z = 0.001·y mm), or zero.
fn write_map(dir: &Path, zero: bool) {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for a in ["X", "Y", "Z"] {
        for k in 0..=100 {
            let p = -500.0 + 10.0 * k as f64;
            let (ex, ez) = match (a, zero) {
                (_, true) => (0.0, 0.0),
                ("X", _) => (2.0 * p, 0.0),
                ("Y", _) => (0.0, p),
                _ => (0.0, 0.0),
            };
            csv.push_str(&format!("{a},both,{p},{ex},0,{ez}\n"));
        }
    }
    write(dir, "map.csv", csv);
}

const PROGRAM: &str = "G21 G90 G17\nG10 L2 P1 X20 Y10 R30\nG0 X0 Y0 Z5\nG1 X10 Y0 Z-1 F300\nG1 X10 Y10\nG91 G1 X5\nG90 G2 X25 Y10 I5 J0\nG1 Y20\nG0 Z5\nM2\n";

/// Axis end points of `volcomp moves FILE`, with their output line numbers.
fn moves(dir: &Path, file: &str) -> Vec<(u64, [f64; 3])> {
    let o = volcomp(&["moves", file], dir);
    common::ok(&o);
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |i: usize| f[i].parse::<f64>().unwrap();
            (f[0].parse().unwrap(), [n(4), n(5), n(6)])
        })
        .collect()
}

/// For each original line, the axis end point of its last output motion
/// (output lines carry `(volcomp Ln)` when a line was split).
fn ends_by_original_line(dir: &Path, out: &str) -> Vec<(u64, [f64; 3])> {
    let text = std::fs::read_to_string(dir.join(out)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let mut by = BTreeMap::new();
    for (line, q) in moves(dir, out) {
        let l = lines[(line - 1) as usize];
        if let Some(i) = l.find("(volcomp L") {
            let n: u64 = l[i + 10..]
                .split(|c: char| !c.is_ascii_digit())
                .next()
                .unwrap()
                .parse()
                .unwrap();
            by.insert(n, q);
        }
    }
    by.into_iter().collect()
}

fn compensate(dir: &Path) {
    write(dir, "rot.ngc", PROGRAM);
    let o = volcomp(
        &[
            "compensate",
            "--map",
            "map.csv",
            "--output",
            "out.ngc",
            // Fixed segments: the map is affine, so adaptive splitting
            // would leave the lines whole, and the split lines' trace
            // comments are what pairs the output with the original here.
            "--segment-length",
            "1",
            "rot.ngc",
        ],
        dir,
    );
    common::ok(&o);
}

/// Writes the map (`zero`: without error) and compensates the program into
/// out.ngc; returns the program's own end points by line.
fn compensated(dir: &Path, zero: bool) -> BTreeMap<u64, [f64; 3]> {
    write_map(dir, zero);
    compensate(dir);
    moves(dir, "rot.ngc").into_iter().collect()
}

#[test]
fn compensated_rotated_program_lands_on_the_nominal_points() {
    let dir = tempdir("rotated-lin");
    let nominal = compensated(&dir, false);
    let ends = ends_by_original_line(&dir, "out.ngc");
    assert!(ends.len() >= 4, "{ends:?}");
    let mut largest_correction = 0.0f64;
    for (line, q) in ends {
        // Where the machine goes for command q: q + e(q).
        let actual = [q[0] + 0.002 * q[0], q[1], q[2] + 0.001 * q[1]];
        let n = nominal[&line];
        for a in 0..3 {
            // 4 written decimals: within 0.1 µm.
            assert!(
                (actual[a] - n[a]).abs() < 1e-4,
                "line {line}: {actual:?} vs {n:?}"
            );
            largest_correction = largest_correction.max((q[a] - n[a]).abs());
        }
    }
    // The corrections are real (tens of µm), not a rounding artefact.
    assert!(largest_correction > 0.02, "{largest_correction}");
    // A correction along axis X changes both program words: the G91 X-only
    // line (program X is at 30° to axis X) is written with a Y increment.
    let out = read(&dir, "out.ngc");
    let g91 = out.lines().find(|l| l.starts_with("G91")).unwrap();
    assert!(g91.contains('X') && g91.contains('Y'), "{g91}");
}

#[test]
fn zero_map_leaves_the_rotated_path_unchanged() {
    let dir = tempdir("rotated-zero");
    let nominal = compensated(&dir, true);
    for (line, q) in ends_by_original_line(&dir, "out.ngc") {
        let n = nominal[&line];
        for a in 0..3 {
            assert!((q[a] - n[a]).abs() < 1e-4, "line {line}: {q:?} vs {n:?}");
        }
    }
    // The original lines that are not split stay as written.
    let out = read(&dir, "out.ngc");
    for l in ["G10 L2 P1 X20 Y10 R30", "G0 X0 Y0 Z5", "M2"] {
        assert!(out.lines().any(|o| o == l), "{l} missing:\n{out}");
    }
}
