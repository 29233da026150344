//! Identification options that cannot be used, or runs that disagree with
//! them. The messages name each option through a caller's naming, so that a
//! command-line front end can speak of its flags and a library user of the
//! [`super::identify::FitOptions`] fields.

use super::identify::FitOptions;
use super::Axis;

/// An option of a straightness identification, for naming in messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitOption {
    /// [`FitOptions::sigma_t`].
    SigmaT,
    /// [`FitOptions::p_t`].
    PT,
    /// [`FitOptions::taper_fraction`].
    Taper,
    /// [`FitOptions::harmonics`].
    Harmonics,
    /// The default axis of runs whose file does not say theirs.
    Axis,
}

impl FitOption {
    /// The option as a library user knows it.
    pub fn describe(self) -> &'static str {
        match self {
            FitOption::SigmaT => "the sigma_t option",
            FitOption::PT => "the p_t option",
            FitOption::Taper => "the taper_fraction option",
            FitOption::Harmonics => "the harmonics option",
            FitOption::Axis => "the default axis",
        }
    }
}

/// An option that cannot be used with these runs.
#[derive(Debug, Clone, PartialEq)]
pub enum OptionError {
    /// σ_t is not a positive number.
    SigmaT(f64),
    /// P_t is not in (0, 1).
    PT(f64),
    /// The taper fraction is not in 0 … 0.5.
    Taper(f64),
    /// Zero harmonics were asked for.
    ZeroHarmonics,
    /// A run's file names another axis than the default axis given.
    AxisConflict {
        /// The run's file.
        file: String,
        /// The axis the file names.
        file_axis: Axis,
        /// The default axis given.
        given: Axis,
    },
    /// A run names no axis and no default axis was given.
    NoAxis {
        /// The run's file.
        file: String,
    },
    /// More harmonics were asked for than the samples resolve.
    TooManyHarmonics {
        /// The axis.
        axis: Axis,
        /// Harmonics asked for.
        harmonics: usize,
        /// Harmonics the samples resolve.
        resolvable: usize,
        /// Samples per profile.
        samples: usize,
    },
    /// No line passes the thresholds and no number of harmonics was given;
    /// `message` says what the spectra show.
    NoSteadyLine {
        /// What was found, naming the axis, feed rates and thresholds.
        message: String,
    },
}

impl OptionError {
    /// What is wrong, naming options with `name`.
    pub fn message(&self, name: impl Fn(FitOption) -> String) -> String {
        match self {
            OptionError::SigmaT(v) => format!("σ_t = {v} is not a positive number"),
            OptionError::PT(v) => format!("P_t = {v} is not between 0 and 1"),
            OptionError::Taper(v) => format!("taper fraction {v} is not in 0 … 0.5"),
            OptionError::ZeroHarmonics => format!(
                "{} 0 leaves no straightness to model",
                name(FitOption::Harmonics)
            ),
            OptionError::AxisConflict {
                file,
                file_axis,
                given,
            } => format!(
                "{file}: the file says axis {} but {} says {}",
                file_axis.letter(),
                name(FitOption::Axis),
                given.letter()
            ),
            OptionError::NoAxis { file } => {
                format!("{file}: the run does not say which axis moved")
            }
            OptionError::TooManyHarmonics {
                axis,
                harmonics,
                resolvable,
                samples,
            } => format!(
                "axis {}: {} {harmonics} is more than the {resolvable} harmonics {samples} samples can resolve",
                axis.letter(),
                name(FitOption::Harmonics)
            ),
            OptionError::NoSteadyLine { message } => message.clone(),
        }
    }

