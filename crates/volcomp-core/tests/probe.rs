//! Calibration with a touch probe on synthetic machines (docs/probing.md):
//! a 21-component truth with reversal, probing noise of 0.3–0.5 µm,
//! direction-dependent pre-travel, artifacts with errors of their own
//! (uncalibrated plates off by 1–3 µm per sphere) placed up to 0.3 mm and
//! 0.5 mrad away from where they were described. The touches are those the
//! generated plans make, found on the true machine by bisection
//! (`volcomp_core::example::probe`). Expected values come from the truth:
//! the identified parameters are compared with the truth's field projected
//! onto the model's parameters (and a rigid motion, which no probing can
//! see), the compensated error with the true one at held-out points.

use volcomp_core::example::probe::{
    log_text, plan_options, plate_toml, simulate, RealArtifact, SyntheticMachine, GAUGE,
    PROBE_LENGTH_MM, RANGES_MM, REFERENCE,
};
use volcomp_core::identify::probe::artifact::{parse_artifact, Artifact};
use volcomp_core::identify::probe::fit::fit_touches;
use volcomp_core::identify::probe::identify::{identify, Identified, IdentifyOptions, Status};
use volcomp_core::identify::probe::plan::plan;
use volcomp_core::identify::probe::program::Frame;
use volcomp_core::identify::probe::result::{kinematic_model, reversal, rms_modulo_rigid};
use volcomp_core::io::probe_log::{read_linuxcnc_log, Touch};
use volcomp_core::model::{Components, Direction, ErrorModel};
use volcomp_core::rng::Rng;
use volcomp_gcode::Vec3;

struct Campaign {
    machine: SyntheticMachine,
    artifacts: Vec<Artifact>,
    touches: Vec<Touch>,
}

/// Probes `texts` (artifact descriptions) on a random machine.
fn campaign(seed: u64, noise_um: f64, texts: &[String]) -> Campaign {
    let machine = SyntheticMachine::random(seed, 2, RANGES_MM, noise_um);
    let mut rng = Rng::new(seed ^ 0xABCD);
    let o = plan_options();
    let frame = Frame {
        work_offset_mm: Vec3::ZERO,
        tool_length_mm: PROBE_LENGTH_MM,
    };
    let mut artifacts = Vec::new();
    let mut touches = Vec::new();
    for (i, t) in texts.iter().enumerate() {
        let art = parse_artifact(t, &format!("a{i}.toml")).unwrap();
        let real = RealArtifact::new(art.clone(), &mut rng);
        let p = plan(&art, None, &o).unwrap();
        let sim = simulate(&machine, &real, &p, PROBE_LENGTH_MM, "x.log", &mut rng);
        assert!(
            sim.iter().all(|t| t.tripped),
            "every planned touch meets its artifact"
        );
        // Through the LinuxCNC log format and back (six decimals).
        let log = log_text(&art.name, &sim, &frame);
        touches.extend(read_linuxcnc_log(&log, &format!("a{i}.log")).unwrap());
        artifacts.push(art);
    }
    Campaign {
        machine,
        artifacts,
        touches,
    }
}

/// The truth's geometric field projected onto the model's parameters and a
/// rigid motion (least squares over a 7×7×7 grid at the probe's length).
fn projected_truth(m: &SyntheticMachine, id: &Identified) -> Vec<f64> {
    use nalgebra::{DMatrix, DVector};
    let pts = volcomp_core::identify::probe::result::grid(RANGES_MM, 7);
    let tool = Vec3::new(0.0, 0.0, id.probe_length_mm);
    let n = id.model.len();
    let c = Vec3::new(300.0, 200.0, 150.0);
    let rows = 3 * pts.len();
    let mut a = DMatrix::zeros(rows, n + 6);
    let mut b = DVector::zeros(rows);
    for (i, q) in pts.iter().enumerate() {
        let basis = id.model.basis_um(*q, tool);
        let e = m.geometric_um(*q, id.probe_length_mm);
        for k in 0..3 {
            for (j, bj) in basis.iter().enumerate() {
                a[(3 * i + k, j)] = bj[k];
            }
            a[(3 * i + k, n + k)] = 1.0;
            for r in 0..3 {
                let mut w = Vec3::ZERO;
                w[r] = 1.0;
                a[(3 * i + k, n + 3 + r)] = w.cross(*q - c)[k] * 1e-3;
            }
            b[3 * i + k] = e[k];
        }
    }
    let svd = a.svd(true, true);
    let x = svd.solve(&b, 1e-9).unwrap();
    (0..n).map(|j| x[j]).collect()
}

