//! volcomp's errors as Python exceptions.
//!
//! One hierarchy, rooted at `VolcompError`, one class per
//! [`volcomp_core::ErrorKind`] (the CLI maps the same kinds to its exit
//! codes, docs/errors.md). Every instance carries `file`, `line`, `column`
//! (each `None` when the error does not point into a file) and `message`
//! (the library's whole text: what is wrong and what to do).

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use volcomp_core::{Error, ErrorKind};

create_exception!(
    volcomp,
    VolcompError,
    PyException,
    "Any error of volcomp. Attributes: `file`, `line`, `column` (None when the error does not point into a file), `message` (what is wrong and what to do)."
);
create_exception!(
    volcomp,
    BadInputError,
    VolcompError,
    "An input file, array or option is malformed or inconsistent: fix the input."
);
create_exception!(
    volcomp,
    RefusedProgramError,
    VolcompError,
    "The G-code interpreter or the compensation refused the program (unsupported or invalid G-code, a point outside the model's range, a residual or correction above its limit, a program compensated already)."
);
create_exception!(
    volcomp,
    VolcompIOError,
    VolcompError,
    "A file could not be read or written."
);
create_exception!(
    volcomp,
    VolcompWarning,
    pyo3::exceptions::PyUserWarning,
    "What the G-code interpreter assumed (no units, no work offset, …): `file:line:column: warning: …`."
);

/// Adds the exception classes to the module.
pub fn register(py: Python<'_>, m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("VolcompError", py.get_type::<VolcompError>())?;
    m.add("BadInputError", py.get_type::<BadInputError>())?;
    m.add("RefusedProgramError", py.get_type::<RefusedProgramError>())?;
    m.add("VolcompIOError", py.get_type::<VolcompIOError>())?;
    m.add("VolcompWarning", py.get_type::<VolcompWarning>())?;
    Ok(())
}

/// Where an error points: file, 1-based line and column.
#[derive(Debug, Clone, Default)]
pub struct Located {
    pub file: Option<String>,
    pub line: Option<u64>,
    pub column: Option<usize>,
}

/// `err` with its location and message as attributes.
fn located(err: PyErr, message: &str, at: Located) -> PyErr {
    Python::attach(|py| {
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail in
        // practice; if it did, the exception still carries its message.
        let _ = value.setattr("file", at.file);
        let _ = value.setattr("line", at.line);
        let _ = value.setattr("column", at.column);
        let _ = value.setattr("message", message);
    });
    err
}

/// A `BadInputError` about an argument (no file position).
pub fn bad_input(message: impl Into<String>) -> PyErr {
    bad_input_at(message, Located::default())
}

/// A `BadInputError` at a file position.
pub fn bad_input_at(message: impl Into<String>, at: Located) -> PyErr {
    let message = message.into();
    located(BadInputError::new_err(message.clone()), &message, at)
}

/// A `VolcompIOError` on a file.
pub fn io_error(path: &str, e: &std::io::Error) -> PyErr {
    let message = format!("{path}: {e}");
    let at = Located {
        file: Some(path.to_string()),
        ..Located::default()
    };
    located(VolcompIOError::new_err(message.clone()), &message, at)
}

/// The library's error as the exception of its kind, located.
pub fn to_py(e: Error) -> PyErr {
    // Options named `{name}` said as Python keywords.
    let message = match &e {
        Error::Option(o) => o.render(&crate::request::Keywords),
        e => crate::request::keywords(&e.to_string()),
    };
    let at = e
        .location()
        .map(|l| Located {
            file: l.file,
            line: l.line,
            column: l.column,
        })
        .unwrap_or_default();
    let err = match e.kind() {
        ErrorKind::BadInput => BadInputError::new_err(message.clone()),
        ErrorKind::RefusedProgram => RefusedProgramError::new_err(message.clone()),
        ErrorKind::Io => VolcompIOError::new_err(message.clone()),
        _ => VolcompError::new_err(message.clone()),
    };
    located(err, &message, at)
}

/// `Result<T, E: Into<Error>>` → `PyResult<T>`.
pub trait IntoPy<T> {
    fn py_err(self) -> PyResult<T>;
}

impl<T, E: Into<Error>> IntoPy<T> for Result<T, E> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| to_py(e.into()))
    }
}
