//! The ballbar against outside references: an independent dead-band
//! simulation, synthetic machines with known causes.

use super::*;
use crate::example::ballbar::Machine;
use crate::model::axis_table::AxisTableMap;
use crate::rng::Rng;
use std::f64::consts::PI;

/// An independent dead-band simulation, written from the physical picture:
/// each axis' carriage sits at a fraction `β ∈ [0, 1]` across its band
/// (0: engaged forward, 1: engaged in reverse) and moves across it at the
/// motor's speed over the band's width `b`; the axis' tables act as
/// `E_fwd + β (E_rev − E_fwd)`. The circle is followed in steps of 0.001°.
fn independent(m: &Machine, t: &TestCircle) -> Vec<Vec<f64>> {
    let step = 0.001_f64;
    let per = (t.step_deg / step).round() as usize;
    let ov = (t.overshoot_deg / step).round() as usize;
    let n = t.samples();
    let mut beta: [Option<f64>; 3] = [None; 3];
    let mut q_prev: Option<volcomp_gcode::Vec3> = None;
    let mut out = vec![vec![0.0; n]; t.senses.len()];
    for (r, sense) in t.senses.iter().enumerate() {
        let sg = sense.sign();
        let total = 2 * ov + n * per;
        for i in 0..=total {
            if r > 0 && i == 0 {
                continue;
            }
            let a = t.start_deg - sg * t.overshoot_deg + sg * step * i as f64;
            let q = t.plane.point(t.centre_mm, t.radius_mm, a.to_radians());
            if let Some(p) = q_prev {
                for k in 0..3 {
                    let dq = q[k] - p[k];
                    if dq == 0.0 {
                        continue;
                    }
                    beta[k] = Some(match beta[k] {
                        None => f64::from(u8::from(dq < 0.0)),
                        Some(b0) if m.b[k] > 0.0 => (b0 - dq * 1000.0 / m.b[k]).clamp(0.0, 1.0),
                        Some(_) => f64::from(u8::from(dq < 0.0)),
                    });
                }
            }
            q_prev = Some(q);
            if i >= ov && i < ov + n * per && (i - ov).is_multiple_of(per) {
                let mut e = [0.0; 3];
                for k in 0..3 {
                    let f = m.table(k, q[k], false);
                    let v = m.table(k, q[k], true);
                    let bk = beta[k].unwrap_or(0.0);
                    for c in 0..3 {
                        e[c] += f[c] + bk * (v[c] - f[c]);
                    }
                }
                let mut d = 0.0;
                for c in 0..3 {
                    let x = q[c] + e[c] * 1e-3 - t.centre_mm[c];
                    d += x * x;
                }
                out[r][(i - ov) / per] = (d.sqrt() - t.radius_mm) * 1e3;
            }
        }
    }
    out
}

fn machine_a() -> Machine {
    Machine {
        s: [12.0, -8.0, 5.0],
        b: [4.0, 2.5, 3.0],
        l: [1.0, -0.8, 0.5],
        sq: [15.0, -20.0, 10.0],
        cyc: [[0.6, -0.3], [0.0, 0.4], [0.2, 0.0]],
        pitch: [10.0, 16.0, 5.0],
    }
}

fn machine_b() -> Machine {
    Machine {
        s: [-20.0, 6.0, -4.0],
        b: [1.5, 6.0, 0.0],
        l: [-0.6, 0.0, 1.2],
        sq: [-35.0, 8.0, -12.0],
        cyc: [[0.0, 0.0], [0.5, 0.5], [0.0, -0.3]],
        pitch: [20.0, 10.0, 8.0],
    }
}

/// Gaussian noise of `sigma_um` on every sample of `trace`, run by run.
fn add_noise(trace: &mut Trace, sigma_um: f64, rng: &mut Rng) {
    for run in &mut trace.runs {
        for d in &mut run.deviation_um {
            *d += sigma_um * rng.normal();
        }
    }
}

/// `m`'s map over the tests' volume, its circle in XY sampled every
/// `step_deg`, and the trace predicted for it.
fn xy_trace(m: &Machine, step_deg: f64) -> (AxisTableMap, TestCircle, Trace) {
    let map = m.map(0.0, 300.0, 0.05);
    let t = test_circle(Plane::XY, step_deg);
    let trace = predict(&map, &t).unwrap();
    (map, t, trace)
}

