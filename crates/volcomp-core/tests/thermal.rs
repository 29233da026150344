//! Thermal identification, regression and compensation on a synthetic
//! machine whose truth is defined here: polynomial component errors drifting
//! linearly with three temperature signals, measured with a ball array and
//! 0.5 µm probing noise.

use volcomp_core::identify::thermal::artifact::{
    simulate_measurement, standard_placements, BallArray, Placement, PlacementMeasurement,
};
use volcomp_core::identify::thermal::identify::{
    identify, Identification, DEFAULT_RELATIVE_THRESHOLD,
};
use volcomp_core::identify::thermal::legendre::legendre;
use volcomp_core::identify::thermal::poly::PolyModel;
use volcomp_core::identify::thermal::regression::Regression;
use volcomp_core::identify::thermal::uncertainty::{analytic_std_um, monte_carlo};
use volcomp_core::io::model_file;
use volcomp_core::model::kinematic::Kinematics;
use volcomp_core::model::topology::Topology;
use volcomp_core::model::{Components, ErrorModel, ALL_FORWARD};
use volcomp_core::rng::Rng;
use volcomp_gcode::Vec3;

const RANGES: [[f64; 2]; 3] = [[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]];
const NOISE_UM: f64 = 0.5;

/// The truth's model: order 3.
fn model() -> PolyModel {
    model_of(3)
}

fn model_of(order: usize) -> PolyModel {
    PolyModel::new(Kinematics::new(Topology::SEED), RANGES, order)
}

fn array() -> BallArray {
    BallArray::uniform(11, 48.0)
}

/// (name, value at 20 °C, drift per K of sensors 0, 1, 2).
const TRUTH: &[(&str, f64, [f64; 3])] = &[
    ("EXX.P1", 8.0, [4.6, 0.3, 0.6]),
    ("EXX.P2", -2.0, [0.3, 0.0, 0.0]),
    ("EXX.P3", 1.0, [0.0, 0.0, 0.0]),
    ("EYY.P1", -5.0, [0.3, 3.4, 0.4]),
    ("EYY.P3", 0.8, [0.0, 0.0, 0.0]),
    ("EZZ.P1", 4.0, [0.1, 2.9, 0.2]),
    ("EZZ.P2", 1.2, [0.0, 0.2, 0.0]),
    ("EYX.P2", 2.5, [0.7, 0.0, 0.0]),
    ("EZX.P2", -1.5, [0.0, 0.0, 0.2]),
    ("EZX.P3", 0.6, [0.0, 0.0, 0.0]),
    ("EXY.P2", 1.4, [0.0, 0.5, 0.0]),
    ("EZY.P2", -1.0, [0.0, 0.0, 0.0]),
    ("EXZ.P2", 0.9, [0.0, 0.3, 0.0]),
    ("EYZ.P2", -1.2, [0.0, 0.4, 0.0]),
    ("EAX.P1", 3.0, [0.5, 0.0, 0.0]),
    ("EBX.P1", 4.0, [0.0, 1.0, 0.3]),
    ("EBX.P2", 1.5, [0.0, 0.0, 0.0]),
    ("ECX.P1", -3.5, [1.0, 0.0, 0.0]),
    ("EAY.P1", 2.5, [0.0, 1.4, 0.0]),
    ("EBY.P1", -2.0, [0.0, 0.5, 0.0]),
    // Invisible at the probe (zero Abbe arm on this chain): still part of the truth.
    ("ECY.P1", 2.0, [0.0, 0.5, 0.0]),
    ("EAZ.P1", 3.0, [0.0, 0.8, 0.0]),
    ("S_xy", 12.0, [2.0, 0.0, 0.0]),
    ("S_yz", -8.0, [0.0, 3.0, 0.0]),
    ("S_zx", 6.0, [0.0, -2.5, 0.6]),
];

fn truth(m: &PolyModel, t_c: &[f64]) -> Vec<f64> {
    let mut theta = vec![0.0; m.len()];
    for (name, cold, drift) in TRUTH {
        let i = m.index(name).unwrap_or_else(|| panic!("{name}"));
        theta[i] = cold + (0..3).map(|s| drift[s] * (t_c[s] - 20.0)).sum::<f64>();
    }
    theta
}

