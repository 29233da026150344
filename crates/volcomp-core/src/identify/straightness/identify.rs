//! Identification of a [`StraightnessModel`] from measured runs: the
//! frequency-domain separation of geometric error from vibration.
//!
//! Per axis (X and Y independently):
//!
//! 1. All runs of the axis share one grid `x_i = x_st + i·Δx`,
//!    `i = 0 … N−1`; the modelling length is `l = N·Δx`.
//! 2. Repeated runs at one feed rate `v_j` are averaged: `z̄_j(x_i)`.
//! 3. Each `z̄_j` loses its least-squares line (the alignment term and the
//!    arbitrary zero), is weighted with the taper window `f(i)` and gives the
//!    power spectrum `P_j(λ_k)`, `λ_k = l/k`, `k = 1 … ⌊N/2⌋`.
//! 4. Normalisation ([`Normalisation`]): `p_j(k) = P_j(k) / T`, with `T` the
//!    mean over feed rates of the total power `Σ_k P_j(k)` (default), or
//!    each run's own total.
//! 5. `P̄(λ_k) = mean_j p_j(k)` and
//!    `σ(λ_k) = sqrt(Σ_j (p_j(k) − P̄)² / (n_v − 1)) / P̄(λ_k)`
//!    (sample standard deviation relative to the mean).
//! 6. `m` (and `λ_c = l/m`) by [`CutoffRule`]: by default the `m` whose
//!    model, fitted to the other feed rates, best predicts each left-out
//!    feed rate ([`super::select`]); or the paper's rule, the shortest `λ_k`
//!    with `σ(λ_k) < σ_t` and `P̄(λ_k) > P_t`.
//! 7. The model of the axis is the least-squares fit of
//!    `c + s·x + Σ_{k=1..m} a_k·cos(2πk(x − x_st)/l) + b_k·sin(2πk(x − x_st)/l)`
//!    to the average of all feed rates' profiles (each feed rate weighted
//!    equally), line and series together; the slope `s` is the alignment
//!    term (`β_zx` for X, `α_yz` for Y).

use super::option_error::{check_options, OptionError};
use super::run::{same_feed, Run};
use super::select::{cross_validate, CrossValidation};
use super::spectrum::{
    fourier_coefficients, least_squares_line, power_spectrum, taper_samples, taper_window,
};
use super::{Axis, AxisModel, FourierSeries, Identification, StraightnessError, StraightnessModel};

/// How the spectra are made comparable across feed rates before `P̄` and
/// `σ` are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Normalisation {
    /// Divide every feed rate's spectrum by one common number, the mean over
    /// feed rates of their total powers. `σ/P̄` is then the plain relative
    /// spread of the power at `λ`, unaffected by how much vibration power
    /// the other wavelengths carry. The default.
    #[default]
    Common,
    /// Divide each feed rate's spectrum by its own total power (spectra as
    /// fractions of power). A feed rate with strong vibration then shrinks
    /// every geometric line of its spectrum, which the method reads as
    /// instability; kept for comparison with the literal method.
    PerRun,
}

impl Normalisation {
    /// `common` or `per-run`.
    pub fn name(self) -> &'static str {
        match self {
            Normalisation::Common => "common",
            Normalisation::PerRun => "per-run",
        }
    }
}

/// How the number of harmonics `m` is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CutoffRule {
    /// Leave-one-feed-rate-out cross-validation ([`super::select`]): the `m`
    /// whose series, fitted to the other feed rates, best predicts each
    /// left-out feed rate. Follows a lead that is no harmonic of `l` as far
    /// as it is predictable, and rejects vibration (which the other feed
    /// rates, at other wavelengths, cannot predict). The default.
    #[default]
    CrossValidation,
    /// The paper's rule: the shortest wavelength with `σ < σ_t` and
    /// `P̄ > P_t`.
    Thresholds,
}

impl CutoffRule {
    /// `cross-validation` or `thresholds`.
    pub fn name(self) -> &'static str {
        match self {
            CutoffRule::CrossValidation => "cross-validation",
            CutoffRule::Thresholds => "thresholds",
        }
    }
}

