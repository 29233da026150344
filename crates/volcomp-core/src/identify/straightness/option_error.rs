//! Identification options that cannot be used, or runs that disagree with
//! them. The messages name each option through a caller's naming, so that a
//! command-line front end can speak of its flags and a library user of the
//! [`super::identify::FitOptions`] fields.

use super::identify::FitOptions;

pub use crate::error::straightness::{FitOption, OptionError};

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
    use crate::identify::straightness::Axis;

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