/// Three temperature signals (°C) of test 0 (training) and test 1 (check).
fn temperatures(test: usize, t: f64) -> Vec<f64> {
    let tau = std::f64::consts::TAU;
    if test == 0 {
        let spindle = if t < 12.0 {
            5.0 * (1.0 - (-t / 2.0).exp())
        } else {
            5.0 * (1.0 - (-6.0f64).exp()) * (-(t - 12.0) / 3.0).exp()
        };
        vec![
            20.0 + 3.0 * (1.0 - (-t / 6.0).exp()),
            20.0 + spindle,
            20.0 + 1.5 * (tau * (t - 8.0) / 24.0).sin(),
        ]
    } else {
        let spindle = if t < 16.0 {
            4.0 * (1.0 - (-t / 3.0).exp())
        } else {
            4.0 * (1.0 - (-16.0f64 / 3.0).exp()) * (-(t - 16.0) / 2.5).exp()
        };
        vec![
            20.0 + 2.5 * (1.0 - (-t / 8.0).exp()),
            20.0 + spindle,
            20.3 + 1.2 * (tau * (t - 11.0) / 24.0).sin(),
        ]
    }
}

/// The 22 standard placements of a 480 mm array; every sphere inside the box.
fn placements() -> Vec<Placement> {
    let p = standard_placements(RANGES, 480.0);
    for pl in &p {
        for c in pl.centres_mm(&array()) {
            for a in 0..3 {
                assert!(
                    c[a] >= RANGES[a][0] - 1e-9 && c[a] <= RANGES[a][1] + 1e-9,
                    "{c:?}"
                );
            }
        }
    }
    p
}

fn measure(
    m: &PolyModel,
    theta: &[f64],
    places: &[Placement],
    rng: &mut Rng,
) -> Vec<PlacementMeasurement> {
    let dev = |q: Vec3| m.deviation_um(theta, q, Vec3::ZERO, true);
    places
        .iter()
        .map(|p| simulate_measurement(&array(), p, &dev, NOISE_UM, rng))
        .collect()
}

struct Test {
    temps: Vec<Vec<f64>>,
    truths: Vec<Vec<f64>>,
    idents: Vec<Identification>,
}

/// Simulates a test on the order-3 truth and identifies with order `order`.
fn run_test(test: usize, cycles: usize, seed: u64, order: usize) -> Test {
    let m = model();
    let fit = model_of(order);
    let places = placements();
    let mut rng = Rng::new(seed);
    let mut out = Test {
        temps: vec![],
        truths: vec![],
        idents: vec![],
    };
    for c in 0..cycles {
        let tc = temperatures(test, c as f64);
        let theta = truth(&m, &tc);
        let meas = measure(&m, &theta, &places, &mut rng);
        out.idents.push(
            identify(
                &fit,
                &array(),
                &meas,
                Vec3::ZERO,
                DEFAULT_RELATIVE_THRESHOLD,
            )
            .unwrap(),
        );
        out.temps.push(tc);
        out.truths.push(theta);
    }
    out
}

#[test]
fn legendre_values_and_orthogonality() {
    // P2(x) = (3x² − 1)/2, P3(x) = (5x³ − 3x)/2, P4(x) = (35x⁴ − 30x² + 3)/8.
    for x in [-1.0, -0.3, 0.0, 0.7, 1.0] {
        let p = legendre(4, x);
        assert!((p[2] - (3.0 * x * x - 1.0) / 2.0).abs() < 1e-14);
        assert!((p[3] - (5.0 * x * x * x - 3.0 * x) / 2.0).abs() < 1e-14);
        assert!((p[4] - (35.0 * x.powi(4) - 30.0 * x * x + 3.0) / 8.0).abs() < 1e-14);
    }
    // ∫_{−1}^{1} P_m P_n dξ = 2/(2n + 1)·δ_mn (composite Simpson, 2000 panels).
    let n = 2000;
    let h = 2.0 / n as f64;
    for a in 0..5 {
        for b in 0..5 {
            let mut s = 0.0;
            for i in 0..=n {
                let x = -1.0 + i as f64 * h;
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let p = legendre(4, x);
                s += w * p[a] * p[b];
            }
            s *= h / 3.0;
            let expect = if a == b {
                2.0 / (2.0 * a as f64 + 1.0)
            } else {
                0.0
            };
            assert!((s - expect).abs() < 1e-9, "P{a}·P{b}: {s}");
        }
    }
}