/// The fit's options with the pitches of `m`'s cyclic errors given.
fn pitched(m: &Machine) -> FitOptions {
    FitOptions {
        pitch_mm: m.pitch.map(Some),
        ..FitOptions::default()
    }
}

/// The tests' circle in `plane`, sampled every `step_deg`.
fn test_circle(plane: Plane, step_deg: f64) -> TestCircle {
    TestCircle {
        plane,
        centre_mm: volcomp_gcode::Vec3::new(150.0, 140.0, 130.0),
        radius_mm: 100.0,
        step_deg,
        ..TestCircle::default()
    }
}

#[test]
fn predict_agrees_with_an_independent_dead_band_simulation() {
    for m in [machine_a(), machine_b()] {
        let map = m.map(0.0, 300.0, 0.05);
        for plane in Plane::ALL {
            let t = test_circle(plane, 0.5);
            let trace = predict(&map, &t).unwrap();
            let want = independent(&m, &t);
            for (run, w) in trace.runs.iter().zip(&want) {
                for (i, (got, w)) in run.deviation_um.iter().zip(w).enumerate() {
                    assert!(
                        (got - w).abs() <= 0.05,
                        "{plane:?} {:?} sample {i} at {}°: {got} vs {w}",
                        run.sense,
                        run.angle_deg[i]
                    );
                }
            }
        }
    }
}

/// The truth of each cause of `m` in `plane` about `centre` (mm).
fn truth(m: &Machine, plane: Plane, centre: [f64; 3], r: f64) -> Vec<(String, f64)> {
    let (u, v) = plane.axes();
    let (nu, nv) = plane.axis_names();
    let pl = plane.name();
    // Squareness of the plane, and its part in the centre's offset.
    let sq = match plane {
        Plane::XY => m.sq[0],
        Plane::YZ => m.sq[1],
        Plane::ZX => m.sq[2],
    };
    // The centre's offset: what every axis adds at the centre, the
    // in-plane axes averaged over their two directions without their own
    // cyclic error (fitted apart), the third axis as it stands (forward:
    // it never moves in this test).
    let w = 3 - u - v;
    let mut off = [0.0; 3];
    for a in [u, v] {
        let f = m.table(a, centre[a], false);
        let rv = m.table(a, centre[a], true);
        let ww = 2.0 * PI * centre[a] / m.pitch[a];
        for c in 0..3 {
            off[c] += (f[c] + rv[c]) / 2.0;
        }
        off[a] -= m.cyc[a][0] * ww.sin() + m.cyc[a][1] * ww.cos();
    }
    let f = m.table(w, centre[w], false);
    for c in 0..3 {
        off[c] += f[c];
    }
    let (cu, cv) = (off[u], off[v]);
    let mut t = vec![
        (format!("centre_{nu}"), cu),
        (format!("centre_{nv}"), cv),
        ("radius".into(), r / 1000.0 * (m.s[u] + m.s[v]) / 2.0),
        (format!("scale_mismatch_{pl}"), m.s[u] - m.s[v]),
        (format!("squareness_{pl}"), sq),
        (format!("servo_mismatch_{pl}"), 0.0),
        (format!("backlash_{nu}+"), m.b[u]),
        (format!("backlash_{nu}-"), m.b[u]),
        (format!("backlash_{nv}+"), m.b[v]),
        (format!("backlash_{nv}-"), m.b[v]),
        (format!("reversal_spike_{nu}+"), 0.0),
        (format!("reversal_spike_{nu}-"), 0.0),
        (format!("reversal_spike_{nv}+"), 0.0),
        (format!("reversal_spike_{nv}-"), 0.0),
        (format!("cyclic_{nu}_sin"), m.cyc[u][0]),
        (format!("cyclic_{nu}_cos"), m.cyc[u][1]),
        (format!("cyclic_{nv}_sin"), m.cyc[v][0]),
        (format!("cyclic_{nv}_cos"), m.cyc[v][1]),
    ];
    // Lateral play of u shows when it acts along v (the next axis is v).
    // (the synthetic machine's play acts on the next axis, X → Y → Z → X).
    let seen = |a: usize, b: usize| if (a + 1) % 3 == b { m.l[a] } else { 0.0 };
    t.push((format!("lateral_play_{nu}"), seen(u, v)));
    t.push((format!("lateral_play_{nv}"), seen(v, u)));
    t
}

