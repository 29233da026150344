//! The result of a probing calibration: the 21-component model file that
//! `compensate`, `simulate`, `map export` and the report read, what was
//! identified with which uncertainty, what could not be seen, and the
//! uncertainty of a compensated position.

use super::fit::{Estimate, Fitted};
use super::identify::{HeldOut, Identified, Status};
use crate::identify::thermal::uncertainty::analytic_std_um;
use crate::io::numfmt;
use crate::model::kinematic::KinematicModel;
use volcomp_gcode::Vec3;

/// Points per component table of the written model.
pub const TABLE_SAMPLES: usize = 61;

/// The 21-component model of an identification: every component sampled
/// over its axis range (unknown parameters as zero), the axes' reversal
/// values put into the forward (−B/2) and reverse (+B/2) positioning
/// tables (docs/design.md, "Direction state and backlash"), measuring tool
/// = the probe's length.
pub fn kinematic_model(id: &Identified, reversal_um: &[Option<Estimate>; 3]) -> KinematicModel {
    let mut km = id.model.to_kinematic_model(&id.ident.theta, TABLE_SAMPLES);
    for (a, b) in reversal_um.iter().enumerate() {
        let Some(b) = b else { continue };
        for e in km.axes[a].forward.linear_um.errors_um.iter_mut() {
            e[a] -= b.value / 2.0;
        }
        for e in km.axes[a].reverse.linear_um.errors_um.iter_mut() {
            e[a] += b.value / 2.0;
        }
    }
    km
}

/// The reversal values to put into the model: the first calibration that
/// has them.
pub fn reversal(fitted: &Fitted) -> [Option<Estimate>; 3] {
    let mut out = [None; 3];
    for (a, slot) in out.iter_mut().enumerate() {
        *slot = fitted.calibrations.iter().find_map(|c| c.reversal_um[a]);
    }
    out
}

/// An evenly spaced `k × k × k` grid over the ranges (corners included).
pub fn grid(ranges_mm: [[f64; 2]; 3], k: usize) -> Vec<Vec3> {
    let k = k.max(2);
    let at = |a: usize, i: usize| {
        ranges_mm[a][0] + (ranges_mm[a][1] - ranges_mm[a][0]) * i as f64 / (k - 1) as f64
    };
    let mut out = Vec::with_capacity(k * k * k);
    for i in 0..k {
        for j in 0..k {
            for l in 0..k {
                out.push(Vec3::new(at(0, i), at(1, j), at(2, l)));
            }
        }
    }
    out
}

/// The RMS over `points` of the norm of a deviation field after removing
/// its best rigid motion (translation and small rotation, least squares):
/// what a part probed and set up on the machine sees of it (µm).
pub fn rms_modulo_rigid(points: &[Vec3], field_um: &[Vec3]) -> f64 {
    use nalgebra::DMatrix;
    let n = points.len();
    if n == 0 {
        return 0.0;
    }
    let c = points.iter().copied().sum::<Vec3>() * (1.0 / n as f64);
    // Unknowns: translation (3, µm), rotation (3, µrad): e ≈ t + ω × (p − c)·1e-3.
    let a = DMatrix::from_fn(3 * n, 6, |r, col| {
        let (i, comp) = (r / 3, r % 3);
        if col < 3 {
            f64::from(u8::from(col == comp))
        } else {
            let mut e = Vec3::ZERO;
            e[col - 3] = 1.0;
            e.cross(points[i] - c)[comp] * 1e-3
        }
    });
    let b: Vec<f64> = field_um.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
    let x = crate::linalg::pinv_solve(&a, &b, 1e-12).map_or(vec![0.0; 6], |s| s.x);
    let mut ss = 0.0;
    for (i, p) in points.iter().enumerate() {
        let t = Vec3::new(x[0], x[1], x[2]);
        let w = Vec3::new(x[3], x[4], x[5]);
        let r = field_um[i] - t - w.cross(*p - c) * 1e-3;
        ss += r.norm_squared();
    }
    (ss / n as f64).sqrt()
}

/// The predicted standard uncertainty of a compensated position at the
/// probe's tool length: RMS and largest over a 5×5×5 grid of the ranges of
/// `sqrt(σ_x² + σ_y² + σ_z²)` from the parameters' covariance (µm).
pub fn compensated_uncertainty_um(id: &Identified, ranges_mm: [[f64; 2]; 3]) -> (f64, f64) {
    let tool = Vec3::new(0.0, 0.0, id.probe_length_mm);
    let (mut ss, mut max, mut n) = (0.0, 0.0f64, 0usize);
    for q in grid(ranges_mm, 5) {
        let s = analytic_std_um(&id.model, &id.ident, q, tool);
        let v = s.norm_squared();
        if v.is_finite() {
            ss += v;
            max = max.max(v.sqrt());
            n += 1;
        }
    }
    ((ss / n.max(1) as f64).sqrt(), max)
}

