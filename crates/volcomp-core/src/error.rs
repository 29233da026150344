//! Errors of the core library. Each says what is wrong, where, and what to do.

use volcomp_gcode::GcodeError;

/// An error model could not be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// A position lies outside the range the map was measured on.
    ///
    /// ```
    /// use volcomp_core::error::ModelError;
    /// let e = ModelError::OutOfRange { axis: 'X', position_mm: 510.0, min_mm: 0.0, max_mm: 500.0 };
    /// assert!(e.to_string().contains("X = 510.0000 mm"));
    /// ```
    #[error("axis {axis} = {position_mm:.4} mm is outside the map's range {min_mm:.4} … {max_mm:.4} mm; measure the machine over the whole working range, or pass --clamp to hold the error at the nearest table end")]
    OutOfRange {
        /// Axis letter.
        axis: char,
        /// Requested position.
        position_mm: f64,
        /// Start of the table.
        min_mm: f64,
        /// End of the table.
        max_mm: f64,
    },
}

/// A located error in an input file (a table, a model or set-up file): file,
/// 1-based row and column, optionally the source line (shown bounded and
/// escaped with a caret, by the same renderer as G-code errors), what is
/// wrong and what to do.
///
/// ```
/// use volcomp_core::error::MapFileError;
/// let e = MapFileError::new("m.csv", 3, 2, "not a number", "write 1.5");
/// assert_eq!(e.to_string(), "m.csv:3:2: not a number\n  help: write 1.5");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapFileError {
    /// File name.
    pub file: String,
    /// 1-based line of the file.
    pub row: usize,
    /// 1-based column (field number for CSV, character for TOML).
    pub column: usize,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
    /// The offending line, when known (empty: no excerpt is shown).
    pub source_line: String,
    /// Byte offset of the caret in `source_line`.
    pub caret_byte: usize,
}

impl MapFileError {
    /// A located error without a source excerpt.
    pub fn new(
        file: impl Into<String>,
        row: usize,
        column: usize,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        Self {
            file: file.into(),
            row,
            column,
            message: message.into(),
            help: help.into(),
            source_line: String::new(),
            caret_byte: 0,
        }
    }

    /// Attaches the source line and the caret's byte offset in it.
    pub fn with_source(mut self, line: &str, caret_byte: usize) -> Self {
        self.source_line = line.to_string();
        self.caret_byte = caret_byte;
        self
    }
}

impl std::fmt::Display for MapFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        volcomp_gcode::error::render_located(
            f,
            &volcomp_gcode::error::Location {
                file: &self.file,
                line: self.row as u64,
                column: self.column,
                source_line: &self.source_line,
                caret_byte: self.caret_byte,
            },
            &self.message,
            &self.help,
        )
    }
}

impl std::error::Error for MapFileError {}

/// Compensation or simulation of a program failed.
#[derive(Debug, thiserror::Error)]
pub enum CompensationError {
    /// The program could not be read or interpreted.
    ///
    /// ```
    /// use volcomp_core::error::CompensationError;
    /// use volcomp_gcode::{GcodeError, ErrorClass};
    /// let e = CompensationError::from(GcodeError::new(ErrorClass::Invalid, 1, 1, "bad", "fix"));
    /// assert!(e.to_string().contains("bad"));
    /// ```
    #[error(transparent)]
    Gcode(#[from] GcodeError),
    /// The model failed at a point of the program.
    ///
    /// ```
    /// use volcomp_core::error::{CompensationError, ModelError};
    /// let e = CompensationError::Model { file: "p.ngc".into(), line: 7, source: ModelError::OutOfRange { axis: 'Y', position_mm: -1.0, min_mm: 0.0, max_mm: 300.0 } };
    /// assert!(e.to_string().starts_with("p.ngc:7: axis Y"));
    /// ```
    #[error("{file}:{line}: {source}")]
    Model {
        /// Program file.
        file: String,
        /// 1-based program line.
        line: u64,
        /// What went wrong.
        source: ModelError,
    },
    /// Anything else located at a program line.
    ///
    /// ```
    /// use volcomp_core::error::CompensationError;
    /// let e = CompensationError::AtLine { file: "p.ngc".into(), line: 3, message: "too big".into(), help: "check units".into() };
    /// assert_eq!(e.to_string(), "p.ngc:3: too big\n  help: check units");
    /// ```
    #[error("{file}:{line}: {message}\n  help: {help}")]
    AtLine {
        /// Program file.
        file: String,
        /// 1-based program line.
        line: u64,
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// Writing the output failed.
    ///
    /// ```
    /// use volcomp_core::error::CompensationError;
    /// let e = CompensationError::from(std::io::Error::other("disk full"));
    /// assert!(e.to_string().contains("disk full"));
    /// ```
    #[error("cannot write the output: {0}")]
    Io(#[from] std::io::Error),
}