#[test]
fn fit_recovers_each_cause_within_three_standard_uncertainties() {
    let mut worst: f64 = 0.0;
    for (mi, m) in [machine_a(), machine_b()].iter().enumerate() {
        let map = m.map(0.0, 300.0, 0.05);
        for (pi, plane) in Plane::ALL.into_iter().enumerate() {
            let t = test_circle(plane, 0.1);
            let clean = predict(&map, &t).unwrap();
            for seed in 0..3u64 {
                let mut rng = Rng::new(100 * seed + 10 * mi as u64 + pi as u64);
                let noise = 0.1 + 0.1 * seed as f64;
                let mut trace = clean.clone();
                add_noise(&mut trace, noise, &mut rng);
                let options = pitched(m);
                let f = fit(&trace, &options).unwrap();
                for (id, want) in truth(m, plane, t.centre_mm.to_array(), t.radius_mm) {
                    let c = f.cause(&id).unwrap_or_else(|| panic!("{id}"));
                    let z = (c.value - want) / c.std;
                    worst = worst.max(z.abs());
                    if z.abs() > 2.0 {
                        eprintln!("z {z:.2} machine {mi} {plane:?} seed {seed} {id}");
                    }
                    assert!(
                        z.abs() <= 3.0,
                        "machine {mi} {plane:?} seed {seed}: {id} = {} ± {} against {want} (z {z:.2})",
                        c.value,
                        c.std
                    );
                }
                assert!(f.residual_rms_um < 1.2 * noise, "{}", f.residual_rms_um);
            }
        }
    }
    eprintln!("largest |z| {worst:.2}");
}

/// Writes the program of a test, for a look by hand.
#[test]
fn the_program_of_a_test() {
    let t = test_circle(Plane::ZX, 0.1);
    let p = program::program(&t).unwrap();
    std::fs::write(std::env::temp_dir().join("ballbar-zx.ngc"), &p).unwrap();
    eprintln!("{p}");
}

/// The test's own program, run through the program path, gives the same
/// trace as the direct prediction.
#[test]
fn the_test_program_predicts_the_same_trace() {
    let (map, t, direct) = xy_trace(&machine_a(), 1.0);
    let text = program::program(&t).unwrap();
    let setup = crate::compensate::MachineSetup::default();
    let via = predict::predict_program(&map, &t, text.as_bytes(), "t.ngc", &setup).unwrap();
    for (a, b) in direct.runs.iter().zip(&via.runs) {
        for i in 0..a.angle_deg.len() {
            assert!((a.angle_deg[i] - b.angle_deg[i]).abs() < 1e-9);
            assert!(
                (a.deviation_um[i] - b.deviation_um[i]).abs() < 0.05,
                "{:?} {}°: {} vs {}",
                a.sense,
                a.angle_deg[i],
                a.deviation_um[i],
                b.deviation_um[i]
            );
        }
    }
}

/// The quick model from three planes, given to `compensate` (take-ups as
/// blocks of their own), takes at least 70 % of the circular deviation
/// away on the machine's tests (the figures: docs/ballbar.md).
#[test]
fn the_quick_map_reduces_the_circular_deviation() {
    for (mi, m) in [machine_a(), machine_b()].iter().enumerate() {
        let map = m.map(0.0, 300.0, 0.05);
        let mut fits = Vec::new();
        let mut rng = Rng::new(42 + mi as u64);
        for plane in Plane::ALL {
            let t = test_circle(plane, 0.2);
            let mut trace = predict(&map, &t).unwrap();
            add_noise(&mut trace, 0.2, &mut rng);
            let options = pitched(m);
            fits.push((plane, t.radius_mm, fit(&trace, &options).unwrap()));
        }
        let refs: Vec<(Plane, f64, &TraceFit)> = fits.iter().map(|(p, r, f)| (*p, *r, f)).collect();
        let quick = quick_map::quick_model(&refs, m.pitch.map(Some)).unwrap();
        let qmap = quick.map([[0.0, 300.0]; 3]).unwrap();
        for plane in Plane::ALL {
            let t = test_circle(plane, 0.2);
            let before = figures(&predict(&map, &t).unwrap()).unwrap();
            let text = program::program(&t).unwrap();
            let mut out = Vec::new();
            // The defaults: the test program states G61, so every take-up
            // keeps the path within the contour tolerance or is a block.
            crate::Compensator::new(&qmap)
                .run(text.as_bytes(), &mut out)
                .unwrap();
            let setup = crate::compensate::MachineSetup::default();
            let after_trace =
                predict::predict_program(&map, &t, out.as_slice(), "c.ngc", &setup).unwrap();
            let after = figures(&after_trace).unwrap();
            eprintln!(
                "machine {mi} {plane:?}: G {:.3} → {:.3} µm, H {:.3} → {:.3}",
                before.g_um,
                after.g_um,
                before.h_um.unwrap(),
                after.h_um.unwrap()
            );
            assert!(after.g_um <= 0.3 * before.g_um, "{before:?} {after:?}");
        }
    }
}