/// Options of the identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// σ_t: largest relative standard deviation across feed rates of a
    /// geometric line (default 0.05).
    pub sigma_t: f64,
    /// P_t: smallest normalised mean power of a line worth modelling
    /// (default 0.01, i.e. 1 % of the power).
    pub p_t: f64,
    /// Fraction of the samples in each raised-cosine end of the taper
    /// window (default 0.1).
    pub taper_fraction: f64,
    /// How spectra are normalised.
    pub normalisation: Normalisation,
    /// Use this `m` instead of the one the rule gives.
    pub harmonics: Option<usize>,
    /// How `m` is chosen when it is not given.
    pub cutoff: CutoffRule,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            sigma_t: 0.05,
            p_t: 0.01,
            taper_fraction: 0.1,
            normalisation: Normalisation::Common,
            harmonics: None,
            cutoff: CutoffRule::CrossValidation,
        }
    }
}

/// A spectral line: harmonic `k` at one feed rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralLine {
    /// `k`.
    pub harmonic: usize,
    /// `λ = l/k` (mm).
    pub wavelength_mm: f64,
    /// The time frequency it has at the feed rate, `v/λ` (Hz).
    pub frequency_hz: f64,
    /// Normalised power.
    pub power: f64,
}

/// The averaged runs of one feed rate and their spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct FeedSpectrum {
    /// Feed rate (mm/min).
    pub feed_mm_per_min: f64,
    /// The files averaged.
    pub files: Vec<String>,
    /// `z̄_j`, the average profile (µm) on the axis grid.
    pub mean_profile_um: Vec<f64>,
    /// `p_j(k)`, `k = 0 … ⌊N/2⌋` (normalised; `k = 0` is zero after detrending).
    pub power: Vec<f64>,
    /// The strongest line shorter than the cut-off that is not steady across
    /// feed rates (`σ ≥ σ_t`): what was rejected, typically vibration
    /// (`frequency_hz` then stays put across feed rates).
    pub strongest_rejected: Option<SpectralLine>,
}

/// Everything the identification of one axis found.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisFit {
    /// The axis.
    pub axis: Axis,
    /// `x_i` (mm).
    pub positions_mm: Vec<f64>,
    /// `Δx` (mm).
    pub spacing_mm: f64,
    /// `l = N·Δx` (mm).
    pub length_mm: f64,
    /// `N_t`, samples in each end of the taper window.
    pub taper_samples: usize,
    /// Per feed rate, ascending.
    pub feeds: Vec<FeedSpectrum>,
    /// `P̄(λ_k)`, `k = 0 … ⌊N/2⌋`.
    pub mean_power: Vec<f64>,
    /// `σ(λ_k)` relative to `P̄` (infinite where `P̄ = 0`).
    pub sigma: Vec<f64>,
    /// Harmonics passing both thresholds.
    pub passing: Vec<usize>,
    /// Leave-one-feed-rate-out cross-validation of `m` (computed whatever
    /// the rule, for the record; `None` only if it cannot be formed).
    pub cross_validation: Option<CrossValidation>,
    /// `m`.
    pub harmonics: usize,
    /// `λ_c = l/m` (mm).
    pub cutoff_wavelength_mm: f64,
    /// Harmonics `k ≤ m` with `P̄ > P_t` but `σ ≥ σ_t`: strong lines that vary
    /// with feed rate yet lie inside the model's band (vibration slower than
    /// the cut-off would be modelled: check them).
    pub unstable_in_band: Vec<usize>,
    /// The average of all feed rates' profiles (µm).
    pub mean_profile_um: Vec<f64>,
    /// The line of the model of `mean_profile_um` (fitted jointly with the
    /// series by least squares): intercept (µm), slope (µm/mm).
    pub line: (f64, f64),
    /// `line + series` on the grid (µm): the model of `mean_profile_um`.
    pub model_profile_um: Vec<f64>,
    /// The Fourier series.
    pub series: FourierSeries,
    /// RMS of `mean_profile_um − model_profile_um` (µm).
    pub residual_rms_um: f64,
    /// Number of runs.
    pub runs: usize,
}

impl AxisFit {
    /// `λ_k = l/k` (mm); infinite for `k = 0`.
    pub fn wavelength_mm(&self, k: usize) -> f64 {
        self.length_mm / k as f64
    }
}