/// The identification as text lines: parameters, what could not be seen,
/// probe calibration, residuals, held-out placements.
pub fn summary(
    id: &Identified,
    fitted: &Fitted,
    reversal_um: &[Option<Estimate>; 3],
    held_out: &[HeldOut],
    ranges_mm: [[f64; 2]; 3],
) -> Vec<String> {
    let mut out = Vec::new();
    for c in &fitted.calibrations {
        out.push(format!(
            "probe (tool length {} mm): effective tip radius {} mm ± {} µm; probing noise {} µm",
            numfmt::mm(c.tool_length_mm),
            numfmt::fixed(c.tip_radius_mm.value, 4),
            numfmt::fixed(c.tip_radius_mm.sigma, 2),
            numfmt::fixed(c.sigma_um, 3)
        ));
        let pre: Vec<String> = crate::io::probe_log::AxisDir::ALL
            .iter()
            .filter_map(|d| {
                c.pretravel_um[d.index()].map(|e| {
                    format!(
                        "{} {} ± {}",
                        d.label(),
                        numfmt::fixed(e.value, 2),
                        numfmt::fixed(e.sigma, 2)
                    )
                })
            })
            .collect();
        if !pre.is_empty() {
            out.push(format!("  pre-travel (µm): {}", pre.join(", ")));
        }
        if !c.unseen.is_empty() {
            out.push(format!(
                "  not separated by the reference touches: {}",
                c.unseen.join(", ")
            ));
        }
    }
    let rev: Vec<String> = (0..3)
        .filter_map(|a| {
            reversal_um[a].map(|e| {
                format!(
                    "{} {} ± {}",
                    ['X', 'Y', 'Z'][a],
                    numfmt::fixed(e.value, 2),
                    numfmt::fixed(e.sigma, 2)
                )
            })
        })
        .collect();
    if rev.is_empty() {
        out.push(
            "reversal (backlash): not measured (needs the reference sphere's reversal touches)"
                .into(),
        );
    } else {
        out.push(format!("reversal (backlash, µm): {}", rev.join(", ")));
    }
    out.push(format!(
        "{} spheres, {} face touches; {} observations; {} of {} parameters identified; noise from the residuals σ0 = {} µm (touches: {} µm)",
        fitted.spheres.len(),
        fitted.faces.len(),
        id.observations,
        id.params.iter().filter(|p| matches!(p.status, Status::Identified(_))).count(),
        id.params.len(),
        id.ident.sigma0_um.map_or("–".into(), |s| numfmt::fixed(s, 3)),
        numfmt::fixed(id.touch_sigma_um, 3)
    ));
    if let Some(mc) = &id.monte_carlo {
        out.push(format!(
            "standard uncertainties: the larger of least squares and a Monte Carlo of the whole fit ({} repeats, probing noise {} µm along each move)",
            mc.draws,
            numfmt::fixed(mc.noise_um, 3)
        ));
    }
    for (i, p) in id.params.iter().enumerate() {
        let unit = if p.unit == "um" { "µm" } else { "µrad" };
        let both = id.monte_carlo.as_ref().and_then(|mc| {
            let (ls, m) = (
                mc.least_squares.get(i)?.as_ref()?,
                mc.sigma.get(i)?.as_ref()?,
            );
            Some(format!(
                "  (least squares {}, Monte Carlo {})",
                numfmt::fixed(*ls, 3),
                numfmt::fixed(*m, 3)
            ))
        });
        match p.status {
            Status::Identified(e) => out.push(format!(
                "  {:<8} {:>10} ± {:<7} {unit}{}",
                p.name,
                numfmt::fixed(e.value, 3),
                numfmt::fixed(e.sigma, 3),
                both.unwrap_or_default()
            )),
            Status::NotSeen => out.push(format!(
                "  {:<8} not seen by these measurements (zero, unknown)",
                p.name
            )),
            Status::NotInModel => {}
        }
    }
    let left: Vec<&str> = id
        .params
        .iter()
        .filter(|p| p.status == Status::NotInModel)
        .map(|p| p.name.as_str())
        .collect();
    if !left.is_empty() {
        out.push(format!(
            "not in the reduced model (zero, unknown: the measurements run along lines and cannot separate angles): {}",
            left.join(", ")
        ));
    }
    for c in &id.combinations {
        out.push(format!(
            "  seen only together with others (not identified): {c}"
        ));
    }
    for n in &id.notes {
        out.push(format!("note: {n}"));
    }
    let (rms, max) = compensated_uncertainty_um(id, ranges_mm);
    out.push(format!(
        "uncertainty of a compensated position (1σ, probe tool length, over the volume): RMS {} µm, largest {} µm",
        numfmt::fixed(rms, 2),
        numfmt::fixed(max, 2)
    ));
    if !held_out.is_empty() {
        out.push("leave-one-placement-out (RMS deviation of the held-out placement's centres, µm): uncorrected → predicted by the model fitted without it".into());
        for h in held_out {
            out.push(format!(
                "  {}/{}: {} → {}",
                h.artifact,
                h.placement,
                numfmt::fixed(h.before_um, 2),
                numfmt::fixed(h.after_um, 2)
            ));
        }
    }
    out
}
