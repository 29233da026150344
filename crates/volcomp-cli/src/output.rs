//! Writing results through the library's output layer
//! (`volcomp_core::io::output`), and the CLI's error type.
//!
//! Every command first declares its inputs and outputs in an
//! [`OutputPlan`] and checks it ([`check`]) before any work; then it
//! writes each output with [`write_atomically`] (one output) or stages
//! several in [`Staged`] and puts them in place together.

use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
pub use volcomp_core::io::output::OutputPlan;
use volcomp_core::io::output::{self, Ledger, OutputError, StageError};
use volcomp_core::ErrorKind;

/// A message as printed on a terminal: control characters other than the
/// line feed escaped (`\x1b`), so that no byte of a file name or value a
/// user gave drives the terminal.
pub fn clean(message: &str) -> std::borrow::Cow<'_, str> {
    volcomp_gcode::error::escape_controls(message)
}

/// Everything that can stop a command, with a message meant for a person.
#[derive(Debug)]
pub enum CliError {
    /// Bad input or usage, in a message that already says what and where.
    Message(String),
    /// An I/O failure on a named path.
    Io(PathBuf, io::Error),
    /// Writing to standard output failed.
    Stdout(io::Error),
    /// An output could not be written (or only some were).
    Output(OutputError),
    /// A library error, kept whole (its cause chain is its `source()`);
    /// `text`, when set, is the CLI's own wording of it (with flag names).
    Library {
        /// What kind of failure (chooses the exit status).
        kind: ErrorKind,
        /// The CLI's wording, if it rewords the library's message.
        text: Option<String>,
        /// The error itself.
        error: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
    /// A bug in volcomp.
    Internal(String),
}

/// Exit status of a run that succeeded.
pub const EXIT_OK: u8 = 0;
/// Exit status of an internal error (a bug: please report it).
pub const EXIT_INTERNAL: u8 = 1;
/// Exit status of bad input or usage, or of an input or output that could
/// not be read or written (clap's usage errors are 2 as well).
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit status of a program refused by the interpreter or the compensation
/// (unsupported or invalid G-code, a point outside the map, a residual or a
/// correction above its limit, a program compensated already).
pub const EXIT_REFUSED: u8 = 3;

impl CliError {
    /// A library error worded by the CLI (e.g. with its flag names).
    pub fn reworded(text: String, error: impl std::error::Error + Send + Sync + 'static) -> Self {
        match CliError::from(error) {
            CliError::Library { kind, error, .. } => CliError::Library {
                kind,
                text: Some(text),
                error,
            },
            other => other,
        }
    }

    /// A closed standard output (e.g. piped into `head`).
    pub fn is_broken_pipe(&self) -> bool {
        let pipe = |e: &io::Error| e.kind() == io::ErrorKind::BrokenPipe;
        match self {
            CliError::Stdout(e) => pipe(e),
            CliError::Io(p, e) => p.as_os_str() == "-" && pipe(e),
            CliError::Output(o) => o.is_stdout() && o.io_error().is_some_and(pipe),
            CliError::Message(_) | CliError::Library { .. } | CliError::Internal(_) => false,
        }
    }

    /// Whether an output passed its size limit (the library's
    /// [`volcomp_core::limits::LimitedWriter`] reports it as an I/O error of
    /// kind `FileTooLarge`, somewhere in the cause chain).
    pub fn passed_size_limit(&self) -> bool {
        let mut next = self.source();
        while let Some(e) = next {
            if e.downcast_ref::<io::Error>()
                .is_some_and(|io| io.kind() == io::ErrorKind::FileTooLarge)
            {
                return true;
            }
            next = e.source();
        }
        false
    }

    /// The process exit status for this error (docs/errors.md, "Exit codes").
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Library { kind, .. } => match kind {
                ErrorKind::RefusedProgram => EXIT_REFUSED,
                ErrorKind::Internal => EXIT_INTERNAL,
                ErrorKind::BadInput | ErrorKind::Io => EXIT_BAD_INPUT,
                _ => EXIT_INTERNAL,
            },
            CliError::Internal(_) => EXIT_INTERNAL,
            CliError::Message(_) | CliError::Io(..) | CliError::Stdout(_) | CliError::Output(_) => {
                EXIT_BAD_INPUT
            }
        }
    }

    /// The cause of this error, if it keeps one (the library error itself,
    /// whose own `source()` goes on down the chain).
    pub fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CliError::Library { error, .. } => {
                Some(error.as_ref() as &(dyn std::error::Error + 'static))
            }
            CliError::Io(_, e) | CliError::Stdout(e) => Some(e),
            CliError::Output(e) => Some(e),
            CliError::Message(_) | CliError::Internal(_) => None,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Message(m) => f.write_str(m),
            CliError::Io(p, e) if p.as_os_str() == "-" => {
                write!(f, "cannot write to standard output: {e}")
            }
            CliError::Io(p, e) => write!(f, "{}: {e}", p.display()),
            CliError::Stdout(e) => write!(f, "cannot write to standard output: {e}"),
            CliError::Output(e) => write!(f, "{e}"),
            CliError::Library {
                text: Some(text), ..
            } => f.write_str(text),
            CliError::Library { error, .. } => write!(f, "{error}"),
            CliError::Internal(m) => write!(f, "internal error: {m}; please report it"),
        }
    }
}

