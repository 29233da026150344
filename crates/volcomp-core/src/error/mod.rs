//! Errors of the core library. Each says what is wrong, where, and what to do.

pub mod domain;
pub mod straightness;

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
/// inside it after a unit factor, the unit that factor suggests. Where
/// several factors bring it inside, the one that brings it nearest the
/// middle of the range is the likelier mistake. A factor of 25.4 is as
/// likely the set-up's (offsets in mm under `units = "inch"`) as the map's.
fn other_unit(x_mm: f64, lo: f64, hi: f64) -> Option<&'static str> {
    let span = (hi - lo).abs();
    let distance = (lo - x_mm).max(x_mm - hi);
    if distance <= 5.0 * span {
        return None;
    }
    let margin = 0.05 * span;
    let inside = |v: f64| v >= lo - margin && v <= hi + margin;
    let middle = 0.5 * (lo + hi);
    [
        (1e3, "µm (the map's numbers are 1000 times the program's)"),
        (1e-3, "metres (the map's numbers are 1/1000 of the program's)"),
        (1.0 / 25.4, "inches (the map's numbers are 1/25.4 of the program's), or the set-up's offsets are in mm under `units = \"inch\"`"),
        (25.4, "mm while the program is in inches"),
    ]
    .into_iter()
    .filter(|(factor, _)| inside(x_mm * factor))
    .min_by(|(a, _), (b, _)| {
        let d = |f: f64| (x_mm * f - middle).abs();
        d(*a).total_cmp(&d(*b))
    })
    .map(|(_, unit)| unit)
}

#[cfg(test)]
mod unit_hint_tests {
    use super::other_unit;

    #[test]
    fn a_factor_of_25_4_is_not_taken_for_metres() {
        // 300 mm read as inches (a set-up in mm under units = "inch"):
        // 7620 mm; 7.62 would be inside 0 … 600 too, but 300 is nearer its
        // middle.
        let hint = other_unit(300.0 * 25.4, 0.0, 600.0).unwrap();
        assert!(hint.starts_with("inches"), "{hint}");
        assert!(hint.contains("units = \"inch\""), "{hint}");
        assert!(other_unit(250.0, 0.0, 0.5).unwrap().starts_with("metres"));
        assert_eq!(other_unit(250.0, 0.0, 200.0), None);
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

/// What kind of failure an [`Error`] is, for callers that act on it (a
/// command line's exit status, a service's response code) without matching
/// every variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// An input file or an option is malformed or inconsistent: fix the input.
    BadInput,
    /// The G-code interpreter or the compensation refused the program:
    /// unsupported or invalid G-code, a point outside the model's range, a
    /// residual or correction above its limit, a program compensated already.
    RefusedProgram,
    /// Reading or writing a file failed.
    Io,
    /// A bug: the library reached a state it should not.
    Internal,
}

/// Where an earlier compensation by volcomp shows in a program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompensatedEvidence {
    /// The provenance header volcomp writes at the top.
    Header,
    /// A `(volcomp Ln)` trace comment on an inserted line.
    Trace,
}

impl std::fmt::Display for CompensatedEvidence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CompensatedEvidence::Header => "its volcomp header",
            CompensatedEvidence::Trace => "a volcomp trace comment",
        })
    }
}