/// The reported uncertainties are the spread of the estimates: over many
/// noise draws on the same machine, `(value − truth)/std` has a standard
/// deviation near 1 for every cause.
#[test]
fn the_standard_uncertainties_are_the_scatter_of_the_estimates() {
    let m = machine_b();
    let (_, t, clean) = xy_trace(&m, 0.25);
    let truth = truth(&m, Plane::XY, t.centre_mm.to_array(), t.radius_mm);
    let mut z: Vec<Vec<f64>> = vec![Vec::new(); truth.len()];
    let options = pitched(&m);
    for seed in 0..40u64 {
        let mut rng = Rng::new(1000 + seed);
        let mut trace = clean.clone();
        add_noise(&mut trace, 0.2, &mut rng);
        let f = fit(&trace, &options).unwrap();
        for (k, (id, want)) in truth.iter().enumerate() {
            let c = f.cause(id).unwrap();
            z[k].push((c.value - want) / c.std);
        }
    }
    for ((id, _), zs) in truth.iter().zip(&z) {
        let n = zs.len() as f64;
        let mean = zs.iter().sum::<f64>() / n;
        let sd = (zs.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
        eprintln!("{id}: mean z {mean:.2}, rms z {sd:.2}");
        // 40 draws: the RMS of 40 standard normals lies in [0.75, 1.25]
        // with probability > 99.5 %; a bias shows as a mean off 0.
        assert!((0.7..=1.3).contains(&sd), "{id}: rms z {sd}");
        assert!(mean.abs() < 0.6, "{id}: mean z {mean}");
    }
}

/// One run only, another radius and sample step: every cause the fit
/// gives (no servo mismatch) is still within three standard uncertainties.
#[test]
fn fit_recovers_the_causes_from_one_run_and_other_test_sizes() {
    for (sense, radius, step) in [(Sense::Ccw, 150.0, 0.5), (Sense::Cw, 50.0, 0.2)] {
        let m = machine_a();
        let map = m.map(-100.0, 400.0, 0.05);
        let t = TestCircle {
            radius_mm: radius,
            senses: vec![sense],
            ..test_circle(Plane::XY, step)
        };
        let mut trace = predict(&map, &t).unwrap();
        let mut rng = Rng::new(7);
        add_noise(&mut trace, 0.15, &mut rng);
        let options = pitched(&m);
        let f = fit(&trace, &options).unwrap();
        assert!(f.cause("servo_mismatch_XY").is_none());
        for (id, want) in truth(&m, Plane::XY, t.centre_mm.to_array(), radius) {
            let Some(c) = f.cause(&id) else { continue };
            let z = (c.value - want) / c.std;
            assert!(
                z.abs() <= 3.0,
                "{sense:?} R{radius}: {id} = {} ± {} against {want}",
                c.value,
                c.std
            );
        }
    }
}

/// A program that does not run the test's path is refused, not cut into
/// runs that are not there.
#[test]
fn a_program_that_is_not_the_test_is_refused() {
    let map = machine_a().map(0.0, 300.0, 0.5);
    let t = test_circle(Plane::XY, 0.1);
    let setup = crate::compensate::MachineSetup::default();
    for text in [
        "G21 G90\nG0 X50 Y140 Z130\nG1 X250 F1000\nM2\n",
        "G21 G90\nM2\n",
        // Only the first run of the two the test has.
        "G21 G90 G17\nG0 Z130\nG0 X50 Y140\nF1000\nG3 X250 Y140 I100 J0\nG3 X250 Y140 I-100 J0\nG3 X50 Y140 I-100 J0\nM2\n",
    ] {
        let e = predict::predict_program(&map, &t, text.as_bytes(), "p.ngc", &setup).unwrap_err();
        assert!(e.to_string().contains("does not run the test's path"), "{e}");
    }
}