    /// What to do, naming options with `name`.
    pub fn help(&self, name: impl Fn(FitOption) -> String) -> String {
        match self {
            OptionError::SigmaT(_) => format!(
                "{} is the largest relative standard deviation across feed rates of a geometric line, e.g. 0.05",
                name(FitOption::SigmaT)
            ),
            OptionError::PT(_) => format!(
                "{} is the smallest normalised mean power of a modelled line, e.g. 0.01 (1 % of the power)",
                name(FitOption::PT)
            ),
            OptionError::Taper(_) => format!(
                "{} is the fraction of the samples in each raised-cosine end, e.g. 0.1",
                name(FitOption::Taper)
            ),
            OptionError::ZeroHarmonics => format!(
                "give at least 1 harmonic, or leave {} out to let the thresholds choose",
                name(FitOption::Harmonics)
            ),
            OptionError::AxisConflict { .. } => format!(
                "{} is for files without an `# axis =` line; remove one of the two",
                name(FitOption::Axis)
            ),
            OptionError::NoAxis { .. } => format!(
                "add a header comment `# axis = X` (or Y) to the file, or pass {}",
                name(FitOption::Axis)
            ),
            OptionError::TooManyHarmonics { .. } => {
                "give fewer harmonics, or sample the profile more densely".into()
            }
            OptionError::NoSteadyLine { .. } => format!(
                "repeat the runs at each feed rate to average noise and vibration down, or relax {} / {}, or choose the number of harmonics with {}",
                name(FitOption::SigmaT),
                name(FitOption::PT),
                name(FitOption::Harmonics)
            ),
        }
    }
}

impl std::fmt::Display for OptionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = |o: FitOption| o.describe().to_string();
        write!(f, "{}\n  help: {}", self.message(name), self.help(name))
    }
}

impl std::error::Error for OptionError {}

/// Checks the options that need no runs.
pub(crate) fn check_options(o: &FitOptions) -> Result<(), OptionError> {
    if !(o.sigma_t.is_finite() && o.sigma_t > 0.0) {
        return Err(OptionError::SigmaT(o.sigma_t));
    }
    if !(o.p_t.is_finite() && o.p_t > 0.0 && o.p_t < 1.0) {
        return Err(OptionError::PT(o.p_t));
    }
    if !(o.taper_fraction.is_finite() && (0.0..=0.5).contains(&o.taper_fraction)) {
        return Err(OptionError::Taper(o.taper_fraction));
    }
    if o.harmonics == Some(0) {
        return Err(OptionError::ZeroHarmonics);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A front end's own names for the options.
    fn flag(o: FitOption) -> String {
        match o {
            FitOption::SigmaT => "<sigma-t>",
            FitOption::PT => "<p-t>",
            FitOption::Taper => "<taper>",
            FitOption::Harmonics => "<harmonics>",
            FitOption::Axis => "<axis>",
        }
        .into()
    }

    #[test]
    fn messages_name_options_as_the_caller_names_them() {
        let e = OptionError::AxisConflict {
            file: "a.csv".into(),
            file_axis: Axis::X,
            given: Axis::Y,
        };
        assert_eq!(
            e.message(flag),
            "a.csv: the file says axis X but <axis> says Y"
        );
        assert_eq!(
            e.to_string(),
            "a.csv: the file says axis X but the default axis says Y\n  help: the default axis is for files without an `# axis =` line; remove one of the two"
        );
        let e = OptionError::NoSteadyLine {
            message: "axis X: nothing steady".into(),
        };
        assert_eq!(e.help(flag), "repeat the runs at each feed rate to average noise and vibration down, or relax <sigma-t> / <p-t>, or choose the number of harmonics with <harmonics>");
        assert!(!e.to_string().contains("--"), "{e}");
    }

    #[test]
    fn options_are_checked_in_order() {
        let o = FitOptions::default();
        assert_eq!(check_options(&o), Ok(()));
        let bad = FitOptions {
            sigma_t: f64::NAN,
            p_t: 2.0,
            ..o
        };
        assert!(matches!(check_options(&bad), Err(OptionError::SigmaT(v)) if v.is_nan()));
        assert_eq!(
            check_options(&FitOptions { p_t: 1.0, ..o }),
            Err(OptionError::PT(1.0))
        );
        assert_eq!(
            check_options(&FitOptions {
                taper_fraction: 0.6,
                ..o
            }),
            Err(OptionError::Taper(0.6))
        );
        assert_eq!(
            check_options(&FitOptions {
                harmonics: Some(0),
                ..o
            }),
            Err(OptionError::ZeroHarmonics)
        );
    }
}
