//! Python arguments → the library's inputs: text or files, arrays, the
//! machine set-up.
//!
//! One rule for every input that may be a file: a `str` (or `bytes`) is the
//! content itself, an `os.PathLike` (`pathlib.Path`) names a file.

use crate::errors::{bad_input, io_error, IntoPy};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyString};
use std::path::PathBuf;
use volcomp_core::MachineSetup;
use volcomp_gcode::{InterpOptions, Vec3};

/// A text input: its bytes, the name messages give it, and its path when it
/// came from a file.
pub struct Source {
    pub bytes: Vec<u8>,
    pub name: String,
    pub path: Option<PathBuf>,
}

/// Whether `obj` names a file (`os.PathLike`).
pub fn is_path_like(obj: &Bound<'_, PyAny>) -> bool {
    obj.hasattr("__fspath__").unwrap_or(false)
}

/// The path an `os.PathLike` names.
pub fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    let os = obj.py().import("os")?;
    let p = os.call_method1("fspath", (obj,))?;
    if let Ok(s) = p.cast::<PyString>() {
        return Ok(PathBuf::from(s.to_str()?));
    }
    Err(bad_input("a path must be text (str), not bytes"))
}

/// Reads a `str` / `bytes` content or an `os.PathLike` file; `what` names
/// the argument in messages, `name` is the content's name when given as text.
pub fn source(obj: &Bound<'_, PyAny>, what: &str, name: Option<&str>) -> PyResult<Source> {
    if is_path_like(obj) {
        let path = path_of(obj)?;
        let shown = path.display().to_string();
        let bytes =
            volcomp_core::io::inputs::read(&path, what).map_err(|e| io_error(&shown, &e))?;
        return Ok(Source {
            bytes,
            name: name.map(str::to_string).unwrap_or(shown),
            path: Some(path),
        });
    }
    let name = name
        .map(str::to_string)
        .unwrap_or_else(|| format!("<{what}>"));
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Source {
            bytes: s.to_str()?.as_bytes().to_vec(),
            name,
            path: None,
        });
    }
    if let Ok(b) = obj.cast::<PyBytes>() {
        return Ok(Source {
            bytes: b.as_bytes().to_vec(),
            name,
            path: None,
        });
    }
    Err(bad_input(format!(
        "{what} must be its text (str or bytes) or a path (pathlib.Path); got {}",
        obj.get_type().name()?
    )))
}

/// `obj` as a C-contiguous float64 array of shape (N, `cols`); a 1-D array
/// of `cols` values is one row.
pub fn f64_rows<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    cols: usize,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let arr = np
        .call_method("ascontiguousarray", (obj,), Some(&kwargs))
        .map_err(|e| bad_input(format!("{what}: not an array of numbers ({e})")))?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    let arr = match ndim {
        1 => arr.call_method1("reshape", ((1usize, cols),)),
        2 => Ok(arr),
        _ => Err(bad_input(format!(
            "{what} must be an array of shape (N, {cols}); got {ndim} dimensions"
        ))),
    }
    .map_err(|_| {
        bad_input(format!(
            "{what} must be an array of shape (N, {cols}) or ({cols},)"
        ))
    })?;
    let arr: PyReadonlyArray2<'py, f64> = arr.extract()?;
    if arr.shape()[1] != cols {
        return Err(bad_input(format!(
            "{what} must be an array of shape (N, {cols}); got shape {:?}",
            arr.shape()
        )));
    }
    Ok(arr)
}

/// `obj` as a 1-D float64 vector.
pub fn f64_vec(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let arr = np
        .call_method("ascontiguousarray", (obj,), Some(&kwargs))
        .map_err(|e| bad_input(format!("{what}: not an array of numbers ({e})")))?;
    let arr: numpy::PyReadonlyArray1<f64> = arr
        .extract()
        .map_err(|_| bad_input(format!("{what} must be a 1-D array of numbers")))?;
    Ok(arr.as_array().to_vec())
}

/// Three finite numbers in mm.
pub fn triple_mm(v: &[f64], what: &str) -> PyResult<Vec3> {
    if v.len() != 3 || !v.iter().all(|x| x.is_finite()) {
        return Err(bad_input(format!(
            "{what} must be three finite numbers in mm (X, Y, Z); got {v:?}"
        )));
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// The machine a program runs on, as the CLI's `--setup`, `--work-offset`,
/// `--absolute-arc-centers`, `--strict-k0` and `--allow-no-program-end`
/// build it; the set-up file's name (for the compensated program's header).
pub struct Machine {
    pub setup: MachineSetup,
    pub setup_file: Option<PathBuf>,
    pub work_offset_given: bool,
}

/// Options shared by every function that reads a program.
pub struct MachineArgs<'a, 'py> {
    pub setup: Option<&'a Bound<'py, PyAny>>,
    pub work_offset_mm: Option<Vec<f64>>,
    pub absolute_arc_centers: bool,
    pub accept_k0: bool,
    pub allow_no_program_end: bool,
    pub chord_tolerance_mm: f64,
}

pub fn machine(a: MachineArgs<'_, '_>) -> PyResult<Machine> {
    if !(a.chord_tolerance_mm.is_finite() && a.chord_tolerance_mm > 0.0) {
        return Err(bad_input(format!(
            "chord_tolerance_mm must be a positive length in mm; got {}",
            a.chord_tolerance_mm
        )));
    }
    let (mut setup, setup_file) = match a.setup {
        None => (MachineSetup::unset(), None),
        Some(obj) if is_path_like(obj) => {
            let path = path_of(obj)?;
            (MachineSetup::from_setup_file(&path).py_err()?, Some(path))
        }
        Some(obj) => {
            let text = source(obj, "setup", None)?;
            let text = String::from_utf8(text.bytes)
                .map_err(|_| bad_input("setup: the set-up text is not UTF-8"))?;
            (
                MachineSetup::from_setup_toml(&text, "<setup>").py_err()?,
                None,
            )
        }
    };
    let work_offset_given = a.work_offset_mm.is_some();
    if let Some(w) = &a.work_offset_mm {
        setup = setup.with_work_offset(triple_mm(w, "work_offset_mm")?);
    }
    let setup = setup
        .with_interp_options(InterpOptions {
            accept_k0_on_xy_arcs: a.accept_k0,
            absolute_arc_centers: a.absolute_arc_centers,
            require_program_end: !a.allow_no_program_end,
            ..InterpOptions::default()
        })
        .with_spline_tolerance(a.chord_tolerance_mm);
    Ok(Machine {
        setup,
        setup_file,
        work_offset_given,
    })
}

/// Warns (`VolcompWarning`) that no work offset was given, as the CLI does.
pub fn warn_without_work_offset(py: Python<'_>, m: &Machine) -> PyResult<()> {
    if m.setup.no_work_offset {
        warn(py, "no work offset was given (G54 = 0): program coordinates are taken as machine coordinates; give the offsets with setup= or work_offset_mm=")?;
    }
    Ok(())
}

/// Issues a `VolcompWarning`.
pub fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let cat = py.get_type::<crate::errors::VolcompWarning>();
    let c = std::ffi::CString::new(message.replace('\0', " "))
        .unwrap_or_else(|_| c"volcomp warning".to_owned());
    PyErr::warn(py, &cat, &c, 1)
}
