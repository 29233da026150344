//! Errors of the core library. Each says what is wrong, where, and what to do.

use volcomp_gcode::GcodeError;

/// An error model could not be evaluated.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelError {
    /// A position lies outside the range the map was measured on.
    ///
    /// ```
    /// use volcomp_core::error::ModelError;
    /// let e = ModelError::OutOfRange { axis: 'X', position_mm: 510.0, min_mm: 0.0, max_mm: 500.0 };
    /// assert!(e.to_string().starts_with("axis X = 510 mm is outside the map's range 0 … 500 mm"));
    /// let e = ModelError::OutOfRange { axis: 'X', position_mm: 250.0, min_mm: 0.0, max_mm: 0.5 };
    /// assert!(e.to_string().contains("another unit: metres"));
    /// let e = ModelError::OutOfRange { axis: 'X', position_mm: 250.0, min_mm: 0.0, max_mm: 200.0 };
    /// assert!(!e.to_string().contains("another unit"));
    /// ```
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

impl std::error::Error for ModelError {}

/// A length in mm with sensible precision: at most four decimals, trailing
/// zeros dropped, scientific notation beyond ±1e9 (a huge value must not
/// print as hundreds of digits).
pub fn fmt_mm(v: f64) -> String {
    if !v.is_finite() || v.abs() >= 1e9 {
        return format!("{v:.3e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}

/// When `x_mm` lies far outside `[lo, hi]` (more than five spans away) but
/// inside it after a unit factor, the unit that factor suggests for the
/// map's positions.
fn other_unit(x_mm: f64, lo: f64, hi: f64) -> Option<&'static str> {
    let span = (hi - lo).abs();
    let distance = (lo - x_mm).max(x_mm - hi);
    if distance <= 5.0 * span {
        return None;
    }
    let margin = 0.05 * span;
    let inside = |v: f64| v >= lo - margin && v <= hi + margin;
    if inside(x_mm * 1e3) {
        Some("µm (the map's numbers are 1000 times the program's)")
    } else if inside(x_mm * 1e-3) {
        Some("metres (the map's numbers are 1/1000 of the program's)")
    } else if inside(x_mm / 25.4) {
        Some("inches (the map's numbers are 1/25.4 of the program's)")
    } else if inside(x_mm * 25.4) {
        Some("mm while the program is in inches")
    } else {
        None
    }
}

impl std::fmt::Display for ModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            ModelError::OutOfRange {
                axis,
                position_mm,
                min_mm,
                max_mm,
            } => {
                write!(
                    f,
                    "axis {axis} = {} mm is outside the map's range {} … {} mm",
                    fmt_mm(position_mm),
                    fmt_mm(min_mm),
                    fmt_mm(max_mm)
                )?;
                if let Some(unit) = other_unit(position_mm, min_mm, max_mm) {
                    write!(f, "; the map may be in another unit: {unit}")?;
                }
                write!(f, "; check the work offset and the units of the program and the map, measure the machine over the whole working range, or use the clamp option to hold the error at the nearest table end")
            }
        }
    }
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

/// "while compensating the target …: the command …" when a target is known.
fn target_note(target_mm: &Option<volcomp_gcode::Vec3>, source: &ModelError) -> String {
    match (target_mm, source) {
        (Some(t), ModelError::OutOfRange { .. }) => format!(
            "the target X {} Y {} Z {} mm (machine axes) lies on the map, but the command that compensates it does not: ",
            fmt_mm(t.x),
            fmt_mm(t.y),
            fmt_mm(t.z)
        ),
        _ => String::new(),
    }
}

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
    /// let e = CompensationError::Model { file: "p.ngc".into(), line: 7, target_mm: None, source: ModelError::OutOfRange { axis: 'Y', position_mm: -1.0, min_mm: 0.0, max_mm: 300.0 } };
    /// assert!(e.to_string().starts_with("p.ngc:7: axis Y"));
    /// let e = CompensationError::Model { file: "p.ngc".into(), line: 7, target_mm: Some(volcomp_gcode::Vec3::new(1.0, 0.0, 2.0)), source: ModelError::OutOfRange { axis: 'Y', position_mm: -0.001, min_mm: 0.0, max_mm: 300.0 } };
    /// assert!(e.to_string().contains("target X 1 Y 0 Z 2 mm"));
    /// ```
    #[error("{file}:{line}: {}{source}", target_note(target_mm, source))]
    Model {
        /// Program file.
        file: String,
        /// 1-based program line.
        line: u64,
        /// The target (machine axis frame, mm) being compensated, when the
        /// failure is at the command that reaches it rather than at the
        /// target itself.
        target_mm: Option<volcomp_gcode::Vec3>,
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
