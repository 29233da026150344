//! The standard uncertainty of every identified parameter by Monte Carlo
//! over the whole chain (docs/probing.md, "Uncertainty budget"), the
//! propagation of distributions of [JCGM 101:2008] (GUM Supplement 1).
//!
//! The least-squares covariance of the identification is that of its last
//! linear solve: it takes the sphere centres, the probe calibration and the
//! field taken out of each sphere as fixed inputs with their own
//! covariance. The chain is not linear in one step, though: the
//! calibration is fitted on touches from which the identified machine's
//! field was taken out, the centres on touches the calibration corrected,
//! and the machine identified again from both (three passes). Here each
//! repeat adds to every touch a draw of the probing noise along its
//! direction of motion (the probe's trigger scatters along the move; σ the
//! touches' own residual scatter) and runs the whole chain again; the
//! spread of the repeats is the Monte Carlo standard uncertainty.

use super::artifact::Artifact;
use super::identify::{fit_and_identify, Identified, IdentifyOptions, Status};
use super::ProbeError;
use crate::io::probe_log::Touch;
use crate::rng::Rng;

/// What the Monte Carlo found, per parameter of [`Identified::params`].
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    /// Repeats of the whole chain.
    pub draws: usize,
    /// The probing noise drawn (µm per touch, along the move).
    pub noise_um: f64,
    /// The least-squares standard uncertainty (`None`: not identified).
    pub least_squares: Vec<Option<f64>>,
    /// The Monte Carlo standard uncertainty (`None`: not identified, or
    /// not identified in every repeat).
    pub sigma: Vec<Option<f64>>,
}

/// Runs [`monte_carlo_sigma`] for the identified parameters of `id` with
/// the identification's own noise estimate σ0 and makes each reported
/// standard uncertainty the larger of the least-squares and the Monte
/// Carlo one (what is not separated from the chain's nonlinearity and the
/// passes between fit and identification is then not left out).
pub fn apply(
    artifacts: &[Artifact],
    touches: &[Touch],
    o: &IdentifyOptions,
    id: &mut Identified,
    draws: usize,
    seed: u64,
) -> Result<(), ProbeError> {
    let noise_um = id.ident.sigma0_um.unwrap_or(id.touch_sigma_um);
    let names: Vec<String> = id.params.iter().map(|p| p.name.clone()).collect();
    let sigma = monte_carlo_sigma(artifacts, touches, o, &names, noise_um, draws, seed)?;
    let mut least_squares = Vec::with_capacity(names.len());
    for (p, mc) in id.params.iter_mut().zip(&sigma) {
        match &mut p.status {
            Status::Identified(e) => {
                least_squares.push(Some(e.sigma));
                if let Some(mc) = mc {
                    e.sigma = e.sigma.max(*mc);
                }
            }
            _ => least_squares.push(None),
        }
    }
    id.monte_carlo = Some(MonteCarlo {
        draws,
        noise_um,
        least_squares,
        sigma,
    });
    Ok(())
}

/// Fewest repeats whose spread is worth reporting (relative standard error
/// of a standard deviation from `n` repeats: `1/√(2(n−1))`, 24 % at 10).
pub const MIN_DRAWS: usize = 10;

/// The sample standard deviation of every parameter of the model over
/// `draws` repeats of the chain with the touches perturbed by
/// `noise_um` along their directions of motion (`None` for a parameter not
/// identified in some repeat). `names` are the model's parameters, in the
/// order returned.
pub fn monte_carlo_sigma(
    artifacts: &[Artifact],
    touches: &[Touch],
    o: &IdentifyOptions,
    names: &[String],
    noise_um: f64,
    draws: usize,
    seed: u64,
) -> Result<Vec<Option<f64>>, ProbeError> {
    if draws < MIN_DRAWS {
        return Err(ProbeError::Invalid(format!(
            "monte_carlo: {draws} repeats are too few for a standard deviation; give {MIN_DRAWS} or more (or 0 for none)"
        )));
    }
    if !(noise_um.is_finite() && noise_um > 0.0) {
        return Err(ProbeError::Invalid(
            "monte_carlo: the touches' noise is unknown (no redundant touches); it needs a probing noise to draw from".into(),
        ));
    }
    let mut rng = Rng::new(seed);
    let mut values: Vec<Vec<f64>> = vec![Vec::with_capacity(draws); names.len()];
    let mut seen = vec![true; names.len()];
    for _ in 0..draws {
        let perturbed: Vec<Touch> = touches
            .iter()
            .map(|t| {
                let mut t = t.clone();
                t.q_mm += t.direction.vector() * (rng.normal() * noise_um * 1e-3);
                t
            })
            .collect();
        let (_, id) = fit_and_identify(artifacts, &perturbed, o)?;
        for (j, name) in names.iter().enumerate() {
            match id.params.iter().find(|p| &p.name == name).map(|p| p.status) {
                Some(Status::Identified(e)) => values[j].push(e.value),
                _ => seen[j] = false,
            }
        }
    }
    Ok(values
        .iter()
        .zip(seen)
        .map(|(v, ok)| ok.then(|| standard_deviation(v)))
        .collect())
}

/// The sample standard deviation (n − 1).
fn standard_deviation(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_standard_deviation_divides_by_n_minus_one() {
        // 1, 2, 3, 4: mean 2.5, squares 2.25 + 0.25 + 0.25 + 2.25 = 5, / 3.
        let s = standard_deviation(&[1.0, 2.0, 3.0, 4.0]);
        assert!((s - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
    }
}
