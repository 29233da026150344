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

/// Monte Carlo draws of a band: 10 (fewer give no 95 % interval) to
/// 10 000 (25 times the default 400; the work and memory grow with it).
pub const BAND_SAMPLES: [usize; 2] = [10, 10_000];

/// Checks a number of Monte Carlo draws against [`BAND_SAMPLES`] before any
/// work: what is wrong, in words that follow the option's name.
pub fn band_samples_problem(samples: u64) -> Result<(), String> {
    let [lo, hi] = BAND_SAMPLES;
    if (lo as u64..=hi as u64).contains(&samples) {
        Ok(())
    } else {
        Err(format!(
            "must be {lo} to {hi} Monte Carlo draws; got {samples}: {lo} give a rough 95 % band, the default 400 a smooth one, more than {hi} add nothing but time and memory"
        ))
    }
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
    let draws = Draws::new(ident, samples, seed);
    trajectory_mm
        .iter()
        .map(|&q| draws.band(model, q, tool_mm))
        .collect()
}

/// The estimate and `samples` (at least 2) parameter sets drawn around it,
/// `θ = θ̂ + F·z` (seeded; parameters that come out not finite are 0).
struct Draws {
    base: Vec<f64>,
    draws: Vec<Vec<f64>>,
}

impl Draws {
    fn new(ident: &Identification, samples: usize, seed: u64) -> Self {
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
        Draws { base, draws }
    }

    /// The band at `q`: the estimate's deviation, and the spread and the
    /// 2.5 % and 97.5 % quantiles of the drawn ones.
    fn band(&self, model: &PolyModel, q: Vec3, tool_mm: Vec3) -> Band {
        let estimate_um = model.deviation_um(&self.base, q, tool_mm, false);
        let mut vals: [Vec<f64>; 3] = Default::default();
        for d in &self.draws {
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
            band.std_um[c] = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            v.sort_by(f64::total_cmp);
            band.lo_um[c] = quantile(v, 0.025);
            band.hi_um[c] = quantile(v, 0.975);
        }
        band
    }
}

/// The Monte Carlo bands along one straight line through the middle of the
/// volume, parallel to one machine axis.
#[derive(Debug, Clone, PartialEq)]
pub struct LineBands {
    /// The axis the line runs along: 0 = X, 1 = Y, 2 = Z.
    pub axis: usize,
    /// The points of the line (mm), evenly spaced over the axis range.
    pub points_mm: Vec<Vec3>,
    /// The band at each point.
    pub bands: Vec<Band>,
}

/// Intervals per axis line in [`axis_line_bands`]: 41 points per line.
pub const LINE_INTERVALS: u32 = 40;

/// The 95 % Monte Carlo bands of the identified tool-tip error along three
/// lines through the middle of the axis ranges, one along each of X, Y and
/// Z ([`LINE_INTERVALS`] + 1 points each, `samples` draws, seed 1), for a
/// probe of length `probe_length_mm` along the tool axis: what a part
/// dimension along each axis sees of the identification's uncertainty.
pub fn axis_line_bands(
    model: &PolyModel,
    ident: &Identification,
    ranges_mm: [[f64; 2]; 3],
    probe_length_mm: f64,
    samples: usize,
) -> Vec<LineBands> {
    axis_line_bands_with_progress(
        model,
        ident,
        ranges_mm,
        probe_length_mm,
        samples,
        &mut crate::progress::Silent,
    )
}

