//! The errors of the library's folders (the model's chain, surfaces,
//! identification, files and outputs), defined below every folder so that
//! each can use them and the crate's [`crate::Error`] can wrap them; each
//! folder re-exports its own and keeps their methods.

use crate::error::straightness::StraightnessError;
use crate::error::{CompensationError, MapFileError};
use std::io;
use std::path::PathBuf;
use volcomp_geom::inputs::ReadFile;

/// The `model` key of a 21-component model file.
pub const MODEL_KIND: &str = "kinematic-21";

/// Why a chain string was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("chain `{text}`, character {column}: {message}\n  help: {help}")]
pub struct TopologyError {
    /// The chain as written.
    pub text: String,
    /// 1-based character position of the problem.
    pub column: usize,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
}

/// Why a surface could not be built, fitted or evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BSplineError {
    /// The definition is inconsistent (knots, counts, degrees, values).
    #[error("invalid B-spline surface: {0}")]
    Invalid(String),
    /// Not enough data for the requested degree or net.
    #[error("too few points: {0}")]
    TooFewPoints(String),
    /// The linear system has no unique solution.
    #[error("the fitting system is singular: {0}")]
    Singular(String),
}

/// Why the mirror method refused its input. Every message says what is wrong,
/// where, and what to do.
#[derive(Debug, thiserror::Error)]
pub enum MirrorError {
    /// A located error in an input file (file, row, column, what to do).
    #[error(transparent)]
    File(#[from] MapFileError),
    /// A file as a whole.
    #[error("{file}: {message}\n  help: {help}")]
    InFile {
        /// File name.
        file: String,
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// The method's parameters or the data as a whole.
    #[error("{message}\n  help: {help}")]
    Method {
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// A nominal surface file whose name does not say its format.
    #[error(
        "{file}: the nominal surface must be a B-spline surface (.toml) or a grid of points (.csv)"
    )]
    NominalFormat {
        /// File name.
        file: String,
    },
    /// Reading or writing the finishing program failed.
    #[error(transparent)]
    Program(#[from] CompensationError),
}

/// Something in the probing workflow cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProbeError {
    /// The inputs do not allow the computation; the message says why and what to do.
    #[error("{0}")]
    Invalid(String),
    /// A malformed input file (located).
    #[error(transparent)]
    File(#[from] crate::error::MapFileError),
    /// A generated program that volcomp's own interpreter refuses (a bug
    /// of the planner; the program is not written).
    #[error("the generated probing program does not pass volcomp's interpreter: {0}")]
    Program(String),
}

/// Something in the thermal workflow cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThermalError {
    /// The inputs do not allow the computation; the message says why and what to do.
    #[error("{0}")]
    Invalid(String),
    /// A malformed input file (located).
    #[error(transparent)]
    File(#[from] crate::error::MapFileError),
    /// The kinematic chain does not parse.
    #[error(transparent)]
    Chain(#[from] crate::error::domain::TopologyError),
    /// One measurement cycle could not be identified.
    #[error("cycle {cycle}: {source}")]
    Cycle {
        /// Cycle number as in the file.
        cycle: usize,
        /// Why.
        #[source]
        source: Box<ThermalError>,
    },
    /// A temperature file has no row for the cycle asked for.
    #[error("{file}: no row for cycle {cycle}; cycles there are {first}…{last}")]
    NoSuchCycle {
        /// The temperature file.
        file: String,
        /// The cycle asked for.
        cycle: usize,
        /// The file's first cycle.
        first: usize,
        /// The file's last cycle.
        last: usize,
    },
    /// A measured sphere centre lies outside the axis ranges of the model.
    #[error("{}", .0.describe("the axis ranges ({ranges_mm})"))]
    OutsideRange(OutsideRange),
}

/// A measured sphere centre outside the axis ranges the polynomials live on.
#[derive(Debug, Clone, PartialEq)]
pub struct OutsideRange {
    /// Cycle number as in the file.
    pub cycle: usize,
    /// Placement, 1-based in label order.
    pub placement: usize,
    /// Sphere, 1-based.
    pub sphere: usize,
    /// The axis letter.
    pub axis: char,
    /// The coordinate (mm).
    pub value_mm: f64,
    /// The axis range (mm).
    pub range_mm: [f64; 2],
}

/// A model file could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelFileError {
    /// The file itself could not be read.
    #[error("{path}: {message}")]
    Io {
        /// File name.
        path: String,
        /// What the system said.
        message: String,
    },
    /// The content is malformed (located).
    #[error(transparent)]
    Format(#[from] MapFileError),
    /// A model is to be written under a name that does not end in `.toml`.
    #[error("{path}: a 21-component model is written as a .toml file (its tables go to a .csv beside it)")]
    NotToml {
        /// The name given.
        path: String,
    },
}

/// A model file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The file is malformed at a row and column (including an unknown or
    /// missing kind).
    #[error(transparent)]
    File(#[from] MapFileError),
    /// A 21-component model file (or a table it names) is malformed.
    #[error(transparent)]
    Kinematic(#[from] ModelFileError),
    /// A straightness model file is malformed.
    #[error(transparent)]
    Straightness(#[from] StraightnessError),
    /// A CSV file given as axis tables holds the component table of a
    /// 21-component model.
    #[error("{source}\n  note: this looks like the component table of a 21-component model; pass its TOML description (model = \"{}\") as the map", MODEL_KIND)]
    ComponentTable {
        /// Why it is not an axis-table map.
        source: MapFileError,
    },
    /// The name ends neither in `.csv` nor `.toml` and the content names no kind.
    #[error("{}: choose the map format by extension: .csv for axis tables, .toml for a 21-component model (docs/design.md)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
}

/// One named file of a command: the flag that named it and its path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Role {
    /// How the user named it: `-o`, `--map`, `PROGRAM`, `OUT_DIR/x.comp`…
    pub flag: String,
    /// The path as given (`-` is standard input or output).
    pub path: PathBuf,
}

/// Why a plan was refused: two roles name the same file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlanError {
    /// An output would replace an input.
    OverwritesInput {
        /// The output.
        output: Role,
        /// The input it would replace.
        input: Role,
    },
    /// An output would replace a file read by the command that no option
    /// names (a table named in a model, a var file, a subroutine file…).
    OverwritesRead {
        /// The output.
        output: Role,
        /// The file read, and as what.
        read: Box<ReadFile>,
    },
    /// Two outputs name the same file: one would replace the other.
    SameOutput {
        /// The first output.
        first: Role,
        /// The second output.
        second: Role,
    },
}

/// A failure on one output, naming it.
#[derive(Debug)]
pub enum OutputError {
    /// An I/O error on `path` (`-` for standard output).
    Io {
        /// The output as named by the user.
        path: PathBuf,
        /// What failed.
        source: io::Error,
    },
    /// An output cannot be written there (a directory, a broken link chain).
    Refused {
        /// The output as named by the user.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// Some outputs were put in place before another failed.
    Partial {
        /// Outputs complete and in place.
        written: Vec<PathBuf>,
        /// Outputs left as they were (old content or absent).
        not_written: Vec<PathBuf>,
        /// The failure.
        cause: Box<OutputError>,
    },
}

/// A table a controller cannot hold, with what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{format}: axis {axis}: {message}; {help}")]
pub struct LimitError {
    /// The format's name.
    pub format: &'static str,
    /// The axis (X, Y, Z).
    pub axis: char,
    /// What exceeds the limit.
    pub message: String,
    /// What to do (e.g. a larger step).
    pub help: String,
}
