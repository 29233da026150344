//! A straightness identification (docs/straightness.md), as plain values:
//! the options of the fit from runs at several feed rates.

use super::option::OptionError;
use crate::identify::straightness::identify::{fit, CutoffRule, Fit, FitOptions, Normalisation};
use crate::identify::straightness::option_error::FitOption;
use crate::identify::straightness::run::Run;
use crate::identify::straightness::{Axis, StraightnessError};
use crate::Error;

request! {
    /// A straightness fit, as plain values.
    #[allow(missing_docs)]
    pub struct StraightnessFitRequest {}
    /// The options of [`StraightnessFitRequest`].
    pub const STRAIGHTNESS_OPTIONS, unknown "axis";

    axis: Option<String> = None,
        Choice.value("AXIS").choices(&[("X", "Runs along X"), ("Y", "Runs along Y")]),
        "The axis of runs whose file has no `# axis =` line: X or Y.";

    sigma_t: f64 = 0.05, Number.value("SIGMA").default("0.05"),
        "σ_t: largest relative standard deviation (σ/P̄) across feed rates of a geometric line.";

    p_t: f64 = 0.01, Number.value("P").default("0.01"),
        "P_t: smallest normalised mean power P̄ of a modelled line (0.01 = 1 % of the power).";

    taper_fraction: f64 = 0.1, Number.flag("taper").value("FRACTION").default("0.1"),
        "Fraction of the samples in each raised-cosine end of the taper window (0 … 0.5).";

    normalisation: String = "common".into(),
        Choice.flag("normalise").value("NORMALISE").default("common").choices(&[
            (
                "common",
                "One common scale for all feed rates: their mean total power (default)",
            ),
            (
                "per-run",
                "Each feed rate's spectrum as fractions of its own total power",
            ),
        ]),
        "How spectra are normalised before P̄ and σ are taken.";

    cutoff: String = "cross-validation".into(),
        Choice.value("CUTOFF").default("cross-validation").choices(&[
            (
                "cross-validation",
                "m that best predicts each left-out feed rate from the others (default)",
            ),
            (
                "thresholds",
                "The paper's rule: shortest wavelength with σ < σ_t and P̄ > P_t",
            ),
        ]),
        "How the number of harmonics m is chosen (σ_t and P_t apply to `thresholds`; they still mark the lines reported as rejected).";

    harmonics: Option<u64> = None, Count.value("M"),
        "Use this number of harmonics m instead of the one the rule chooses.";

    negate: bool = false, Switch,
        "The files' displacement has the opposite sign of the deviation (e.g. workpiece relative to tool): negate it.";
}

/// The request's name of an identification option.
fn name(o: FitOption) -> &'static str {
    match o {
        FitOption::SigmaT => "sigma_t",
        FitOption::PT => "p_t",
        FitOption::Taper => "taper_fraction",
        FitOption::Harmonics => "harmonics",
        FitOption::Axis => "axis",
    }
}