/// [`axis_line_bands`], telling `progress` of the points done out of
/// `3 (LINE_INTERVALS + 1)`.
pub fn axis_line_bands_with_progress(
    model: &PolyModel,
    ident: &Identification,
    ranges_mm: [[f64; 2]; 3],
    probe_length_mm: f64,
    samples: usize,
    progress: &mut dyn crate::progress::Progress,
) -> Vec<LineBands> {
    let per_line = u64::from(LINE_INTERVALS) + 1;
    progress.start("Monte Carlo bands", Some(3 * per_line));
    let mid = Vec3::new(
        0.5 * (ranges_mm[0][0] + ranges_mm[0][1]),
        0.5 * (ranges_mm[1][0] + ranges_mm[1][1]),
        0.5 * (ranges_mm[2][0] + ranges_mm[2][1]),
    );
    let tool = Vec3::new(0.0, 0.0, probe_length_mm);
    // Every line with the same draws (seed 1).
    let draws = Draws::new(ident, samples, 1);
    let lines = (0..3)
        .map(|axis| {
            let [lo, hi] = ranges_mm[axis];
            let points_mm: Vec<Vec3> = (0..=LINE_INTERVALS)
                .map(|k| {
                    let mut p = mid;
                    p[axis] = lo + (hi - lo) * f64::from(k) / f64::from(LINE_INTERVALS);
                    p
                })
                .collect();
            let bands = points_mm
                .iter()
                .enumerate()
                .map(|(i, &q)| {
                    progress.advance_to(axis as u64 * per_line + i as u64);
                    draws.band(model, q, tool)
                })
                .collect();
            LineBands {
                axis,
                points_mm,
                bands,
            }
        })
        .collect::<Vec<_>>();
    progress.advance_to(3 * per_line);
    lines
}

fn quantile(sorted: &[f64], p: f64) -> f64 {
    let pos = p * (sorted.len() - 1) as f64;
    let i = pos.floor() as usize;
    let j = (i + 1).min(sorted.len() - 1);
    let f = pos - i as f64;
    sorted[i] * (1.0 - f) + sorted[j] * f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_lines_run_through_the_middle_of_the_ranges() {
        let model = crate::example::thermal::poly_model();
        let n = model.len();
        // Zero parameters with no uncertainty: every draw is the estimate 0.
        let ident = Identification {
            theta: vec![Some(0.0); n],
            sigma: vec![Some(0.0); n],
            rank: n,
            singular_values: Vec::new(),
            null_space: Vec::new(),
            sigma0_um: Some(0.0),
            residuals_um: Vec::new(),
            observations: 0,
            cov_factor: vec![vec![0.0]; n],
        };
        let ranges = [[0.0, 600.0], [-100.0, 300.0], [10.0, 30.0]];
        // Progress: 3 lines × 41 points, told in order, ending at 123.
        struct Log(Vec<u64>, Option<u64>);
        impl crate::progress::Progress for Log {
            fn start(&mut self, _: &str, total: Option<u64>) {
                self.1 = total;
            }
            fn advance_to(&mut self, done: u64) {
                self.0.push(done);
            }
        }
        let mut log = Log(Vec::new(), None);
        let lines = axis_line_bands_with_progress(&model, &ident, ranges, 50.0, 10, &mut log);
        assert_eq!(log.1, Some(123));
        assert_eq!(log.0, (0..=123).collect::<Vec<u64>>());
        assert_eq!(lines, axis_line_bands(&model, &ident, ranges, 50.0, 10));
        assert_eq!(lines.len(), 3);
        // Middle: (300, 100, 20); the line along Y steps (300 + 100) / 40 = 10 mm.
        let y = &lines[1];
        assert_eq!(y.axis, 1);
        assert_eq!(y.points_mm.len(), 41);
        assert_eq!(y.points_mm[0], Vec3::new(300.0, -100.0, 20.0));
        assert_eq!(y.points_mm[1], Vec3::new(300.0, -90.0, 20.0));
        assert_eq!(y.points_mm[40], Vec3::new(300.0, 300.0, 20.0));
        assert_eq!(lines[2].points_mm[20], Vec3::new(300.0, 100.0, 20.0));
        for l in &lines {
            assert_eq!(l.bands.len(), 41);
            for b in &l.bands {
                assert_eq!(b.estimate_um, Vec3::ZERO);
                assert_eq!(b.std_um, Vec3::ZERO);
                assert_eq!((b.lo_um, b.hi_um), (Vec3::ZERO, Vec3::ZERO));
            }
        }
    }
}
