//! The bundled example: a realistic axis-table map of a mid-size vertical
//! machining centre and the test programs of the published work (circles
//! Ø20 and Ø50 as 10–30 line segments, a Ø20 spiral with 1 mm pitch and 60
//! segments per turn).
//!
//! The map is synthetic but shaped like laser measurements of such machines:
//! a positioning slope (thermal/pitch error of the ball screw), a cyclic
//! error at the screw lead, guideway bows in both straightness directions,
//! a squareness-like linear straightness term, and backlash: the reverse
//! positioning table lies a few µm above the forward one (docs/design.md, "Direction state and backlash").

pub mod ballbar;
pub mod build;
pub mod kinematic;
pub mod probe;
pub mod thermal;

use crate::model::axis_table::{AxisTableMap, AxisTables, Table};
use volcomp_gcode::Vec3;

/// Work offset (G54, machine coordinates, mm) the demo programs run at.
pub const DEMO_WORK_OFFSET_MM: Vec3 = Vec3::new(250.0, 200.0, 150.0);

/// Travel of the example machine (mm): X 0…600, Y 0…400, Z 0…300.
pub const TRAVEL_MM: [f64; 3] = [600.0, 400.0, 300.0];

struct AxisShape {
    slope_um_per_m: f64,
    lead_mm: f64,
    cyclic_um: f64,
    bow1_um: f64,
    bow2_um: f64,
    linear_um_per_m: f64,
    backlash_um: f64,
}

/// The shape of an axis' bow at `x_mm` over its travel `len_mm`: 0 at the
/// ends, 1 in the middle (a parabola).
fn bow_at(x_mm: f64, len_mm: f64) -> f64 {
    let u = x_mm / len_mm;
    4.0 * u * (1.0 - u)
}

/// The example map, tables every 2 mm.
pub fn example_map() -> AxisTableMap {
    let shapes = [
        AxisShape {
            slope_um_per_m: 12.0,
            lead_mm: 16.0,
            cyclic_um: 0.9,
            bow1_um: 4.0,
            bow2_um: -3.0,
            linear_um_per_m: 0.0,
            backlash_um: 3.0,
        },
        AxisShape {
            slope_um_per_m: -9.0,
            lead_mm: 10.0,
            cyclic_um: 0.7,
            bow1_um: -3.5,
            bow2_um: 2.5,
            linear_um_per_m: 20.0,
            backlash_um: 4.0,
        },
        AxisShape {
            slope_um_per_m: 15.0,
            lead_mm: 12.0,
            cyclic_um: 0.6,
            bow1_um: 2.0,
            bow2_um: -2.5,
            linear_um_per_m: -15.0,
            backlash_um: 2.0,
        },
    ];
    let axes = [0, 1, 2].map(|a| {
        let sh = &shapes[a];
        let len = TRAVEL_MM[a];
        let n = (len / 2.0) as usize;
        let positions: Vec<f64> = (0..=n).map(|k| k as f64 * 2.0).collect();
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let table = |reverse: bool| {
            let errors_um = positions
                .iter()
                .map(|&x| {
                    let bow = bow_at(x, len);
                    let mut e = Vec3::ZERO;
                    e[a] = sh.slope_um_per_m * x * 1e-3
                        + sh.cyclic_um * (std::f64::consts::TAU * x / sh.lead_mm).sin()
                        + if reverse { sh.backlash_um } else { 0.0 };
                    e[b] = sh.bow1_um * bow
                        + sh.linear_um_per_m * x * 1e-3
                        + if reverse { 0.3 } else { 0.0 };
                    e[c] = sh.bow2_um * bow
                        + 0.2 * (std::f64::consts::TAU * x / (3.0 * sh.lead_mm)).sin();
                    e.map(|v| (v * 1e4).round() / 1e4)
                })
                .collect();
            Table {
                positions_mm: positions.clone(),
                errors_um,
            }
        };
        AxisTables {
            forward: table(false),
            reverse: table(true),
        }
    });
    AxisTableMap { axes, clamp: false }
}

/// A demo program: name and G-code text.
pub struct DemoProgram {
    /// File stem.
    pub name: &'static str,
    /// What it is, for the table.
    pub title: &'static str,
    /// Program text.
    pub text: String,
}

fn polygon_program(
    title: &str,
    diameter_mm: f64,
    segments: u32,
    turns: u32,
    pitch_mm: f64,
) -> String {
    let r = diameter_mm / 2.0;
    let mut s = format!("%\n({title})\n(volcomp demo program, work offset G54)\nG21 G17 G90 G94 G54\nG0 Z5.0000\nG0 X{r:.4} Y0.0000\nG1 Z0.0000 F300\n");
    let total = segments * turns;
    for k in 1..=total {
        let phi = std::f64::consts::TAU * f64::from(k) / f64::from(segments);
        let z = -pitch_mm * f64::from(k) / f64::from(segments);
        let (x, y) = (r * phi.cos(), r * phi.sin());
        let (x, y) = (
            if x.abs() < 5e-5 { 0.0 } else { x },
            if y.abs() < 5e-5 { 0.0 } else { y },
        );
        if pitch_mm == 0.0 {
            s.push_str(&format!("G1 X{x:.4} Y{y:.4}\n"));
        } else {
            s.push_str(&format!("G1 X{x:.4} Y{y:.4} Z{z:.4}\n"));
        }
    }
    s.push_str("G0 Z5.0000\nM2\n%\n");
    s
}

/// The papers' programs.
pub fn demo_programs() -> Vec<DemoProgram> {
    vec![
        DemoProgram {
            name: "circle_d20_20seg",
            title: "circle D20, 20 segments",
            text: polygon_program("circle D20, 20 segments", 20.0, 20, 1, 0.0),
        },
        DemoProgram {
            name: "circle_d20_30seg",
            title: "circle D20, 30 segments",
            text: polygon_program("circle D20, 30 segments", 20.0, 30, 1, 0.0),
        },
        DemoProgram {
            name: "circle_d50_10seg",
            title: "circle D50, 10 segments",
            text: polygon_program("circle D50, 10 segments", 50.0, 10, 1, 0.0),
        },
        DemoProgram {
            name: "circle_d50_20seg",
            title: "circle D50, 20 segments",
            text: polygon_program("circle D50, 20 segments", 50.0, 20, 1, 0.0),
        },
        DemoProgram {
            name: "circle_d50_30seg",
            title: "circle D50, 30 segments",
            text: polygon_program("circle D50, 30 segments", 50.0, 30, 1, 0.0),
        },
        DemoProgram {
            name: "spiral_d20_p1_60seg",
            title: "spiral D20, pitch 1, 60 seg/turn",
            text: polygon_program(
                "spiral D20, pitch 1 mm, 60 segments per turn",
                20.0,
                60,
                3,
                1.0,
            ),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Components, Direction, ErrorModel};

    #[test]
    fn backlash_is_normal_and_of_the_stated_size() {
        let m = example_map();
        let q = Vec3::new(123.0, 77.0, 41.0);
        let f = m
            .deviation_um(q, [Direction::Forward; 3], Components::PositioningOnly)
            .unwrap();
        let r = m
            .deviation_um(q, [Direction::Reverse; 3], Components::PositioningOnly)
            .unwrap();
        let b = r - f;
        assert!((b.x - 3.0).abs() < 1e-3 && (b.y - 4.0).abs() < 1e-3 && (b.z - 2.0).abs() < 1e-3);
    }

    #[test]
    fn programs_close_their_circles() {
        for p in demo_programs() {
            assert!(p.text.contains("M2"));
            assert!(p.text.lines().count() > 10, "{}", p.name);
        }
    }
}
