//! Propagation of the parameter uncertainty to the tool-tip error along a
//! trajectory: analytically (`σ_e² = b·C·bᵀ`, `b` the first-order basis) and
//! by Monte Carlo (`θ = θ̂ + F·z`, `z ~ N(0, I)`, `C = F·Fᵀ`, seeded).

use super::identify::Identification;
use super::poly::PolyModel;
use crate::rng::Rng;
use volcomp_gcode::Vec3;

/// The confidence band of the predicted deviation at one trajectory point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    /// Deviation with the estimated parameters (µm).
    pub estimate_um: Vec3,
    /// Monte Carlo standard deviation per component (µm).
    pub std_um: Vec3,
    /// 2.5 % quantile per component (µm).
    pub lo_um: Vec3,
    /// 97.5 % quantile per component (µm).
    pub hi_um: Vec3,
}

/// The estimate with unidentifiable parameters as zero.
pub fn estimate(ident: &Identification) -> Vec<f64> {
    ident.theta.iter().map(|t| t.unwrap_or(0.0)).collect()
}

/// Analytic standard deviation of the first-order deviation at `q` (µm).
pub fn analytic_std_um(
    model: &PolyModel,
    ident: &Identification,
    q_mm: Vec3,
    tool_mm: Vec3,
) -> Vec3 {
    let b = model.basis_um(q_mm, tool_mm);
    let rank = ident.cov_factor.first().map_or(0, Vec::len);
    let mut var = Vec3::ZERO;
    for k in 0..rank {
        let mut g = Vec3::ZERO;
        for (bi, f) in b.iter().zip(&ident.cov_factor) {
            g += *bi * f[k];
        }
        var += g.map(|x| x * x);
    }
    var.map(f64::sqrt)
}

/// Monte Carlo bands along `trajectory_mm` with `samples` draws (seeded).
pub fn monte_carlo(
    model: &PolyModel,
    ident: &Identification,
    trajectory_mm: &[Vec3],
    tool_mm: Vec3,
    samples: usize,
    seed: u64,
) -> Vec<Band> {
    let base = estimate(ident);
    let rank = ident.cov_factor.first().map_or(0, Vec::len);
    let mut rng = Rng::new(seed);
    let draws: Vec<Vec<f64>> = (0..samples.max(2))
        .map(|_| {
            let z: Vec<f64> = (0..rank).map(|_| rng.normal()).collect();
            base.iter()
                .zip(&ident.cov_factor)
                .map(|(b, f)| b + f.iter().zip(&z).map(|(a, c)| a * c).sum::<f64>())
                .map(|x| if x.is_finite() { x } else { 0.0 })
                .collect()
        })
        .collect();
    trajectory_mm
        .iter()
        .map(|&q| {
            let estimate_um = model.deviation_um(&base, q, tool_mm, false);
            let mut vals: [Vec<f64>; 3] = Default::default();
            for d in &draws {
                let e = model.deviation_um(d, q, tool_mm, false);
                for c in 0..3 {
                    vals[c].push(e[c]);
                }
            }
            let mut band = Band {
                estimate_um,
                std_um: Vec3::ZERO,
                lo_um: Vec3::ZERO,
                hi_um: Vec3::ZERO,
            };
            for (c, v) in vals.iter_mut().enumerate() {
                let n = v.len() as f64;
                let mean = v.iter().sum::<f64>() / n;
                band.std_um[c] =
                    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                v.sort_by(f64::total_cmp);
                band.lo_um[c] = quantile(v, 0.025);
                band.hi_um[c] = quantile(v, 0.975);
            }
            band
        })
        .collect()
}

fn quantile(sorted: &[f64], p: f64) -> f64 {
    let pos = p * (sorted.len() - 1) as f64;
    let i = pos.floor() as usize;
    let j = (i + 1).min(sorted.len() - 1);
    let f = pos - i as f64;
    sorted[i] * (1.0 - f) + sorted[j] * f
}