#[test]
fn identification_recovers_the_identifiable_parameters() {
    let m = model();
    let t = run_test(0, 12, 11, 3);
    let id0 = &t.idents[0];
    // The chain w X' Y' b Z t with the probe at the measuring point: the Abbe
    // arm of Y is along Z only and Z has none, so ECY, ECZ, EAZ, EBZ act on
    // nothing the probe sees — exactly these 12 parameters are unidentifiable.
    let unident: Vec<String> = (0..m.len())
        .filter(|&i| id0.theta[i].is_none())
        .map(|i| m.params[i].name())
        .collect();
    let expected: Vec<String> = m
        .params
        .iter()
        .map(|p| p.name())
        .filter(|n| ["ECY", "ECZ", "EAZ", "EBZ"].contains(&&n[..3]))
        .collect();
    assert_eq!(unident, expected);
    assert_eq!(id0.rank, m.len() - expected.len());
    // Within 3σ for ≥ 95 % over all cycles.
    let (mut inside, mut total) = (0, 0);
    let mut worst_ratio = 0.0f64;
    for (id, th) in t.idents.iter().zip(&t.truths) {
        let s0 = id.sigma0_um.unwrap();
        assert!((s0 / NOISE_UM - 1.0).abs() < 0.3, "σ0 = {s0}");
        for i in id.identifiable() {
            let err = id.theta[i].unwrap() - th[i];
            let sig = id.sigma[i].unwrap();
            total += 1;
            if err.abs() < 3.0 * sig {
                inside += 1;
            }
            worst_ratio = worst_ratio.max(err.abs() / sig);
        }
    }
    let share = inside as f64 / total as f64;
    let sig: Vec<f64> = id0
        .identifiable()
        .iter()
        .map(|&i| id0.sigma[i].unwrap())
        .collect();
    eprintln!(
        "identification: {inside}/{total} within 3σ ({:.1} %), worst |error|/σ = {worst_ratio:.2}, \
         σ range {:.3}…{:.3}, σ0 = {:.3} µm",
        share * 100.0,
        sig.iter().cloned().fold(f64::INFINITY, f64::min),
        sig.iter().cloned().fold(0.0, f64::max),
        id0.sigma0_um.unwrap()
    );
    assert!(share >= 0.95, "{share}");
}

#[test]
fn a_poor_orientation_set_is_reported_rank_deficient() {
    let m = model();
    // Three arrays all along X: nothing moves Y or Z.
    let places: Vec<Placement> = [[50.0, 100.0], [300.0, 450.0], [500.0, 150.0]]
        .iter()
        .map(|&[y, z]| Placement::between(Vec3::new(100.0, y, z), Vec3::new(700.0, y, z)))
        .collect();
    let theta = truth(&m, &[20.0, 20.0, 20.0]);
    let meas = measure(&m, &theta, &places, &mut Rng::new(3));
    let id = identify(&m, &array(), &meas, Vec3::ZERO, DEFAULT_RELATIVE_THRESHOLD).unwrap();
    assert!(id.rank < 10, "rank {}", id.rank);
    assert!(!id.null_space.is_empty());
    for name in ["EYY.P1", "EZZ.P2", "S_yz", "EAY.P1"] {
        assert_eq!(id.theta[m.index(name).unwrap()], None, "{name}");
    }
    // Along X only the positioning of X is seen directly.
    for name in ["EXX.P1", "EXX.P2", "EXX.P3"] {
        let i = m.index(name).unwrap();
        let err = id.theta[i].unwrap() - theta[i];
        assert!(err.abs() < 4.0 * id.sigma[i].unwrap(), "{name}: {err}");
    }
}