/// The model and what was found on each axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The model.
    pub model: StraightnessModel,
    /// Per axis (X before Y).
    pub axes: Vec<AxisFit>,
}

fn runs_error(message: String, help: &str) -> StraightnessError {
    StraightnessError::Runs {
        message,
        help: help.to_string(),
    }
}

/// Identifies the model from `runs` (X and/or Y). Runs whose file does not
/// name its axis take `default_axis`.
pub fn fit(
    runs: &[Run],
    default_axis: Option<Axis>,
    options: &FitOptions,
) -> Result<Fit, StraightnessError> {
    check_options(options)?;
    if runs.is_empty() {
        return Err(runs_error(
            "no runs were given".into(),
            "give the CSV files of runs at two or more feed rates (three or more, each repeated, is better)",
        ));
    }
    let mut by_axis: [Vec<&Run>; 2] = [Vec::new(), Vec::new()];
    for r in runs {
        let axis = match (r.axis, default_axis) {
            (Some(a), Some(d)) if a != d => {
                return Err(OptionError::AxisConflict {
                    file: r.file.clone(),
                    file_axis: a,
                    given: d,
                }
                .into())
            }
            (Some(a), _) | (None, Some(a)) => a,
            (None, None) => {
                return Err(OptionError::NoAxis {
                    file: r.file.clone(),
                }
                .into())
            }
        };
        by_axis[axis as usize].push(r);
    }
    let mut axes = Vec::new();
    for (axis, list) in [Axis::X, Axis::Y].into_iter().zip(by_axis) {
        if !list.is_empty() {
            axes.push(fit_axis(axis, &list, options)?);
        }
    }
    let mut model = StraightnessModel {
        offset_um: 0.0,
        beta_zx_urad: 0.0,
        alpha_yz_urad: 0.0,
        x: None,
        y: None,
        clamp: false,
    };
    for a in &axes {
        let slope_urad = a.line.1 * 1e3;
        let n = a.positions_mm.len();
        let mean_x = 0.5 * (a.positions_mm[0] + a.positions_mm[n - 1]);
        model.offset_um -= slope_urad * 1e-3 * mean_x;
        let [lo, hi] = [a.positions_mm[0], a.positions_mm[n - 1]];
        let margin = a.cutoff_wavelength_mm.min(0.5 * (hi - lo));
        let feeds: Vec<f64> = a.feeds.iter().map(|f| f.feed_mm_per_min).collect();
        let m = AxisModel {
            series: a.series.clone(),
            range_mm: [lo, hi],
            recommended_range_mm: [lo + margin, hi - margin],
            identification: Some(Identification {
                runs: a.runs,
                feeds_mm_per_min: feeds,
                samples: n,
                spacing_mm: a.spacing_mm,
                taper_fraction: options.taper_fraction,
                sigma_t: options.sigma_t,
                p_t: options.p_t,
                normalisation: options.normalisation.name().to_string(),
                harmonics_forced: options.harmonics.is_some(),
                cutoff_rule: options.cutoff.name().to_string(),
                fit_residual_rms_um: a.residual_rms_um,
            }),
        };
        match a.axis {
            Axis::X => {
                model.beta_zx_urad = slope_urad;
                model.x = Some(m);
            }
            Axis::Y => {
                model.alpha_yz_urad = slope_urad;
                model.y = Some(m);
            }
        }
    }
    Ok(Fit { model, axes })
}

