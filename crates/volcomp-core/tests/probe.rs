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
use volcomp_core::identify::probe::identify::{
    fit_and_identify, leave_one_out, Identified, IdentifyOptions, Status,
};
use volcomp_core::identify::probe::monte_carlo;
use volcomp_core::identify::probe::plan::plan;
use volcomp_core::identify::probe::program::Frame;
use volcomp_core::identify::probe::request::FitOutput;
use volcomp_core::identify::probe::result::{kinematic_model, reversal, rms_modulo_rigid};
use volcomp_core::io::numfmt::fixed;
use volcomp_core::io::probe_log::{read_linuxcnc_log, Touch};
use volcomp_core::model::{Components, Direction, ErrorModel};
use volcomp_core::report::{Block, Table};
use volcomp_core::rng::Rng;
use volcomp_gcode::Vec3;

struct Campaign {
    machine: SyntheticMachine,
    artifacts: Vec<Artifact>,
    touches: Vec<Touch>,
    reals: Vec<RealArtifact>,
}

/// Probes `texts` (artifact descriptions) on a random machine.
fn campaign(seed: u64, noise_um: f64, texts: &[String]) -> Campaign {
    campaign2(seed, seed ^ 0xABCD, noise_um, texts)
}

/// A campaign on machine `seed` with the artifacts and noise of `draw`.
fn campaign2(seed: u64, draw: u64, noise_um: f64, texts: &[String]) -> Campaign {
    let machine = SyntheticMachine::random(seed, 2, RANGES_MM, noise_um);
    let mut rng = Rng::new(draw);
    let o = plan_options();
    let frame = Frame {
        work_offset_mm: Vec3::ZERO,
        tool_length_mm: PROBE_LENGTH_MM,
        mm_per_machine_unit: 1.0,
    };
    let mut artifacts = Vec::new();
    let mut touches = Vec::new();
    let mut reals = Vec::new();
    for (i, t) in texts.iter().enumerate() {
        let art = parse_artifact(t, &format!("a{i}.toml")).unwrap();
        let real = RealArtifact::new(art.clone(), &mut rng);
        reals.push(real.clone());
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
        reals,
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

/// How many reported standard uncertainties an identified parameter may lie
/// from the truth. The target is 3 for every parameter; measured: the worst
/// of 25 parameters is 3.4 σ on the example machine (EYY.P1) and 3.7 σ on
/// machine 2 at 0.5 µm noise (EAY.P1), under 3 on the eight other campaigns.
/// A Monte Carlo of the whole chain on the example machine (40 draws of noise
/// and artifact, `diagnostic_monte_carlo`) finds the reported σ honest to a
/// few per cent (spread / σ 0.84–1.20 per parameter, RMS z 1.05) — and a
/// parameter beyond 3 σ somewhere in 5 of the 40 campaigns, as 25 correlated
/// parameters give by chance. Bounding every campaign by 3 would need σ
/// inflated beyond the truth; the RMS of z over the campaigns is bounded
/// instead (`other_machines_noise_and_artifacts`), and single values by 4.
const Z_BOUND: f64 = 4.0;

fn all_texts() -> Vec<String> {
    vec![REFERENCE.to_string(), plate_toml(), GAUGE.to_string()]
}

/// What a campaign's identification achieved against its truth.
struct Outcome {
    /// Largest |identified − truth| / σ over the identified parameters
    /// (those in `skip` left out), and its parameter.
    worst_z: (f64, String),
    /// Identified parameters.
    identified: usize,
    /// Names of the parameters reported as not seen.
    not_seen: Vec<String>,
    /// RMS (modulo a rigid motion) of the true error and of what the model
    /// leaves, at 400 held-out points with random direction states (µm).
    before_um: f64,
    after_um: f64,
    /// |reversal − truth| / σ, largest of the three axes.
    reversal_z: f64,
    reversal: [Option<volcomp_core::identify::probe::fit::Estimate>; 3],
    id: Identified,
    fitted: volcomp_core::identify::probe::fit::Fitted,
    /// (identified − truth) / σ of every identified parameter not skipped.
    zs: Vec<f64>,
}

fn evaluate(c: &Campaign, o: &IdentifyOptions, skip: &[&str]) -> Outcome {
    let (fitted, id) = fit_and_identify(&c.artifacts, &c.touches, o).unwrap();
    let truth = projected_truth(&c.machine, &id);
    let names: Vec<String> = id.model.params.iter().map(|p| p.name()).collect();
    let mut worst = (0.0f64, String::new());
    let mut identified = 0;
    let mut not_seen = Vec::new();
    let mut zs = Vec::new();
    for p in &id.params {
        match (p.status, names.iter().position(|n| *n == p.name)) {
            (Status::Identified(e), Some(i)) => {
                identified += 1;
                let z = ((e.value - truth[i]) / e.sigma).abs();
                if !skip.contains(&p.name.as_str()) {
                    zs.push(z);
                    if z > worst.0 {
                        worst = (z, p.name.clone());
                    }
                }
            }
            (Status::NotSeen, _) => not_seen.push(p.name.clone()),
            _ => {}
        }
    }
    let rev = reversal(&fitted);
    let mut reversal_z: f64 = 0.0;
    for (e, truth) in rev.iter().zip(c.machine.reversal_um) {
        if let Some(e) = e {
            reversal_z = reversal_z.max(((e.value - truth) / e.sigma).abs());
        }
    }
    let km = kinematic_model(&id, &rev);
    let mut rng = Rng::new(99);
    let (mut pts, mut before, mut after) = (Vec::new(), Vec::new(), Vec::new());
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
    Outcome {
        worst_z: worst,
        identified,
        not_seen,
        before_um: rms_modulo_rigid(&pts, &before),
        after_um: rms_modulo_rigid(&pts, &after),
        reversal_z,
        reversal: rev,
        id,
        fitted,
        zs,
    }
}

fn options() -> IdentifyOptions {
    IdentifyOptions {
        ranges_mm: RANGES_MM,
        ..IdentifyOptions::default()
    }
}

/// The parameters a probe of one length cannot see on the seed chain
/// (docs/thermal.md, §3): ECY, EAZ, EBZ, ECZ.
fn invisible() -> Vec<String> {
    let mut v = Vec::new();
    for c in ["ECY", "EAZ", "EBZ", "ECZ"] {
        for k in 1..=2 {
            v.push(format!("{c}.P{k}"));
        }
    }
    v.sort();
    v
}

/// The plate with a certificate (its nominal centres, 0.3 µm).
fn certified_plate() -> String {
    let p = plate_toml();
    let list = p
        .lines()
        .find(|l| l.starts_with("spheres_mm"))
        .unwrap()
        .trim_start_matches("spheres_mm = ")
        .to_string();
    let at = p.find("[[placements]]").unwrap();
    format!(
        "{}[certificate]\nspheres_mm = {list}\nu_um = 0.3\n{}",
        &p[..at],
        &p[at..]
    )
}

#[test]
fn the_example_campaign_identifies_the_machine_within_its_uncertainty() {
    let c = campaign(2026, 0.4, &all_texts());
    let r = evaluate(&c, &options(), &[]);
    println!(
        "worst {:.2} σ ({}), {:.2} → {:.2} µm, reversal {:.2} σ",
        r.worst_z.0, r.worst_z.1, r.before_um, r.after_um, r.reversal_z
    );
    for p in &r.id.params {
        println!("{:8} {:?}", p.name, p.status);
    }
    assert_eq!(r.identified, 25);
    let mut ns = r.not_seen.clone();
    ns.sort();
    assert_eq!(ns, invisible());
    assert!(
        r.worst_z.0 < Z_BOUND,
        "{} off by {:.2} σ",
        r.worst_z.1,
        r.worst_z.0
    );
    assert!(r.reversal_z < 3.0, "reversal off by {:.2} σ", r.reversal_z);
    assert!(
        r.after_um < 0.2 * r.before_um,
        "{} → {}",
        r.before_um,
        r.after_um
    );
    // σ0 estimates the probing noise.
    let s0 = r.id.ident.sigma0_um.unwrap();
    assert!((s0 - 0.4).abs() < 0.1, "σ0 = {s0}");
    assert!(r.id.notes.iter().any(|n| n.contains("one probe length")));
    assert!(!r.id.scale_from_artifact);
    // A second method for the uncertainties: the whole chain repeated with
    // the touches perturbed by the probing noise agrees with the least
    // squares' covariance — a standard deviation from 10 repeats lies
    // within 0.35…2 of the true one but for a chance of 1e-3 (χ² with 9
    // degrees of freedom), 2 % over 25 parameters — and the reported σ
    // becomes the larger of the two.
    let mut id = r.id.clone();
    monte_carlo::apply(&c.artifacts, &c.touches, &options(), &mut id, 10, 7).unwrap();
    let mc = id.monte_carlo.as_ref().unwrap();
    for (p, (ls, m)) in id.params.iter().zip(mc.least_squares.iter().zip(&mc.sigma)) {
        match (p.status, ls, m) {
            (Status::Identified(e), Some(ls), Some(m)) => {
                println!("{:8} least squares {ls:.3}  Monte Carlo {m:.3}", p.name);
                assert!((0.35..2.0).contains(&(m / ls)), "{}: {ls} vs {m}", p.name);
                assert_eq!(e.sigma, ls.max(*m));
            }
            (Status::NotSeen, None, None) => {}
            other => panic!("{}: {other:?}", p.name),
        }
    }
    // The report shows both beside the σ it took, and the
    // leave-one-placement-out predictions.
    let held_out = leave_one_out(&c.artifacts, &r.fitted, &options()).unwrap();
    assert_eq!(held_out.len(), 8);
    let reversal_um = reversal(&r.fitted);
    let out = FitOutput {
        artifacts: c.artifacts.clone(),
        touches: c.touches.clone(),
        model: kinematic_model(&id, &reversal_um),
        fitted: r.fitted.clone(),
        identified: id.clone(),
        reversal_um,
        held_out: held_out.clone(),
    };
    let sections = volcomp_core::report::probe::sections(&out, RANGES_MM);
    let table = |id: &str| -> Table {
        sections
            .iter()
            .find(|s| s.id == id)
            .and_then(|s| {
                s.blocks.iter().find_map(|b| match b {
                    Block::Table(t) => Some(t.clone()),
                    _ => None,
                })
            })
            .unwrap_or_else(|| panic!("no table in {id}"))
    };
    let t = table("probe-parameters");
    assert_eq!(t.headers[3], "least squares");
    assert_eq!(t.headers[4], "Monte Carlo (10 repeats)");
    for (p, row) in id.params.iter().zip(&t.rows) {
        let i = id.params.iter().position(|q| q.name == p.name).unwrap();
        assert_eq!(row[0], p.name);
        if let Status::Identified(e) = p.status {
            let (ls, m) = (mc.least_squares[i].unwrap(), mc.sigma[i].unwrap());
            assert_eq!(row[2], fixed(e.sigma, 3));
            assert_eq!(row[3], fixed(ls, 3));
            assert_eq!(row[4], fixed(m, 3));
        } else {
            assert_eq!(&row[3..5], ["–", "–"]);
        }
    }
    let t = table("probe-held-out");
    for (h, row) in held_out.iter().zip(&t.rows) {
        assert_eq!(row[1], h.placement);
        assert_eq!(row[3], fixed(h.after_um, 3));
        assert!(h.after_um < h.before_um, "{}: {h:?}", h.placement);
    }
}

#[test]
fn other_machines_noise_and_artifacts() {
    // Several machines (seeds), noise 0.3 and 0.5 µm, the uncalibrated plate
    // with a gauge block, and a certified plate alone.
    let sets = [all_texts(), vec![REFERENCE.to_string(), certified_plate()]];
    let mut zs = Vec::new();
    for (seed, noise) in [(1u64, 0.3), (2, 0.5), (3, 0.4), (4, 0.5)] {
        for (k, texts) in sets.iter().enumerate() {
            let c = campaign(seed, noise, texts);
            let r = evaluate(&c, &options(), &[]);
            zs.extend(r.zs.iter().copied());
            println!(
                "seed {seed} noise {noise} set {k}: worst {:.2} σ ({}), {:.2} → {:.2} µm ({:.0} %), reversal {:.2} σ, σ0 {:?}",
                r.worst_z.0,
                r.worst_z.1,
                r.before_um,
                r.after_um,
                100.0 * (1.0 - r.after_um / r.before_um),
                r.reversal_z,
                r.id.ident.sigma0_um
            );
            let mut ns = r.not_seen.clone();
            ns.sort();
            assert_eq!(ns, invisible(), "seed {seed} set {k}");
            assert_eq!(r.identified, 25);
            assert!(
                r.worst_z.0 < Z_BOUND,
                "seed {seed} set {k}: {} off by {:.2} σ",
                r.worst_z.1,
                r.worst_z.0
            );
            assert!(
                r.reversal_z < 3.0,
                "seed {seed} set {k}: reversal {:.2} σ: {:?} truth {:?}",
                r.reversal_z,
                r.reversal,
                c.machine.reversal_um
            );
            assert!(
                r.after_um < 0.2 * r.before_um,
                "seed {seed} set {k}: {} → {}",
                r.before_um,
                r.after_um
            );
        }
    }
    // The uncertainties as a whole: honest ones give an RMS of |error|/σ
    // near 1 over the 200 values (sampling spread about 0.05, more with the
    // parameters' correlation); a covariance a third too small gives 1.33.
    let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
    let above = zs.iter().filter(|z| **z > 3.0).count();
    println!("{} values: RMS z {rms:.3}, {above} above 3", zs.len());
    assert!(
        rms < 1.25,
        "RMS of |error|/σ {rms:.3}: the uncertainties are optimistic"
    );
}

#[test]
fn without_a_calibrated_length_the_common_scale_is_the_artifacts() {
    let c = campaign(5, 0.4, &[REFERENCE.to_string(), plate_toml()]);
    // The positioning slopes carry the unknown common scale: left out of
    // the comparison; everything else must agree.
    let r = evaluate(&c, &options(), &["EXX.P1", "EYY.P1", "EZZ.P1"]);
    println!(
        "worst {:.2} σ ({}), {:.2} → {:.2} µm",
        r.worst_z.0, r.worst_z.1, r.before_um, r.after_um
    );
    assert!(r.id.scale_from_artifact);
    assert!(r.id.notes.iter().any(|n| n.contains("common scale")));
    assert!(
        r.worst_z.0 < Z_BOUND,
        "{} off by {:.2} σ",
        r.worst_z.1,
        r.worst_z.0
    );
}

/// Touches without noise (0.001 µm) on machine 1 with the reference
/// sphere, the uncalibrated plate and the gauge: the probe calibration and
/// every identified parameter come out as the truth put them. A certificate
/// (the gauge's, 0.1 µm) then weighs 0.01 of a touch; before the
/// identifiable subspace was decided with certificates weighing at least one
/// touch, the common scale (seen through the gauge alone) fell below the
/// relative threshold in every other pass, the field taken out of the
/// reference sphere lost 46 µm/m of scale, and the calibration came out
/// 2.0 µm small in tip radius and 1.0–1.4 µm in pre-travel.
#[test]
fn noiseless_touches_calibrate_the_probe_and_the_machine_exactly() {
    let c = campaign(1, 0.001, &all_texts());
    let (fitted, id) = fit_and_identify(&c.artifacts, &c.touches, &options()).unwrap();
    let cal = &fitted.calibrations[0];
    let m = &c.machine;
    let tip_um = (cal.tip_radius_mm.value - m.tip_radius_mm) * 1e3;
    println!("tip radius off by {tip_um:.4} µm");
    assert!(tip_um.abs() < 0.01, "tip radius off by {tip_um} µm");
    for (k, (e, truth)) in cal.pretravel_um.iter().zip(m.pretravel_um).enumerate() {
        if let Some(e) = e {
            assert!(
                (e.value - truth).abs() < 0.01,
                "pre-travel {k}: {} vs {truth}",
                e.value
            );
        }
    }
    for (e, truth) in cal.reversal_um.iter().zip(m.reversal_um) {
        let e = e.unwrap();
        assert!(
            (e.value - truth).abs() < 0.01,
            "reversal {} vs {truth}",
            e.value
        );
    }
    let truth = projected_truth(m, &id);
    let names: Vec<String> = id.model.params.iter().map(|p| p.name()).collect();
    let mut identified = 0;
    for p in &id.params {
        if let (Status::Identified(e), Some(i)) =
            (p.status, names.iter().position(|n| *n == p.name))
        {
            identified += 1;
            assert!(
                (e.value - truth[i]).abs() < 0.05,
                "{}: {} vs {}",
                p.name,
                e.value,
                truth[i]
            );
        }
    }
    assert_eq!(identified, 25);
}

#[test]
#[ignore]
fn diagnostic_calibration_z_scores() {
    use volcomp_core::identify::probe::fit::fit_touches;
    let mut zs = vec![Vec::new(); 3];
    let mut zp = Vec::new();
    for seed in 0..100u64 {
        let c = campaign(seed + 100, 0.4, &[REFERENCE.to_string()]);
        let f = fit_touches(&c.artifacts, &c.touches, None).unwrap();
        let cal = &f.calibrations[0];
        for (a, z) in zs.iter_mut().enumerate() {
            let e = cal.reversal_um[a].unwrap();
            z.push((e.value - c.machine.reversal_um[a]) / e.sigma);
        }
        let e = cal.pretravel_um[0].unwrap();
        zp.push((e.value - c.machine.pretravel_um[0]) / e.sigma);
    }
    let sd = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    println!(
        "z rms: B {:.2} {:.2} {:.2}  p+X {:.2}",
        sd(&zs[0]),
        sd(&zs[1]),
        sd(&zs[2]),
        sd(&zp)
    );
}

/// Per parameter over repeated noise draws of one machine: mean z, RMS z,
/// and the spread of the estimates over the mean reported σ.
/// Per parameter: z values, errors, σ.
type ZTable = std::collections::BTreeMap<String, (Vec<f64>, Vec<f64>, Vec<f64>)>;

fn z_table(z: &ZTable) -> f64 {
    let mut all = Vec::new();
    for (name, (zs, est, sig)) in z {
        let n = zs.len() as f64;
        let mean = zs.iter().sum::<f64>() / n;
        let rms = (zs.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        let em = est.iter().sum::<f64>() / n;
        let sd = (est.iter().map(|x| (x - em) * (x - em)).sum::<f64>() / (n - 1.0)).sqrt();
        let sm = sig.iter().sum::<f64>() / n;
        println!(
            "{name:8} mean z {mean:6.2}  rms z {rms:5.2}  sd/σ {:5.2}  σ {sm:.4}",
            sd / sm
        );
        all.extend(zs.iter().copied());
    }
    (all.iter().map(|x| x * x).sum::<f64>() / all.len() as f64).sqrt()
}

#[test]
#[ignore]
fn diagnostic_monte_carlo() {
    let draws: u64 = std::env::var("MC_DRAWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24);
    let seed: u64 = std::env::var("MC_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2026);
    let noise: f64 = std::env::var("MC_NOISE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.4);
    let mut z: ZTable = Default::default();
    let ideal = std::env::var("MC_IDEAL").is_ok();
    let (mut s0, mut st) = (0.0, 0.0);
    let texts = match std::env::var("MC_SET").as_deref() {
        Ok("certified") => vec![REFERENCE.to_string(), certified_plate()],
        _ => all_texts(),
    };
    for draw in 0..draws {
        let c = campaign2(seed, 1000 + draw, noise, &texts);
        let (mut fitted, mut id) = fit_and_identify(&c.artifacts, &c.touches, &options()).unwrap();
        if ideal {
            ideal_centres(&c, &mut fitted, draw);
            id = volcomp_core::identify::probe::identify::identify(
                &c.artifacts,
                &fitted,
                &options(),
            )
            .unwrap();
        }
        s0 += id.ident.sigma0_um.unwrap() / draws as f64;
        st += fitted.sigma_um / draws as f64;
        let truth = projected_truth(&c.machine, &id);
        let names: Vec<String> = id.model.params.iter().map(|p| p.name()).collect();
        let mut worst = (0.0f64, String::new());
        for p in &id.params {
            if let (Status::Identified(e), Some(i)) =
                (p.status, names.iter().position(|n| *n == p.name))
            {
                let zz = ((e.value - truth[i]) / e.sigma).abs();
                if zz > worst.0 {
                    worst = (zz, p.name.clone());
                }
                let v = z.entry(p.name.clone()).or_default();
                v.0.push((e.value - truth[i]) / e.sigma);
                v.1.push(e.value - truth[i]);
                v.2.push(e.sigma);
            }
        }
        println!(
            "draw {draw}: worst {:.2} σ ({}), σ0 {:.3}",
            worst.0,
            worst.1,
            id.ident.sigma0_um.unwrap()
        );
    }
    println!(
        "all: rms z {:.3}; mean σ0 {s0:.3}, touch σ {st:.3}",
        z_table(&z)
    );
}

/// Every sphere centre replaced by the truth plus noise of the fit's own
/// covariance (the identification alone under test).
fn ideal_centres(c: &Campaign, fitted: &mut volcomp_core::identify::probe::fit::Fitted, draw: u64) {
    let mut rng = Rng::new(draw + 77);
    let sig = fitted.sigma_um;
    for s in &mut fitted.spheres {
        let real = c
            .reals
            .iter()
            .find(|r| r.described.name == s.artifact)
            .unwrap();
        let k = real
            .described
            .placements
            .iter()
            .position(|p| p.name == s.placement)
            .unwrap();
        let idx: usize = s.feature[1..].parse::<usize>().unwrap() - 1;
        let truth = real.placements[k].to_machine(real.balls_mm[idx]);
        let e = c.machine.geometric_um(truth, PROBE_LENGTH_MM);
        let cov = nalgebra::Matrix3::from_fn(|a, b| s.unit_cov[a][b] * sig * sig);
        let l = nalgebra::Cholesky::new(cov).unwrap().unpack();
        let n = l * nalgebra::Vector3::new(rng.normal(), rng.normal(), rng.normal());
        s.centre_mm = truth - e * 1e-3 + Vec3::new(n[0], n[1], n[2]) * 1e-3;
    }
}

/// Machines of the held-out class drawn with seeds no other test uses
/// (reference sphere, uncalibrated plate with 1–3 µm errors, gauge; noise
/// 0.3–0.5 µm per machine; `HO_DRAWS` campaigns of artifact and noise per
/// machine, `HO_SEEDS` a comma list): per machine the compensated share at
/// held-out points, the largest |error|/σ and the share of parameters
/// beyond 3 σ; over all campaigns the factor σ would need to be inflated by
/// to put every parameter of every campaign within 3 σ (docs/probing.md,
/// "Uncertainty budget").
#[test]
#[ignore]
fn measure_held_out_like_machines() {
    let seeds: Vec<u64> = std::env::var("HO_SEEDS")
        .ok()
        .map(|v| v.split(',').filter_map(|s| s.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![31, 47, 58, 64, 73, 89]);
    let draws: u64 = std::env::var("HO_DRAWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10);
    let mut worst_all = Vec::new();
    let mut z_all = Vec::new();
    for seed in seeds {
        let noise = 0.3 + 0.2 * Rng::new(seed * 7919).uniform();
        let (mut removal, mut worst, mut zs) = (Vec::new(), Vec::new(), Vec::new());
        for d in 0..draws {
            let c = campaign2(seed, 1000 * seed + d, noise, &all_texts());
            let r = evaluate(&c, &options(), &[]);
            let mut ns = r.not_seen.clone();
            ns.sort();
            assert_eq!(ns, invisible(), "seed {seed} draw {d}");
            assert_eq!(r.identified, 25);
            removal.push(100.0 * (1.0 - r.after_um / r.before_um));
            worst.push(r.worst_z.0);
            zs.extend(r.zs.iter().copied());
        }
        let n = draws as f64;
        let beyond = zs.iter().filter(|z| **z > 3.0).count();
        let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
        let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        println!(
            "seed {seed} noise {noise:.2} µm: removed {:.0}…{:.0} % (mean {:.0}); max |z| {:.2} (median over campaigns {:.2}); campaigns with a parameter beyond 3 σ {}/{draws}; parameters beyond 3 σ {beyond}/{} ({:.1} %); RMS z {rms:.3}",
            min(&removal),
            max(&removal),
            removal.iter().sum::<f64>() / n,
            max(&worst),
            {
                let mut w = worst.clone();
                w.sort_by(f64::total_cmp);
                w[w.len() / 2]
            },
            worst.iter().filter(|w| **w > 3.0).count(),
            zs.len(),
            100.0 * beyond as f64 / zs.len() as f64
        );
        assert!(min(&removal) >= 80.0, "seed {seed}: {removal:?}");
        worst_all.extend(worst);
        z_all.extend(zs);
    }
    worst_all.sort_by(f64::total_cmp);
    let k = |q: f64| worst_all[((worst_all.len() - 1) as f64 * q).round() as usize] / 3.0;
    let rms = (z_all.iter().map(|z| z * z).sum::<f64>() / z_all.len() as f64).sqrt();
    println!(
        "{} campaigns, {} values: RMS z {rms:.3}; campaigns with a parameter beyond 3 σ {:.1} %; σ inflated by {:.2} puts every parameter of every campaign within 3 σ ({:.2} for 95 % of the campaigns, {:.2} for 90 %); RMS z then {:.3}",
        worst_all.len(),
        z_all.len(),
        100.0 * worst_all.iter().filter(|w| **w > 3.0).count() as f64 / worst_all.len() as f64,
        k(1.0),
        k(0.95),
        k(0.90),
        rms / k(1.0).max(1.0)
    );
}
