//! A synthetic machine for the circular test, every cause known (scale,
//! backlash, lateral play, squareness, cyclic errors), and the example
//! traces of docs/ballbar.md: its tests in the three planes with 0.2 µm of
//! noise (a fixed seed of the crate's generator: the same files every run).

use crate::ballbar::{predict, Plane, TestCircle};
use crate::model::axis_table::{AxisTableMap, CSV_HEADER};
use crate::rng::Rng;
use std::f64::consts::PI;

/// A synthetic machine, each cause known. Scale `s` (µm/m), backlash `b`
/// and lateral play `l` (µm) per axis, squareness S_xy, S_yz, S_zx (µrad),
/// cyclic amplitude (sine, cosine; µm) and pitch (mm) per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Machine {
    /// Scale error of X, Y, Z (µm/m).
    pub s: [f64; 3],
    /// Backlash (reverse above forward, µm).
    pub b: [f64; 3],
    /// Lateral play of X, Y, Z across to the next axis (X → Y → Z → X), µm.
    pub l: [f64; 3],
    /// Squareness S_xy, S_yz, S_zx (µrad).
    pub sq: [f64; 3],
    /// Cyclic error per axis: sine and cosine amplitude (µm).
    pub cyc: [[f64; 2]; 3],
    /// Lead-screw pitch per axis (mm).
    pub pitch: [f64; 3],
}

impl Machine {
    /// Axis `a`'s error vector (µm) at position `x` (mm), moving in
    /// reverse or not: scale, ±b/2 along, ±l/2 across (on the next axis),
    /// cyclic along, squareness on Y and Z.
    pub fn table(&self, a: usize, x: f64, reverse: bool) -> [f64; 3] {
        let sign = if reverse { 0.5 } else { -0.5 };
        let mut e = [0.0; 3];
        let w = 2.0 * PI * x / self.pitch[a];
        e[a] = self.s[a] * x / 1000.0
            + sign * self.b[a]
            + self.cyc[a][0] * w.sin()
            + self.cyc[a][1] * w.cos();
        e[(a + 1) % 3] += sign * self.l[a];
        // Squareness (docs/design.md): e_x += S_xy·y + S_zx·z, e_y += S_yz·z.
        match a {
            1 => e[0] += self.sq[0] * x / 1000.0,
            2 => {
                e[0] += self.sq[2] * x / 1000.0;
                e[1] += self.sq[1] * x / 1000.0;
            }
            _ => {}
        }
        e
    }

    /// The machine as an axis-table map over `[lo, hi]` per axis, every `h` mm.
    pub fn map(&self, lo: f64, hi: f64, h: f64) -> AxisTableMap {
        let mut csv = format!("{CSV_HEADER}\n");
        let n = ((hi - lo) / h).round() as usize;
        for a in 0..3 {
            for (dir, rev) in [("forward", false), ("reverse", true)] {
                for i in 0..=n {
                    let x = lo + (hi - lo) * i as f64 / n as f64;
                    let e = self.table(a, x, rev);
                    csv += &format!(
                        "{},{dir},{x},{},{},{}\n",
                        ["X", "Y", "Z"][a],
                        e[0],
                        e[1],
                        e[2]
                    );
                }
            }
        }
        AxisTableMap::from_csv(&csv, "synthetic.csv").unwrap()
    }
}

/// The machine behind the example traces.
pub const EXAMPLE: Machine = Machine {
    s: [10.0, -6.0, 4.0],
    b: [3.0, 4.0, 2.0],
    l: [0.8, 0.0, 0.0],
    sq: [20.0, -12.0, 8.0],
    cyc: [[0.3, 0.0], [0.0, 0.0], [0.0, 0.0]],
    pitch: [10.0, 10.0, 10.0],
};

/// The example machine's map `ballbar/machine.csv` (every 1 mm over 0…600
/// mm: the cyclic error's linear interpolation is within 0.015 µm) and its
/// traces `ballbar/xy.csv`, `yz.csv`, `zx.csv`: R 100 mm about (300, 200,
/// 150), F 1000, both runs, every 0.5°, 0.2 µm of noise.
pub fn files() -> Vec<(String, String)> {
    let map = EXAMPLE.map(0.0, 600.0, 1.0);
    let mut rng = Rng::new(2304);
    let mut out = vec![("ballbar/machine.csv".to_string(), map.to_csv())];
    out.extend(Plane::ALL.iter().map(|&plane| {
        let t = TestCircle {
            plane,
            centre_mm: volcomp_gcode::Vec3::new(300.0, 200.0, 150.0),
            step_deg: 0.5,
            ..TestCircle::default()
        };
        let mut trace = predict(&map, &t).expect("the example machine covers the circles");
        for run in &mut trace.runs {
            for d in &mut run.deviation_um {
                *d += 0.2 * rng.normal();
            }
        }
        (
            format!("ballbar/{}.csv", plane.name().to_ascii_lowercase()),
            crate::ballbar::trace::write(&trace),
        )
    }));
    out
}