/// The choice of option `name` that `value` names.
fn choice(name: &'static str, value: &str) -> Result<&'static str, OptionError> {
    let info = <StraightnessFitRequest as super::Request>::info(name).expect("an option");
    info.choice(value).map_err(|p| OptionError::new(name, p))
}

impl StraightnessFitRequest {
    /// The identification's options (their ranges are checked by the fit,
    /// which names them as `{name}`).
    pub fn options(&self) -> Result<FitOptions, OptionError> {
        let normalisation = choice("normalisation", &self.normalisation)?;
        let cutoff = choice("cutoff", &self.cutoff)?;
        let harmonics = self
            .harmonics
            .map(|m| usize::try_from(m).map_err(|_| OptionError::new("harmonics", "is too large")))
            .transpose()?;
        Ok(FitOptions {
            sigma_t: self.sigma_t,
            p_t: self.p_t,
            taper_fraction: self.taper_fraction,
            normalisation: match normalisation {
                "per-run" => Normalisation::PerRun,
                _ => Normalisation::Common,
            },
            harmonics,
            cutoff: match cutoff {
                "thresholds" => CutoffRule::Thresholds,
                _ => CutoffRule::CrossValidation,
            },
        })
    }

    /// The default axis of runs whose file does not say theirs.
    pub fn axis(&self) -> Result<Option<Axis>, OptionError> {
        match self.axis.as_deref().map(|a| choice("axis", a)).transpose()? {
            None => Ok(None),
            Some(a) => Axis::parse(a).map(Some).ok_or_else(|| {
                OptionError::new(
                    "axis",
                    format!("must be X or Y (straightness runs are profiles along X or Y; the Z deviation is what they measure); got `{a}`"),
                )
            }),
        }
    }

    /// Identifies the model from `runs` (each negated first when asked).
    pub fn fit(&self, mut runs: Vec<Run>) -> Result<Fit, Error> {
        let options = self.options()?;
        let axis = self.axis()?;
        if self.negate {
            runs.iter_mut().for_each(Run::negate);
        }
        fit(&runs, axis, &options).map_err(|e| match e {
            // Said with the options' names, for a front end to spell.
            StraightnessError::Option(o) => {
                let named = |f: FitOption| format!("{{{}}}", name(f));
                Error::from(StraightnessError::Runs {
                    message: o.message(named),
                    help: o.help(named),
                })
            }
            e => e.into(),
        })
    }
}

/// What a fit found, in lines for a person (for standard error): per axis
/// the runs, the cut-off and harmonics with how they were chosen, the
/// rejected lines and where to compensate.
pub fn fit_summary(f: &Fit, o: &FitOptions) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    for a in &f.axes {
        let feeds: Vec<String> = a
            .feeds
            .iter()
            .map(|g| format!("{} ({}×)", g.feed_mm_per_min, g.files.len()))
            .collect();
        let slope = match a.axis {
            Axis::X => format!("β_zx = {:.3} µrad", f.model.beta_zx_urad),
            Axis::Y => format!("α_yz = {:.3} µrad", f.model.alpha_yz_urad),
        };
        let n = a.positions_mm.len();
        let _ = writeln!(
            s,
            "volcomp: straightness along {}: {} runs at {} mm/min; {n} samples every {:.4} mm from x_st = {:.4} mm, l = {:.4} mm",
            a.axis.letter(),
            a.runs,
            feeds.join(", "),
            a.spacing_mm,
            a.positions_mm[0],
            a.length_mm
        );
        let how = if o.harmonics.is_some() {
            "given by {harmonics}".to_string()
        } else if o.cutoff == CutoffRule::CrossValidation {
            "best prediction of each left-out feed rate from the others".to_string()
        } else {
            format!(
                "shortest wavelength with σ < {} and P̄ > {} ({} normalisation)",
                o.sigma_t,
                o.p_t,
                o.normalisation.name()
            )
        };
        let _ = writeln!(
            s,
            "  cut-off λ_c = {:.4} mm, m = {} harmonics ({how}); {slope}; measured − model RMS {:.4} µm",
            a.cutoff_wavelength_mm, a.harmonics, a.residual_rms_um
        );
        axis_notes(&mut s, f, a);
    }
    s
}

/// The rejected lines, the unstable ones, and where to compensate.
fn axis_notes(s: &mut String, f: &Fit, a: &crate::identify::straightness::identify::AxisFit) {
    use std::fmt::Write as _;
    let rejected: Vec<String> = a
        .feeds
        .iter()
        .filter_map(|g| {
            g.strongest_rejected.map(|l| {
                format!(
                    "{} mm/min: λ {:.4} mm = {:.1} Hz ({:.2} % of the power)",
                    g.feed_mm_per_min,
                    l.wavelength_mm,
                    l.frequency_hz,
                    100.0 * l.power
                )
            })
        })
        .collect();
    if !rejected.is_empty() {
        let _ = writeln!(
            s,
            "  strongest rejected line per feed rate (vibration if its frequency stays put): {}",
            rejected.join("; ")
        );
    }
    if !a.unstable_in_band.is_empty() {
        let lines: Vec<String> = a
            .unstable_in_band
            .iter()
            .map(|&k| format!("λ {:.3} mm (σ {:.3})", a.wavelength_mm(k), a.sigma[k]))
            .collect();
        let _ = writeln!(
            s,
            "volcomp: warning: strong lines longer than the cut-off vary with feed rate and are modelled anyway (slow vibration? thermal drift?): {}",
            lines.join(", ")
        );
    }
    if let Some(m) = f.model.axis(a.axis) {
        let [lo, hi] = m.recommended_range_mm;
        let _ = writeln!(
            s,
            "  compensate inside {lo:.3} … {hi:.3} mm: within one cut-off wavelength of the measured ends the series is poor"
        );
    }
}
