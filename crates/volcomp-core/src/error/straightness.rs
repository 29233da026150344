//! The straightness workflow's errors and the axis they name (its methods
//! and messages are in `identify::straightness`).

use crate::error::MapFileError;

/// The moving axis of a straightness profile in Z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// Z deviation along X motion, `e_z(x)`.
    X,
    /// Z deviation along Y motion, `e_z(y)`.
    Y,
}

/// Why runs could not be fitted or a model file read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StraightnessError {
    /// A run file is malformed at a row and column.
    #[error(transparent)]
    File(#[from] MapFileError),
    /// The set of runs (or the options) cannot give a model.
    ///
    /// ```
    /// use volcomp_core::identify::straightness::StraightnessError;
    /// let e = StraightnessError::Runs { message: "one feed rate".into(), help: "measure more".into() };
    /// assert_eq!(e.to_string(), "one feed rate\n  help: measure more");
    /// ```
    #[error("{message}\n  help: {help}")]
    Runs {
        /// What is wrong, naming the files concerned.
        message: String,
        /// What to do.
        help: String,
    },
    /// An option cannot be used with these runs.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// A model file is malformed.
    #[error("{file}: {message}\n  help: {help}")]
    ModelFile {
        /// File name.
        file: String,
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
}

/// An option of a straightness identification, for naming in messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitOption {
    /// `FitOptions::sigma_t`.
    SigmaT,
    /// `FitOptions::p_t`.
    PT,
    /// `FitOptions::taper_fraction`.
    Taper,
    /// `FitOptions::harmonics`.
    Harmonics,
    /// The default axis of runs whose file does not say theirs.
    Axis,
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
