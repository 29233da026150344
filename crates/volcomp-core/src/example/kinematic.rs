//! A realistic 21-component model of the example machining centre (the
//! machine of [`crate::example`]: travel X 0…600, Y 0…400, Z 0…300 mm, table
//! on X, X on Y, spindle on Z), for tests, documentation and the demo.
//!
//! Synthetic but shaped like laser-interferometer data of such a machine
//! every 25 mm: positioning slopes of 8–15 µm/m with a reversal value of
//! 2–4 µm, guideway bows of 2–3 µm in straightness, pitch, yaw and roll of a
//! few µrad (linear trends and bows, the same in both directions), and
//! squareness errors of 6–12 µrad. Measured along lines through
//! (300, 200, 150) mm with the reflector 100 mm below the spindle nose.

use super::bow_at;
use crate::model::kinematic::{
    AxisComponents, ComponentTable, KinematicModel, Kinematics, MeasuringLine, Squareness,
};
use crate::model::topology::Topology;
use volcomp_gcode::Vec3;

/// Travel (mm) of X, Y, Z.
pub const TRAVEL_MM: [f64; 3] = [600.0, 400.0, 300.0];

/// Table spacing (mm).
pub const SPACING_MM: f64 = 25.0;

/// Where the example machine's linear errors were measured (axis positions, mm).
pub const MEASURING_POINT_MM: Vec3 = Vec3::new(300.0, 200.0, 150.0);

/// Tool length offset of the reflector during the measurement (mm).
pub const MEASURING_TOOL_LENGTH_MM: f64 = 100.0;

/// `v` rounded to `decimals` places (the nearest double to that decimal).
fn round(v: f64, decimals: i32) -> f64 {
    let k = 10f64.powi(decimals);
    (v * k).round() / k + 0.0
}

/// The example model (HTM form, not clamped, no tool).
pub fn example_model() -> KinematicModel {
    // Per axis: [positioning µm/m, reversal µm, straightness bows (next, next-but-one) µm,
    //            angular: [trend, bow, offset] µrad for rotations about X, Y, Z]
    struct Shape {
        slope_um_per_m: f64,
        reversal_um: f64,
        bow_um: [f64; 2],
        angles_urad: [[f64; 3]; 3],
    }
    let shapes = [
        Shape {
            slope_um_per_m: 12.0,
            reversal_um: 3.0,
            bow_um: [3.0, -2.5],
            // EAX roll, EBX pitch, ECX yaw
            angles_urad: [[0.0, 4.0, -1.0], [12.0, 0.0, -4.0], [3.0, -6.0, 0.0]],
        },
        Shape {
            slope_um_per_m: -8.0,
            reversal_um: 4.0,
            bow_um: [2.0, -2.0],
            // EAY pitch, EBY roll, ECY yaw
            angles_urad: [[8.0, 0.0, -3.0], [0.0, 3.0, 0.0], [0.0, -5.0, 2.0]],
        },
        Shape {
            slope_um_per_m: 15.0,
            reversal_um: 2.0,
            bow_um: [1.5, -2.0],
            // EAZ, EBZ tilt the spindle, ECZ roll
            angles_urad: [[6.0, 0.0, -2.0], [0.0, -4.0, 1.0], [0.0, 2.0, 0.0]],
        },
    ];
    let axes = [0, 1, 2].map(|a| {
        let sh = &shapes[a];
        let len = TRAVEL_MM[a];
        let n = (len / SPACING_MM).round() as usize;
        let positions: Vec<f64> = (0..=n).map(|k| k as f64 * SPACING_MM).collect();
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let angular: Vec<Vec3> = positions
            .iter()
            .map(|&x| {
                let u = x / len;
                let bow = bow_at(x, len);
                let mut g = Vec3::ZERO;
                for (k, [trend, bw, offset]) in sh.angles_urad.iter().enumerate() {
                    g[k] = round(trend * u + bw * bow + offset, 2);
                }
                g
            })
            .collect();
        let linear = |reverse: bool| -> Vec<Vec3> {
            positions
                .iter()
                .map(|&x| {
                    let bow = bow_at(x, len);
                    let mut e = Vec3::ZERO;
                    e[a] = sh.slope_um_per_m * x * 1e-3
                        + 0.6 * (std::f64::consts::TAU * x / 150.0).sin()
                        + if reverse { sh.reversal_um } else { 0.0 };
                    e[b] = sh.bow_um[0] * bow;
                    e[c] = sh.bow_um[1] * bow;
                    e.map(|v| round(v, 3))
                })
                .collect()
        };
        let table = |reverse: bool| {
            ComponentTable::new(positions.clone(), linear(reverse), angular.clone())
                .unwrap_or_else(|| unreachable!("example positions increase"))
        };
        AxisComponents {
            forward: table(false),
            reverse: table(true),
        }
    });
    let line = MeasuringLine {
        point_mm: MEASURING_POINT_MM,
        tool_offset_mm: Vec3::new(0.0, 0.0, MEASURING_TOOL_LENGTH_MM),
    };
    let kinematics = Kinematics {
        topology: Topology::SEED,
        measuring: [line; 3],
        squareness: Squareness {
            xy_urad: 12.0,
            yz_urad: -8.0,
            zx_urad: 6.0,
        },
        angles: crate::model::kinematic::AngleConvention::Relative,
    };
    KinematicModel::new(axes, kinematics)
}

/// The example as files: the TOML description naming `csv_name`, and the CSV.
pub fn example_files(csv_name: &str) -> (String, String) {
    let m = example_model();
    (
        crate::io::model_file::model_to_toml(
            &m,
            csv_name,
            Some("volcomp example: mid-size vertical machining centre, synthetic laser data every 25 mm"),
        ),
        crate::io::model_file::components_to_csv(&m.axes),
    )
}
