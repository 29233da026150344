//! A synthetic thermal test of the example machine (travel 600 × 400 ×
//! 300 mm, chain `w X' Y' b Z t`): polynomial component errors that drift
//! linearly with three temperature signals, and ball-array measurements with
//! probing noise, for `volcomp thermal example` and the documentation.

use crate::identify::thermal::artifact::{
    simulate_measurement, standard_placements, BallArray, Placement, PlacementMeasurement,
};
use crate::identify::thermal::poly::PolyModel;
use crate::model::kinematic::Kinematics;
use crate::model::topology::Topology;
use crate::rng::Rng;
use volcomp_gcode::Vec3;

/// Axis ranges (mm).
pub const RANGES_MM: [[f64; 2]; 3] = [[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]];

/// The example's polynomial model (order 2, probe at the gauge point).
pub fn poly_model() -> PolyModel {
    PolyModel::new(Kinematics::new(Topology::SEED), RANGES_MM, 2)
}

/// The example artifact: 11 spheres 28 mm apart (280 mm: fits the 300 mm Z travel).
pub fn artifact() -> BallArray {
    BallArray::uniform(11, 28.0)
}

/// The example placements (all 22 [`standard_placements`]).
pub fn placements() -> Vec<Placement> {
    standard_placements(RANGES_MM, 280.0)
}

/// Sensor names of the example.
pub const SENSORS: [&str; 3] = ["bed_C", "column_C", "ambient_C"];

/// `(name, cold value, drift per kelvin of the three sensors)`.
pub const TRUTH: [(&str, f64, [f64; 3]); 18] = [
    ("EXX.P1", 6.0, [3.5, 0.4, 0.8]),
    ("EXX.P2", 1.5, [0.0, 0.0, 0.0]),
    ("EYY.P1", -4.0, [0.4, 2.4, 0.5]),
    ("EYY.P2", 1.0, [0.0, 0.0, 0.0]),
    ("EZZ.P1", 5.0, [0.2, 2.2, 0.3]),
    ("EYX.P2", 2.0, [0.6, 0.0, 0.0]),
    ("EZX.P2", -1.5, [0.0, 0.0, 0.0]),
    ("EXY.P2", 1.2, [0.0, 0.4, 0.0]),
    ("EXZ.P2", 0.8, [0.0, 0.0, 0.0]),
    ("EYZ.P2", -1.1, [0.0, 0.3, 0.0]),
    ("EAX.P1", 3.0, [0.0, 0.0, 0.0]),
    ("EBX.P1", 4.0, [0.0, 0.9, 0.3]),
    ("ECX.P1", -3.0, [0.8, 0.0, 0.0]),
    ("EAY.P1", 2.5, [0.0, 1.2, 0.0]),
    ("EBY.P1", -2.0, [0.0, 0.0, 0.0]),
    ("S_xy", 10.0, [1.5, 0.0, 0.0]),
    ("S_yz", -8.0, [0.0, 2.5, 0.0]),
    ("S_zx", 6.0, [0.0, -2.0, 0.5]),
];

/// The true parameters at temperatures `t_c` (°C, reference 20 °C).
pub fn truth(model: &PolyModel, t_c: &[f64]) -> Vec<f64> {
    let mut theta = vec![0.0; model.len()];
    for (name, cold, drift) in TRUTH {
        if let Some(i) = model.index(name) {
            theta[i] = cold
                + drift
                    .iter()
                    .zip(t_c)
                    .map(|(d, t)| d * (t - 20.0))
                    .sum::<f64>();
        }
    }
    theta
}

/// Temperatures (°C) of test 0 (training: warm-up, spindle stop at 14 h)
/// or test 1 (check: slower warm-up, shifted ambient) at `time_h`.
pub fn temperatures(test: usize, time_h: f64) -> Vec<f64> {
    // Per test: the bed's rise (K) and time constant (h); the column's rise
    // (K), time constant (h), spindle stop (h) and cooling time constant
    // (h); the ambient's daily swing (K), its phase (h) and shift (K).
    const COURSES: [[f64; 9]; 2] = [
        [3.0, 6.0, 5.0, 2.0, 14.0, 3.0, 1.5, 8.0, 0.0],
        [2.5, 8.0, 4.0, 3.0, 18.0, 2.5, 1.2, 11.0, 0.3],
    ];
    let [bed_k, bed_h, column_k, column_h, stop_h, cool_h, ambient_k, phase_h, shift_k] =
        COURSES[test.min(1)];
    let t = time_h;
    let tau = std::f64::consts::TAU;
    let column = if t < stop_h {
        column_k * (1.0 - (-t / column_h).exp())
    } else {
        column_k * (1.0 - (-stop_h / column_h).exp()) * (-(t - stop_h) / cool_h).exp()
    };
    vec![
        20.0 + bed_k * (1.0 - (-t / bed_h).exp()),
        20.0 + column,
        20.0 + ambient_k * (tau * (t - phase_h) / 24.0).sin() + shift_k,
    ]
}