/// Every error of the library: one variant per domain, each keeping the
/// domain's own error as its [`source`](std::error::Error::source), so a
/// caller can match the domain, ask [`Error::kind`], or walk the cause chain.
/// The text is the domain error's own.
///
/// ```
/// use volcomp_core::error::{Error, ErrorKind, MapFileError};
/// use std::error::Error as _;
/// let e = Error::from(MapFileError::new("m.csv", 3, 2, "not a number", "write 1.5"));
/// assert_eq!(e.kind(), ErrorKind::BadInput);
/// assert_eq!(e.to_string(), "m.csv:3:2: not a number\n  help: write 1.5");
/// assert!(e.source().unwrap().downcast_ref::<MapFileError>().is_some());
/// ```
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error model could not be evaluated.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// A located error in a table, model or set-up file.
    #[error("{0}")]
    MapFile(#[from] MapFileError),
    /// A ballbar test or trace that cannot be evaluated.
    #[error("{0}")]
    Ballbar(#[from] BallbarError),
    /// A model file could not be read.
    #[error("{0}")]
    ModelFile(#[from] crate::error::domain::ModelFileError),
    /// Compensation or simulation of a program failed.
    #[error("{0}")]
    Compensation(#[from] CompensationError),
    /// A G-code program could not be read or interpreted.
    #[error("{0}")]
    Gcode(#[from] GcodeError),
    /// The thermal workflow failed.
    #[error("{0}")]
    Thermal(#[from] crate::error::domain::ThermalError),
    /// Straightness identification failed.
    #[error("{0}")]
    Straightness(#[from] crate::error::straightness::StraightnessError),
    /// Probing (plan, fit, identification) failed.
    #[error("{0}")]
    Probe(#[from] crate::error::domain::ProbeError),
    /// The mirror (surface) method refused its input.
    #[error("{0}")]
    Mirror(#[from] crate::error::domain::MirrorError),
    /// A B-spline surface could not be built or evaluated.
    #[error("{0}")]
    BSpline(#[from] crate::error::domain::BSplineError),
    /// A model file could not be loaded (`io::load_model`).
    #[error("{0}")]
    Load(#[source] Box<crate::error::domain::LoadError>),
    /// A machine set-up file was refused (bad input, not a refused program).
    #[error("{0}")]
    Setup(#[source] GcodeError),
    /// A kinematic topology was refused.
    #[error("{0}")]
    Topology(#[from] crate::error::domain::TopologyError),
    /// Outputs name an input or each other.
    #[error("{0}")]
    OutputPlan(#[from] crate::error::domain::PlanError),
    /// An output could not be written.
    #[error("{0}")]
    Output(#[from] crate::error::domain::OutputError),
    /// An option's value was refused (named as the library names it; a
    /// front end spells it its own way with `OptionError::render`).
    #[error("{0}")]
    Option(#[from] OptionError),
    /// A controller's table would exceed what the controller holds.
    #[error("{0}")]
    Limit(#[from] crate::error::domain::LimitError),
    /// A request cannot be carried out as asked: the message says what to
    /// give instead (options named as `{name}`).
    #[error("{0}")]
    Request(String),
    /// Reading or writing `path` failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file, as named by the caller.
        path: std::path::PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The program was compensated by volcomp already: compensating it again
    /// would apply every correction twice.
    #[error("{file}:{line}: this program was compensated by volcomp already ({evidence} is here); compensating it again would apply every correction twice: compensate the original program, or allow recompensation ({{allow_recompensate}}) if that is really meant")]
    AlreadyCompensated {
        /// Program name.
        file: String,
        /// 1-based line of the evidence.
        line: u64,
        /// What shows the earlier compensation.
        evidence: CompensatedEvidence,
    },
}

impl From<crate::error::domain::LoadError> for Error {
    fn from(e: crate::error::domain::LoadError) -> Self {
        Error::Load(Box::new(e))
    }
}

/// What is wrong with a ballbar test or trace.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct BallbarError(pub String);

impl BallbarError {
    pub(crate) fn new(text: impl Into<String>) -> Self {
        Self(text.into())
    }
}

/// An option's value was refused. The text names options as `{name}`;
/// `OptionError::render` (with the requests, `crate::request`) writes them
/// in a front end's terms, `Display` by their names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OptionError {
    /// The option at fault.
    pub option: &'static str,
    /// What is wrong and what to do, after the option's name (`must be …`).
    pub problem: String,
}

impl OptionError {
    /// `option` refused: `problem` (after its name).
    pub fn new(option: &'static str, problem: impl Into<String>) -> Self {
        Self {
            option,
            problem: problem.into(),
        }
    }

    /// A request has no option `name` (a misspelt keyword); `option` is one
    /// of the request's own, named beside the message.
    pub fn unknown(option: &'static str, name: &str) -> Self {
        Self::new(option, format!("has no option `{name}`"))
    }
}

/// Where an error is: the file, and the 1-based line (row) and column when
/// the error points into the file. What a front end shows beside the message
/// (the Python bindings put it on their exceptions).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ErrorLocation {
    /// The file (or program name) as the caller named it, when known.
    pub file: Option<String>,
    /// 1-based line of a program or row of a table; `None` for a file as a whole.
    pub line: Option<u64>,
    /// 1-based column (byte of a program line, field of a table, character
    /// of a TOML line); `None` when the error is a whole line.
    pub column: Option<usize>,
}

impl ErrorLocation {
    fn at(file: Option<&str>, line: u64, column: Option<usize>) -> Self {
        Self {
            file: file.map(str::to_string),
            line: (line > 0).then_some(line),
            column: column.filter(|c| *c > 0),
        }
    }

    fn file(file: impl Into<String>) -> Self {
        Self {
            file: Some(file.into()),
            ..Self::default()
        }
    }

    fn of_map_file(e: &MapFileError) -> Self {
        Self::at(Some(&e.file), e.row as u64, Some(e.column))
    }

    fn of_gcode(e: &GcodeError, file: Option<&str>) -> Self {
        let d = &e.diagnostic;
        Self::at(d.file.as_deref().or(file), d.line, Some(d.column))
    }

    fn of_compensation(e: &CompensationError) -> Option<Self> {
        match e {
            CompensationError::Gcode(g) => Some(Self::of_gcode(g, None)),
            CompensationError::Model { file, line, .. }
            | CompensationError::AtLine { file, line, .. } => {
                Some(Self::at(Some(file), *line, None))
            }
            CompensationError::Io(_) => None,
        }
    }
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<std::path::PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// Where the error is (file, line, column), when it points into a file
    /// or program; `None` for errors of the inputs as a whole.
    ///
    /// ```
    /// use volcomp_core::error::{Error, MapFileError};
    /// let e = Error::from(MapFileError::new("m.csv", 3, 2, "not a number", "write 1.5"));
    /// let at = e.location().unwrap();
    /// assert_eq!((at.file.as_deref(), at.line, at.column), (Some("m.csv"), Some(3), Some(2)));
    /// ```
    pub fn location(&self) -> Option<ErrorLocation> {
        use crate::error::domain::LoadError;
        use crate::error::domain::MirrorError;
        use crate::error::domain::ModelFileError;
        use crate::error::domain::ThermalError;
        use crate::error::straightness::StraightnessError;
        let model_file = |e: &ModelFileError| match e {
            ModelFileError::Format(f) => ErrorLocation::of_map_file(f),
            ModelFileError::Io { path, .. } | ModelFileError::NotToml { path } => {
                ErrorLocation::file(path.clone())
            }
        };
        let straightness = |e: &StraightnessError| match e {
            StraightnessError::File(f) => Some(ErrorLocation::of_map_file(f)),
            StraightnessError::ModelFile { file, .. } => Some(ErrorLocation::file(file.clone())),
            _ => None,
        };
        match self {
            Error::MapFile(e) => Some(ErrorLocation::of_map_file(e)),
            Error::ModelFile(e) => Some(model_file(e)),
            Error::Compensation(e) => ErrorLocation::of_compensation(e),
            Error::Gcode(e) | Error::Setup(e) => Some(ErrorLocation::of_gcode(e, None)),
            Error::Thermal(ThermalError::File(f)) => Some(ErrorLocation::of_map_file(f)),
            Error::Thermal(ThermalError::NoSuchCycle { file, .. }) => {
                Some(ErrorLocation::file(file.clone()))
            }
            Error::Straightness(e) => straightness(e),
            Error::Probe(crate::error::domain::ProbeError::File(f)) => {
                Some(ErrorLocation::of_map_file(f))
            }
            Error::Mirror(MirrorError::File(f)) => Some(ErrorLocation::of_map_file(f)),
            Error::Mirror(MirrorError::InFile { file, .. })
            | Error::Mirror(MirrorError::NominalFormat { file }) => {
                Some(ErrorLocation::file(file.clone()))
            }
            Error::Mirror(MirrorError::Program(e)) => ErrorLocation::of_compensation(e),
            Error::Load(e) => match e.as_ref() {
                LoadError::Io { path, .. } | LoadError::UnknownFormat { path } => {
                    Some(ErrorLocation::file(path.display().to_string()))
                }
                LoadError::File(f) | LoadError::ComponentTable { source: f } => {
                    Some(ErrorLocation::of_map_file(f))
                }
                LoadError::Kinematic(k) => Some(model_file(k)),
                LoadError::Straightness(s) => straightness(s),
            },
            Error::Io { path, .. } => Some(ErrorLocation::file(path.display().to_string())),
            Error::AlreadyCompensated { file, line, .. } => {
                Some(ErrorLocation::at(Some(file), *line, None))
            }
            _ => None,
        }
    }

    /// The kind of failure (see [`ErrorKind`]).
    ///
    /// ```
    /// use volcomp_core::error::{Error, ErrorKind, ModelError};
    /// use volcomp_gcode::{ErrorClass, GcodeError};
    /// let unsupported = GcodeError::new(ErrorClass::Unsupported, 1, 1, "G52", "remove it");
    /// assert_eq!(Error::from(unsupported).kind(), ErrorKind::RefusedProgram);
    /// let far = ModelError::OutOfRange { axis: 'X', position_mm: 9.0, min_mm: 0.0, max_mm: 1.0 };
    /// assert_eq!(Error::from(far).kind(), ErrorKind::RefusedProgram);
    /// assert_eq!(Error::io("a.csv", std::io::Error::other("gone")).kind(), ErrorKind::Io);
    /// ```
    pub fn kind(&self) -> ErrorKind {
        use crate::error::domain::MirrorError;
        use crate::error::domain::ModelFileError;
        match self {
            Error::Model(_) | Error::AlreadyCompensated { .. } => ErrorKind::RefusedProgram,
            Error::Compensation(e) => e.kind(),
            Error::Gcode(e) => gcode_kind(e),
            Error::Mirror(MirrorError::Program(e)) => e.kind(),
            Error::ModelFile(ModelFileError::Io { .. }) => ErrorKind::Io,
            Error::Io { .. } | Error::Output(_) => ErrorKind::Io,
            Error::Load(e) if matches!(**e, crate::error::domain::LoadError::Io { .. }) => {
                ErrorKind::Io
            }
            Error::MapFile(_)
            | Error::ModelFile(_)
            | Error::Setup(_)
            | Error::Load(_)
            | Error::Thermal(_)
            | Error::Straightness(_)
            | Error::Probe(_)
            | Error::Mirror(_)
            | Error::BSpline(_)
            | Error::Topology(_)
            | Error::OutputPlan(_)
            | Error::Option(_)
            | Error::Ballbar(_)
            | Error::Limit(_)
            | Error::Request(_) => ErrorKind::BadInput,
        }
    }
}

/// An interpreter error refuses the program unless reading it failed.
fn gcode_kind(e: &GcodeError) -> ErrorKind {
    match e.class {
        volcomp_gcode::ErrorClass::Io => ErrorKind::Io,
        _ => ErrorKind::RefusedProgram,
    }
}

impl CompensationError {
    /// The kind of failure: everything located at a program line refuses the
    /// program; failing to read or write it is I/O.
    pub fn kind(&self) -> ErrorKind {
        match self {
            CompensationError::Gcode(e) => gcode_kind(e),
            CompensationError::Model { .. } | CompensationError::AtLine { .. } => {
                ErrorKind::RefusedProgram
            }
            CompensationError::Io(_) => ErrorKind::Io,
        }
    }
}

/// Help texts of located compensation and simulation errors
/// ([`CompensationError::AtLine`]) that name an option. They name options
/// as `{name}` (the requests' option names, `crate::request`); a front end
/// writes each its own way (`--no-split`, `no_split=True`).
pub mod help {
    /// Splitting a block under inverse-time feed (G93).
    pub const SPLIT_UNDER_INVERSE_TIME: &str =
        "turn segmentation off ({no_split}) for straight moves, or post the program in G94 (units per minute)";
    /// A block would give more points than the limit.
    pub const TOO_MANY_POINTS: &str = "split the move in the program, or choose a coarser segmentation: a longer {segment_length_mm}, fewer {segments}, a larger {chord_tolerance_mm} or a longer {min_segment_length_mm}";
    /// A correction above the largest accepted.
    pub const CORRECTION_LIMIT: &str = "check that the map is in µm (not mm) and belongs to this machine; raise the largest accepted correction ({max_correction_mm}) only if the machine really is this far off";
    /// A point whose residual is above the largest accepted.
    pub const RESIDUAL_LIMIT: &str = "with ILC raise the iteration limit ({max_iterations}) or the gain ({gain}); check that the map is smooth and in µm; the largest accepted residual is {max_residual_um}";
    /// A simulated line that does not pair with the reference.
    pub const REFERENCE_PAIRING: &str = "give as the reference ({reference}) the original program this one was compensated from by volcomp (its `(volcomp Ln)` comments pair the two; a program written without trace comments ({trace}) cannot be paired once lines were split or take-ups inserted)";
    /// The reference moves on after the simulated program ends.
    pub const REFERENCE_LEFT: &str = "give as the reference ({reference}) the original program this one was compensated from, and simulate the whole compensated program";
}