fn all_texts() -> Vec<String> {
    vec![REFERENCE.to_string(), plate_toml(), GAUGE.to_string()]
}

#[test]
fn the_example_campaign_identifies_the_machine_within_its_uncertainty() {
    let c = campaign(2026, 0.4, &all_texts());
    let fitted = fit_touches(&c.artifacts, &c.touches).unwrap();
    let cal = &fitted.calibrations[0];
    println!(
        "tip {:?} truth {}",
        cal.tip_radius_mm, c.machine.tip_radius_mm
    );
    println!(
        "pretravel {:?} truth {:?}",
        cal.pretravel_um, c.machine.pretravel_um
    );
    println!(
        "reversal {:?} truth {:?}",
        cal.reversal_um, c.machine.reversal_um
    );
    println!("sigma {}", fitted.sigma_um);
    let o = IdentifyOptions {
        ranges_mm: RANGES_MM,
        ..IdentifyOptions::default()
    };
    let id = identify(&c.artifacts, &fitted, &o).unwrap();
    let truth = projected_truth(&c.machine, &id);
    let names: Vec<String> = id.model.params.iter().map(|p| p.name()).collect();
    let mut worst: f64 = 0.0;
    for p in &id.params {
        let i = names.iter().position(|n| *n == p.name);
        match (p.status, i) {
            (Status::Identified(e), Some(i)) => {
                let z = (e.value - truth[i]) / e.sigma;
                println!(
                    "{:8} {:10.3} ± {:7.3}  truth {:10.3}  z {:6.2}",
                    p.name, e.value, e.sigma, truth[i], z
                );
                worst = worst.max(z.abs());
            }
            (s, _) => println!("{:8} {:?}", p.name, s),
        }
    }
    println!("sigma0 {:?} rank {}", id.ident.sigma0_um, id.ident.rank);
    for n in &id.notes {
        println!("note {n}");
    }
    for comb in &id.combinations {
        println!("comb {comb}");
    }
    println!("worst z {worst}");
    // Held-out points: random positions and direction states.
    let rev = reversal(&fitted);
    let km = kinematic_model(&id, &rev);
    let mut rng = Rng::new(99);
    let mut pts = Vec::new();
    let mut before = Vec::new();
    let mut after = Vec::new();
    for _ in 0..400 {
        let q = Vec3::new(
            600.0 * rng.uniform(),
            400.0 * rng.uniform(),
            300.0 * rng.uniform(),
        );
        let s = [0, 1, 2].map(|_| {
            if rng.uniform() < 0.5 {
                Direction::Forward
            } else {
                Direction::Reverse
            }
        });
        let e = c.machine.deviation_um(q, s, PROBE_LENGTH_MM);
        let em = km
            .deviation_with_tool_um(q, s, Components::All, Vec3::new(0.0, 0.0, PROBE_LENGTH_MM))
            .unwrap();
        pts.push(q);
        before.push(e);
        after.push(e - em);
    }
    let (b, a) = (
        rms_modulo_rigid(&pts, &before),
        rms_modulo_rigid(&pts, &after),
    );
    println!(
        "RMS before {b:.3} after {a:.3}: {:.1} % removed",
        100.0 * (1.0 - a / b)
    );
    assert!(a < 0.2 * b);
    assert!(worst < 3.0);
}