/// One simulated test: times (h), temperatures and measured placements per
/// cycle, with `noise_um` probing noise (seeded). The machine's truth is
/// evaluated with the HTM form.
pub fn simulate_test(
    test: usize,
    cycles: usize,
    step_h: f64,
    noise_um: f64,
    seed: u64,
) -> (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<PlacementMeasurement>>) {
    let model = poly_model();
    let array = artifact();
    let places = placements();
    let mut rng = Rng::new(seed);
    let mut times = Vec::new();
    let mut temps = Vec::new();
    let mut meas = Vec::new();
    for c in 0..cycles {
        let t = c as f64 * step_h;
        let tc = temperatures(test, t);
        let theta = truth(&model, &tc);
        let dev = |q: Vec3| model.deviation_um(&theta, q, Vec3::ZERO, true);
        meas.push(
            places
                .iter()
                .map(|p| simulate_measurement(&array, p, &dev, noise_um, &mut rng))
                .collect(),
        );
        times.push(t);
        temps.push(tc);
    }
    (times, temps, meas)
}

/// The artifact file text.
pub fn artifact_csv(array: &BallArray) -> String {
    let mut s = String::from(
        "# calibrated distance of each sphere from sphere 1 (mm)\nsphere,distance_mm\n",
    );
    for (i, d) in array.distances_mm.iter().enumerate() {
        s.push_str(&format!("{},{}\n", i + 1, crate::io::numfmt::mm(*d)));
    }
    s
}

/// The measurement file text.
pub fn measurements_csv(times: &[f64], meas: &[Vec<PlacementMeasurement>]) -> String {
    let mut s = String::from(
        "# measured sphere centres in machine coordinates (mm), one row per sphere\n\
         cycle,time_h,placement,sphere,x_mm,y_mm,z_mm\n",
    );
    for (c, (t, places)) in times.iter().zip(meas).enumerate() {
        for (p, m) in places.iter().enumerate() {
            for (j, q) in m.centres_mm.iter().enumerate() {
                s.push_str(&format!(
                    "{c},{},{},{},{:.5},{:.5},{:.5}\n",
                    crate::io::numfmt::hours(*t),
                    p + 1,
                    j + 1,
                    q.x,
                    q.y,
                    q.z
                ));
            }
        }
    }
    s
}

/// The temperature file text.
pub fn temperatures_csv(sensors: &[&str], times: &[f64], temps: &[Vec<f64>]) -> String {
    let mut s = format!("cycle,time_h,{}\n", sensors.join(","));
    for (c, (t, v)) in times.iter().zip(temps).enumerate() {
        let vals: Vec<String> = v.iter().map(|x| format!("{x:.3}")).collect();
        s.push_str(&format!(
            "{c},{},{}\n",
            crate::io::numfmt::hours(*t),
            vals.join(",")
        ));
    }
    s
}

/// The example's input files as `(file name, text)`: the artifact, and the
/// measurements and temperatures of a training test (`train`, seed 7) and a
/// check test (`check`, seed 8), 12 cycles every 2 h with 0.5 µm probing
/// noise each.
pub fn example_files() -> Vec<(String, String)> {
    let array = artifact();
    let mut files: Vec<(String, String)> = vec![("artifact.csv".into(), artifact_csv(&array))];
    for (test, name, seed) in [(0, "train", 7u64), (1, "check", 8)] {
        let (times, temps, meas) = simulate_test(test, 12, 2.0, 0.5, seed);
        files.push((
            format!("measurements_{name}.csv"),
            measurements_csv(&times, &meas),
        ));
        files.push((
            format!("temperatures_{name}.csv"),
            temperatures_csv(&SENSORS, &times, &temps),
        ));
    }
    files
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn example_files_are_the_artifact_and_two_tests() {
        let files = example_files();
        let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "artifact.csv",
                "measurements_train.csv",
                "temperatures_train.csv",
                "measurements_check.csv",
                "temperatures_check.csv"
            ]
        );
        // 12 cycles: a header and 12 rows of temperatures; the two tests
        // differ (different seeds and temperature histories).
        assert_eq!(files[2].1.lines().count(), 13);
        assert_ne!(files[1].1, files[3].1);
        assert_eq!(files[0].1, artifact_csv(&artifact()));
    }
}