/// The kind of a library error, found by its type; errors of other crates
/// (and library errors without a kind) are bad input.
fn kind_of(e: &(dyn std::error::Error + 'static)) -> ErrorKind {
    use volcomp_core::error::{CompensationError, ModelError};
    if let Some(e) = e.downcast_ref::<volcomp_core::Error>() {
        e.kind()
    } else if let Some(e) = e.downcast_ref::<CompensationError>() {
        e.kind()
    } else if let Some(e) = e.downcast_ref::<volcomp_gcode::GcodeError>() {
        volcomp_core::Error::from(e.clone()).kind()
    } else if e.downcast_ref::<ModelError>().is_some() {
        ErrorKind::RefusedProgram
    } else if let Some(e) = e.downcast_ref::<volcomp_core::surface::mirror::MirrorError>() {
        match e {
            volcomp_core::surface::mirror::MirrorError::Program(c) => c.kind(),
            _ => ErrorKind::BadInput,
        }
    } else {
        ErrorKind::BadInput
    }
}

impl<E: std::error::Error + Send + Sync + 'static> From<E> for CliError {
    fn from(e: E) -> Self {
        let kind = kind_of(&e);
        CliError::Library {
            kind,
            text: crate::flags::reword(&e),
            error: Box::new(e),
        }
    }
}

/// The outputs the command declared, and those put in place so far: if
/// the command fails after some were written, `main` says which.
static LEDGER: Ledger = Ledger::new();

/// Refuses a plan whose outputs name an input or each other. Call it
/// before any work: nothing has been written when it fails.
pub fn check(plan: &OutputPlan) -> Result<(), CliError> {
    LEDGER
        .check(plan)
        .map_err(|e| CliError::Message(e.to_string()))
}

/// After a failure: which declared outputs were written before it and
/// which were not (left as they were), if any were written.
pub fn outputs_note() -> Option<String> {
    LEDGER.note()
}

/// Outputs written to temporaries and put in place together
/// ([`volcomp_core::io::output::Staged`]).
#[derive(Default)]
pub struct Staged(output::Staged);

impl Staged {
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `bytes` as one output.
    pub fn write_bytes(&mut self, target: &Path, bytes: &[u8]) -> Result<(), CliError> {
        self.write(target, |w| {
            w.write_all(bytes)
                .map_err(|e| CliError::Io(target.to_path_buf(), e))
        })
    }

    /// Writes one output (`-` is standard output) into its temporary.
    pub fn write(
        &mut self,
        target: &Path,
        write: impl FnOnce(&mut dyn Write) -> Result<(), CliError>,
    ) -> Result<(), CliError> {
        self.0.write(target, write).map_err(|e| match e {
            StageError::Io(path, e) => CliError::Io(path, e),
            StageError::Output(e) => CliError::Output(e),
            StageError::Writer(e) => e,
        })
    }

    /// Puts every staged output in place.
    pub fn commit(self) -> Result<(), CliError> {
        self.0.commit(&LEDGER).map_err(CliError::Output)
    }
}

/// Writes one output completely or not at all (see `volcomp_core::io::output`);
/// refuses to write over any of `inputs`. Commands with several outputs
/// check an [`OutputPlan`] first and use [`Staged`].
pub fn write_atomically(
    target: &Path,
    inputs: &[&Path],
    write: impl FnOnce(&mut dyn Write) -> Result<(), CliError>,
) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for i in inputs {
        plan.input("input", i);
    }
    plan.output("output", target);
    check(&plan)?;
    let mut staged = Staged::new();
    staged.write(target, write)?;
    staged.commit()
}

/// Writes `bytes` to `target` as [`write_atomically`] does.
pub fn write_file(target: &Path, inputs: &[&Path], bytes: &[u8]) -> Result<(), CliError> {
    write_atomically(target, inputs, |w| {
        w.write_all(bytes)
            .map_err(|e| CliError::Io(target.to_path_buf(), e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcomp_core::error::{CompensationError, ModelError};

    #[test]
    fn a_library_error_keeps_its_cause_chain_and_its_kind() {
        let model = ModelError::OutOfRange {
            axis: 'X',
            position_mm: 700.0,
            min_mm: 0.0,
            max_mm: 600.0,
        };
        let e = CliError::from(volcomp_core::Error::from(CompensationError::Model {
            file: "p.ngc".into(),
            line: 3,
            target_mm: None,
            source: model.clone(),
        }));
        assert_eq!(e.exit_code(), EXIT_REFUSED);
        assert!(e.to_string().starts_with("p.ngc:3: axis X = 700 mm"), "{e}");
        // CliError → volcomp_core::Error → CompensationError → ModelError.
        let core = e.source().unwrap();
        let compensation = std::error::Error::source(core).unwrap();
        assert!(compensation.downcast_ref::<CompensationError>().is_some());
        let cause = std::error::Error::source(compensation).unwrap();
        assert_eq!(cause.downcast_ref::<ModelError>(), Some(&model));
    }

    #[test]
    fn exit_codes_follow_the_kind() {
        let bad = CliError::from(volcomp_core::error::MapFileError::new(
            "m.csv", 2, 1, "x", "y",
        ));
        assert_eq!(bad.exit_code(), EXIT_BAD_INPUT);
        assert_eq!(
            CliError::Message("usage".into()).exit_code(),
            EXIT_BAD_INPUT
        );
        assert_eq!(CliError::Internal("bug".into()).exit_code(), EXIT_INTERNAL);
        let g = volcomp_gcode::GcodeError::new(
            volcomp_gcode::ErrorClass::Unsupported,
            1,
            1,
            "G52",
            "h",
        );
        assert_eq!(CliError::from(g).exit_code(), EXIT_REFUSED);
    }
}