#[test]
fn monte_carlo_matches_the_analytic_propagation() {
    let m = model();
    let t = run_test(0, 1, 5, 3);
    let id = &t.idents[0];
    let line: Vec<Vec3> = (0..=8)
        .map(|i| Vec3::new(100.0 * i as f64, 300.0, 250.0))
        .collect();
    let bands = monte_carlo(&m, id, &line, Vec3::ZERO, 2000, 42);
    for (q, b) in line.iter().zip(&bands) {
        let a = analytic_std_um(&m, id, *q, Vec3::ZERO);
        for c in 0..3 {
            if a[c] > 1e-6 {
                assert!(
                    (b.std_um[c] / a[c] - 1.0).abs() < 0.1,
                    "{q:?} {c}: {b:?} vs {a:?}"
                );
                // 95 % band ≈ ±1.96σ.
                let w = (b.hi_um[c] - b.lo_um[c]) / (2.0 * 1.96 * a[c]);
                assert!((w - 1.0).abs() < 0.15, "{w}");
            }
        }
    }
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

#[test]
fn regression_predicts_the_other_test_and_compensation_beats_the_study() {
    // Order 2 fits an order-3 truth: at 0.5 µm probing noise the lower
    // order's smaller variance outweighs its bias (order 3 gives −60 % on Y).
    let order = 2;
    let truth_model = model();
    let m = model_of(order);
    let train = run_test(0, 24, 17, order);
    let check = run_test(1, 24, 23, order);
    // Truth in the fitted layout (parameters the fit lacks are model error).
    let check_truths: Vec<Vec<f64>> = check
        .truths
        .iter()
        .map(|th| {
            m.params
                .iter()
                .map(|p| truth_model.index(&p.name()).map_or(0.0, |i| th[i]))
                .collect()
        })
        .collect();
    let ident = train.idents[0].identifiable();
    let outputs: Vec<Vec<f64>> = train
        .idents
        .iter()
        .map(|id| ident.iter().map(|&i| id.theta[i].unwrap()).collect())
        .collect();
    let reg = Regression::fit(&train.temps, &outputs, 0).unwrap();

    // Prediction of the check test's parameters vs its truth.
    let (mut pred_err, mut drift) = (vec![], vec![]);
    let mut predicted = vec![];
    for (c, th) in check_truths.iter().enumerate() {
        let p = reg.predict(&check.temps, c).unwrap();
        for (k, &i) in ident.iter().enumerate() {
            pred_err.push(p[k] - th[i]);
            drift.push(th[i] - check_truths[0][i]);
        }
        let mut full = vec![None; m.len()];
        for (k, &i) in ident.iter().enumerate() {
            full[i] = Some(p[k]);
        }
        predicted.push(full);
    }
    // Parameters with a real drift (RMS change > 2σ of one identification):
    // the regression trained on test 0 must predict test 1 to within 15 %.
    let n = ident.len();
    let (mut e_sig, mut d_sig) = (vec![], vec![]);
    for (k, &i) in ident.iter().enumerate() {
        let e: Vec<f64> = pred_err.iter().skip(k).step_by(n).cloned().collect();
        let d: Vec<f64> = drift.iter().skip(k).step_by(n).cloned().collect();
        if rms(&d) > 2.0 * train.idents[0].sigma[i].unwrap() {
            eprintln!(
                "{:8} drift RMS {:.3}, prediction error RMS {:.3}",
                m.params[i].name(),
                rms(&d),
                rms(&e)
            );
            e_sig.extend(e);
            d_sig.extend(d);
        }
    }
    let ratio = rms(&e_sig) / rms(&d_sig);
    eprintln!(
        "regression: drifting parameters predicted with RMS error {:.3} vs RMS drift {:.3} ({:.1} %); \
         all identifiable parameters: {:.3} vs {:.3}",
        rms(&e_sig),
        rms(&d_sig),
        100.0 * ratio,
        rms(&pred_err),
        rms(&drift)
    );
    assert!(e_sig.len() >= 4 * 24, "too few drifting parameters");
    assert!(ratio < 0.15, "{ratio}");

    // TCP error along X, Y and Z lines through the middle of the volume,
    // compensated (direct, q = t − e_pred(t)) with the predicted model as
    // written to and read back from the 21-component model files.
    let mid = Vec3::new(400.0, 300.0, 250.0);
    let cold: Vec<Option<f64>> = train.idents[0].theta.clone();
    let to_model = |theta: &[Option<f64>]| {
        let km = m.to_kinematic_model(theta, 81);
        let toml = model_file::model_to_toml(&km, "t.csv", None);
        let csv = model_file::components_to_csv(&km.axes);
        model_file::parse_model(&toml, "t.toml", &mut |_| Ok(("t.csv".into(), csv.clone())))
            .unwrap()
    };
    for (axis, need) in [(0, 0.50), (1, 0.65), (2, 0.65)] {
        let (mut none, mut comp, mut cold_comp) = (vec![], vec![], vec![]);
        for (c, th) in check.truths.iter().enumerate() {
            let pred_model = to_model(&predicted[c]);
            let cold_model = to_model(&cold);
            for i in 0..=40 {
                let mut t = mid;
                t[axis] = RANGES[axis][0] + (RANGES[axis][1] - RANGES[axis][0]) * i as f64 / 40.0;
                let actual_err =
                    |q: Vec3| q + truth_model.deviation_um(th, q, Vec3::ZERO, true) * 1e-3 - t;
                none.push(actual_err(t).norm() * 1e3);
                let e = pred_model
                    .deviation_um(t, ALL_FORWARD, Components::All)
                    .unwrap();
                comp.push(actual_err(t - e * 1e-3).norm() * 1e3);
                let e = cold_model
                    .deviation_um(t, ALL_FORWARD, Components::All)
                    .unwrap();
                cold_comp.push(actual_err(t - e * 1e-3).norm() * 1e3);
            }
        }
        let (a, b, c) = (rms(&none), rms(&comp), rms(&cold_comp));
        eprintln!(
            "axis {}: RMS TCP error {a:.2} µm uncompensated, {c:.2} µm with the cold model, \
             {b:.2} µm with the predicted model: −{:.0} % vs none, −{:.0} % vs cold",
            ['X', 'Y', 'Z'][axis],
            100.0 * (1.0 - b / a),
            100.0 * (1.0 - b / c)
        );
        assert!(1.0 - b / a >= need, "axis {axis}: {a} → {b}");
        assert!(b < c, "the thermal prediction must beat the cold model");
    }
}