fn fmt_feeds(feeds: &[f64]) -> String {
    feeds
        .iter()
        .map(|f| format!("{f}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn fit_axis(axis: Axis, runs: &[&Run], o: &FitOptions) -> Result<AxisFit, StraightnessError> {
    let letter = axis.letter();
    let first = runs[0];
    let n = first.positions_mm.len();
    let dx = first.spacing_mm();
    // One grid for every run of the axis.
    for r in &runs[1..] {
        let same = r.positions_mm.len() == n
            && (r.start_mm() - first.start_mm()).abs() <= 0.1 * dx
            && (r.end_mm() - first.end_mm()).abs() <= 0.1 * dx;
        if !same {
            return Err(runs_error(
                format!(
                    "{}: sampled {:.4} … {:.4} mm in {} samples, but {} (the first {letter} run) is sampled {:.4} … {:.4} mm in {n} samples",
                    r.file,
                    r.start_mm(),
                    r.end_mm(),
                    r.positions_mm.len(),
                    first.file,
                    first.start_mm(),
                    first.end_mm()
                ),
                "every run of one axis must be sampled at the same positions: trim the runs to a common range and resample them onto one grid",
            ));
        }
    }
    // Group by feed rate, ascending.
    let mut groups: Vec<(f64, Vec<&Run>)> = Vec::new();
    for r in runs {
        match groups
            .iter_mut()
            .find(|(f, _)| same_feed(*f, r.feed_mm_per_min))
        {
            Some((_, g)) => g.push(r),
            None => groups.push((r.feed_mm_per_min, vec![r])),
        }
    }
    groups.sort_by(|a, b| a.0.total_cmp(&b.0));
    if groups.len() < 2 {
        let files: Vec<&str> = runs.iter().map(|r| r.file.as_str()).collect();
        let message = if runs.len() == 1 {
            format!(
                "axis {letter}: only one run ({}); the method needs runs at two or more feed rates",
                files[0]
            )
        } else {
            format!(
                "axis {letter}: all {} runs ({}) are at one feed rate, {} mm/min",
                runs.len(),
                files.join(", "),
                groups[0].0
            )
        };
        return Err(runs_error(
            message,
            "vibration is told from geometric error by how its wavelength changes with the feed rate: add runs of this axis at another feed rate at least (three or more feed rates, each repeated, is better)",
        ));
    }

    let positions: Vec<f64> = (0..n).map(|i| first.start_mm() + i as f64 * dx).collect();
    // l = N·Δx, computed from the span so that it prints as it reads.
    let length_mm = (first.end_mm() - first.start_mm()) * n as f64 / (n - 1) as f64;
    let n_taper = taper_samples(n, o.taper_fraction);
    let window = taper_window(n, n_taper);
    let half = n / 2;

    let mut feeds: Vec<FeedSpectrum> = groups
        .iter()
        .map(|(feed, g)| {
            let mut mean = vec![0.0; n];
            for r in g {
                for (m, z) in mean.iter_mut().zip(&r.displacement_um) {
                    *m += z;
                }
            }
            mean.iter_mut().for_each(|m| *m /= g.len() as f64);
            let (c, s) = least_squares_line(&positions, &mean);
            let detrended: Vec<f64> = mean
                .iter()
                .zip(&positions)
                .map(|(z, x)| z - c - s * x)
                .collect();
            FeedSpectrum {
                feed_mm_per_min: *feed,
                files: g.iter().map(|r| r.file.clone()).collect(),
                mean_profile_um: mean,
                power: power_spectrum(&detrended, &window),
                strongest_rejected: None,
            }
        })
        .collect();
    let nv = feeds.len() as f64;

    // Normalisation (the DC bin is excluded from the totals: detrended).
    let totals: Vec<f64> = feeds.iter().map(|f| f.power[1..].iter().sum()).collect();
    let common = totals.iter().sum::<f64>() / nv;
    for (f, t) in feeds.iter_mut().zip(&totals) {
        let d = match o.normalisation {
            Normalisation::Common => common,
            Normalisation::PerRun => *t,
        };
        let d = if d > 0.0 { d } else { 1.0 };
        f.power.iter_mut().for_each(|p| *p /= d);
        f.power[0] = 0.0;
    }
    let mut mean_power = vec![0.0; half + 1];
    let mut sigma = vec![f64::INFINITY; half + 1];
    for k in 1..=half {
        let mean = feeds.iter().map(|f| f.power[k]).sum::<f64>() / nv;
        let var = feeds
            .iter()
            .map(|f| (f.power[k] - mean).powi(2))
            .sum::<f64>()
            / (nv - 1.0);
        mean_power[k] = mean;
        if mean > 0.0 {
            sigma[k] = var.sqrt() / mean;
        }
    }
    let passing: Vec<usize> = (1..=half)
        .filter(|&k| sigma[k] < o.sigma_t && mean_power[k] > o.p_t)
        .collect();
    let profiles: Vec<Vec<f64>> = feeds.iter().map(|f| f.mean_profile_um.clone()).collect();
    let cross_validation = cross_validate(&profiles, &positions);
    let chosen = match o.cutoff {
        CutoffRule::Thresholds => passing.last().copied(),
        CutoffRule::CrossValidation => cross_validation.as_ref().map(|c| c.harmonics),
    };
    let m = match (o.harmonics, chosen) {
        (Some(h), _) => {
            if h > half {
                return Err(OptionError::TooManyHarmonics {
                    axis,
                    harmonics: h,
                    resolvable: half,
                    samples: n,
                }
                .into());
            }
            h
        }
        (None, Some(k)) => k,
        (None, None) => {
            let best = (1..=half)
                .filter(|&k| mean_power[k] > o.p_t)
                .min_by(|&a, &b| sigma[a].total_cmp(&sigma[b]));
            let hint = match best {
                Some(k) => format!(
                    "; the steadiest line above P_t is λ = {:.4} mm with σ = {:.3}",
                    length_mm / k as f64,
                    sigma[k]
                ),
                None => "; no line carries more than P_t of the power".into(),
            };
            return Err(OptionError::NoSteadyLine {
                message: format!(
                    "axis {letter}: no wavelength is both steady across the feed rates {} mm/min (σ < σ_t = {}) and strong (P̄ > P_t = {}){hint}",
                    fmt_feeds(&groups.iter().map(|g| g.0).collect::<Vec<_>>()),
                    o.sigma_t,
                    o.p_t
                ),
            }
            .into());
        }
    };
    let unstable_in_band: Vec<usize> = (1..=m)
        .filter(|&k| mean_power[k] > o.p_t && sigma[k] >= o.sigma_t)
        .collect();
    for f in &mut feeds {
        let v_mm_s = f.feed_mm_per_min / 60.0;
        f.strongest_rejected = (m + 1..=half)
            .filter(|&k| sigma[k] >= o.sigma_t)
            .max_by(|&a, &b| f.power[a].total_cmp(&f.power[b]))
            .map(|k| SpectralLine {
                harmonic: k,
                wavelength_mm: length_mm / k as f64,
                frequency_hz: v_mm_s * k as f64 / length_mm,
                power: f.power[k],
            });
    }

    // The model: grand mean of the feed rates, its line and its series.
    let mut mean_profile = vec![0.0; n];
    for f in &feeds {
        for (m, z) in mean_profile.iter_mut().zip(&f.mean_profile_um) {
            *m += z / nv;
        }
    }
    let (c, s, cos_um, sin_um) = fit_line_and_series(&positions, &mean_profile, m);
    let series = FourierSeries {
        start_mm: positions[0],
        length_mm,
        cos_um,
        sin_um,
    };
    let model_profile: Vec<f64> = positions
        .iter()
        .map(|&x| c + s * x + series.eval_um(x))
        .collect();
    let residual_rms_um = (mean_profile
        .iter()
        .zip(&model_profile)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    Ok(AxisFit {
        axis,
        positions_mm: positions,
        spacing_mm: dx,
        length_mm,
        taper_samples: n_taper,
        feeds,
        mean_power,
        sigma,
        passing,
        cross_validation,
        harmonics: m,
        cutoff_wavelength_mm: length_mm / m as f64,
        unstable_in_band,
        mean_profile_um: mean_profile,
        line: (c, s),
        model_profile_um: model_profile,
        series,
        residual_rms_um,
        runs: runs.len(),
    })
}

/// Least squares of `z ≈ c + s·x + Σ_{k=1..m} a_k·cos(2πk·i/N) + b_k·sin(2πk·i/N)`
/// on the grid: returns `(c, s, a, b)`.
///
/// The Fourier columns are orthogonal to each other and to the constant on
/// an even grid, so only `x` couples with them. With `x̃` the part of
/// `x − x̄` outside the span of the constant and the `m` harmonics (the
/// ramp's harmonics above `m`), `s = ⟨x̃, z⟩ / ⟨x̃, x̃⟩`; then `a, b` are the
/// Fourier coefficients of `z − s·x` and `c` its mean. Unlike removing the
/// least-squares line first, this does not let in-band periodic error tilt
/// the alignment term (whose sawtooth would then leak into every harmonic).
/// When `x̃` is negligible (`m` near `N/2`, where the harmonics span the ramp)
/// the plain least-squares line is used.
fn fit_line_and_series(x: &[f64], z: &[f64], m: usize) -> (f64, f64, Vec<f64>, Vec<f64>) {
    let n = x.len();
    let theta = |i: usize| 2.0 * std::f64::consts::PI * i as f64 / n as f64;
    let xm = x.iter().sum::<f64>() / n as f64;
    let xc: Vec<f64> = x.iter().map(|v| v - xm).collect();
    let (ax, bx) = fourier_coefficients(&xc, m);
    let xt: Vec<f64> = (0..n)
        .map(|i| xc[i] - super::spectrum::fourier_sum(&ax, &bx, theta(i)))
        .collect();
    let xt2: f64 = xt.iter().map(|v| v * v).sum();
    let xc2: f64 = xc.iter().map(|v| v * v).sum();
    let s = if xt2 > 1e-9 * xc2 {
        xt.iter().zip(z).map(|(a, b)| a * b).sum::<f64>() / xt2
    } else {
        least_squares_line(x, z).1
    };
    let rest: Vec<f64> = z.iter().zip(x).map(|(z, x)| z - s * x).collect();
    let c = rest.iter().sum::<f64>() / n as f64;
    let (a, b) = fourier_coefficients(&rest, m);
    (c, s, a, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn run(file: &str, axis: Option<Axis>, feed: f64, n: usize, f: impl Fn(f64) -> f64) -> Run {
        let positions: Vec<f64> = (0..n).map(|i| i as f64 * 0.5).collect();
        Run {
            file: file.into(),
            axis,
            feed_mm_per_min: feed,
            displacement_um: positions.iter().map(|&x| f(x)).collect(),
            positions_mm: positions,
        }
    }

    #[test]
    fn refuses_unusable_sets() {
        let o = FitOptions::default();
        let g = |x: f64| (2.0 * PI * x / 10.0).sin();
        // The set is refused with a message that holds every `want`.
        let refused = |runs: &[Run], axis: Option<Axis>, want: &[&str]| {
            let e = fit(runs, axis, &o).unwrap_err().to_string();
            assert!(want.iter().all(|w| e.contains(w)), "{e}");
            e
        };
        refused(&[], None, &["no runs"]);
        let one = [run("a.csv", Some(Axis::X), 4800.0, 200, g)];
        refused(&one, None, &["only one run (a.csv)", "help:"]);
        let same = [
            run("a.csv", Some(Axis::X), 4800.0, 200, g),
            run("b.csv", Some(Axis::X), 4800.0, 200, g),
        ];
        refused(&same, None, &["one feed rate, 4800 mm/min", "b.csv"]);
        let grid = [
            run("a.csv", Some(Axis::X), 4800.0, 200, g),
            run("b.csv", Some(Axis::X), 7200.0, 199, g),
        ];
        let e = refused(&grid, None, &["a.csv"]);
        assert!(e.starts_with("b.csv: sampled"), "{e}");
        let no_axis = [run("a.csv", None, 4800.0, 200, g)];
        refused(&no_axis, None, &["or pass the default axis"]);
        refused(
            &one,
            Some(Axis::Y),
            &["says axis X but the default axis says Y"],
        );
        for bad in [
            FitOptions { sigma_t: 0.0, ..o },
            FitOptions { p_t: 1.5, ..o },
            FitOptions {
                taper_fraction: 0.7,
                ..o
            },
            FitOptions {
                taper_fraction: f64::NAN,
                ..o
            },
            FitOptions {
                harmonics: Some(0),
                ..o
            },
        ] {
            assert!(fit(&grid, None, &bad).is_err());
        }
    }

    #[test]
    fn exact_geometry_without_vibration() {
        // Noise-free identical runs: every line is perfectly steady, so the
        // cut-off is the shortest strong line, and the model is exact.
        let l = 100.0; // 200 samples × 0.5 mm
        let g = |x: f64| {
            0.5 * (2.0 * PI * x / 10.0 + 0.3).sin() + 0.2 * (2.0 * PI * x / l).cos() + 3e-3 * x
        };
        let runs: Vec<Run> = [4800.0, 7200.0, 9600.0]
            .iter()
            .map(|&f| run(&format!("{f}.csv"), Some(Axis::X), f, 200, g))
            .collect();
        let fit = fit(&runs, None, &FitOptions::default()).unwrap();
        let a = &fit.axes[0];
        // The 10 mm line is harmonic 10. The taper spreads a line over about
        // ±N/N_t = ±10 harmonics; that leakage is as steady as the line, so
        // neighbours above P_t pass too: m is 10 or a little more.
        assert!((10..=20).contains(&a.harmonics), "m = {}", a.harmonics);
        assert!(a.passing.contains(&10) && a.passing.contains(&1));
        assert!(a.residual_rms_um < 1e-9, "{}", a.residual_rms_um);
        let m = &fit.model;
        assert!((m.beta_zx_urad - 3.0).abs() < 0.05, "{}", m.beta_zx_urad);
        // The model reproduces the profile up to a constant.
        let d0 = g(0.0) - m.ez_um(0.0, 0.0).unwrap();
        for i in 0..200 {
            let x = i as f64 * 0.5;
            assert!((g(x) - m.ez_um(x, 0.0).unwrap() - d0).abs() < 1e-9);
        }
        // Forced harmonics.
        let forced = super::fit(
            &runs,
            None,
            &FitOptions {
                harmonics: Some(3),
                ..FitOptions::default()
            },
        )
        .unwrap();
        assert_eq!(forced.axes[0].harmonics, 3);
        let too_many = FitOptions {
            harmonics: Some(101),
            ..FitOptions::default()
        };
        assert!(super::fit(&runs, None, &too_many).is_err());
    }
    #[test]
    fn joint_line_and_series_beats_removing_the_line_first() {
        // A wave with whole periods over l is inside the series, yet it has a
        // least-squares slope (≈ 2.4·10⁻³ µm/mm for 0.5 µm at λ = 100 mm over
        // 200 mm). Removing the line first turns that slope into a sawtooth
        // (≈ 0.24 µm end to end) whose harmonics above m are lost: about
        // 0.01 µm RMS. The joint fit recovers the profile exactly. With 2.5
        // periods (not periodic over l) neither is exact; the joint fit is
        // least squares over line and series together, so it is never worse.
        let (n, dx) = (400usize, 0.5);
        let x: Vec<f64> = (0..n).map(|i| i as f64 * dx).collect();
        let m = 25;
        let theta = |i: usize| 2.0 * PI * i as f64 / n as f64;
        let sum = super::super::spectrum::fourier_sum;
        for (lambda, exact) in [(100.0, true), (80.0, false)] {
            let z: Vec<f64> = x
                .iter()
                .map(|&x| {
                    0.5 * (2.0 * PI * x / lambda).sin()
                        + 0.3 * (2.0 * PI * x / 10.0).cos()
                        + 2e-3 * x
                })
                .collect();
            let rms = |model: &dyn Fn(usize) -> f64| {
                ((0..n).map(|i| (z[i] - model(i)).powi(2)).sum::<f64>() / n as f64).sqrt()
            };
            let (c, s, a, b) = fit_line_and_series(&x, &z, m);
            let joint = rms(&|i| c + s * x[i] + sum(&a, &b, theta(i)));
            let (c2, s2) = least_squares_line(&x, &z);
            let rest: Vec<f64> = (0..n).map(|i| z[i] - c2 - s2 * x[i]).collect();
            let (a2, b2) = fourier_coefficients(&rest, m);
            let staged = rms(&|i| c2 + s2 * x[i] + sum(&a2, &b2, theta(i)));
            assert!(
                joint <= staged,
                "λ {lambda}: joint {joint} vs staged {staged}"
            );
            if exact {
                assert!(joint < 1e-9, "joint {joint}");
                assert!((s - 2e-3).abs() < 1e-12, "slope {s}");
                assert!(staged > 3e-3, "staged {staged}");
            }
        }
    }
}
