//! Python arguments → the library's inputs: text or files, arrays, the
//! machine set-up.
//!
//! One rule for every input that may be a file: a `str` (or `bytes`) is the
//! content itself, an `os.PathLike` (`pathlib.Path`) names a file.

use crate::errors::{bad_input, io_error};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyString};
use std::path::PathBuf;
use volcomp_core::report::columns::{Field, Fields};
use volcomp_core::request::{Input, Machine};
use volcomp_gcode::Vec3;

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

/// A file name: a `str` or an `os.PathLike`.
pub fn file_path(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    if is_path_like(obj) {
        return path_of(obj);
    }
    obj.extract::<String>()
        .map(PathBuf::from)
        .map_err(|_| bad_input("path must be a file name (str or pathlib.Path)"))
}

/// Reads an input file: a path (`str` or `os.PathLike`) or a file
/// object's content (the one rule of the package: text only through a file
/// object, `io.StringIO(text)`); `what` names the argument in messages,
/// `name` overrides the name messages give the input.
pub fn source(obj: &Bound<'_, PyAny>, what: &str, name: Option<&str>) -> PyResult<Source> {
    let (bytes, shown, path) = match crate::request::input(obj, what)? {
        Input::File(path) => {
            let shown = path.display().to_string();
            let bytes =
                volcomp_core::io::inputs::read(&path, what).map_err(|e| io_error(&shown, &e))?;
            (bytes, shown, Some(path))
        }
        Input::Content { name, bytes } => (bytes, name, None),
    };
    Ok(Source {
        bytes,
        name: name.map(str::to_string).unwrap_or(shown),
        path,
    })
}

/// A text argument (a `str` is the text itself, `bytes` its UTF-8 bytes),
/// or a path (`os.PathLike`) or file object as [`source`] reads them.
pub fn text_or_file(obj: &Bound<'_, PyAny>, what: &str, name: Option<&str>) -> PyResult<Source> {
    let named = |default: String| name.map(str::to_string).unwrap_or(default);
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Source {
            bytes: s.to_str()?.as_bytes().to_vec(),
            name: named(format!("<{what}>")),
            path: None,
        });
    }
    if let Ok(b) = obj.cast::<PyBytes>() {
        return Ok(Source {
            bytes: b.as_bytes().to_vec(),
            name: named(format!("<{what}>")),
            path: None,
        });
    }
    source(obj, what, name)
}

/// `obj` as a C-contiguous float64 array of shape (N, `cols`); a 1-D array
/// of `cols` values is one row.
pub fn f64_rows<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    cols: usize,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let arr = float64(obj, what)?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    let wanted = || {
        bad_input(format!(
            "{what} must be an array of shape (N, {cols}) or ({cols},)"
        ))
    };
    let arr = match ndim {
        1 => arr
            .call_method1("reshape", ((1usize, cols),))
            .map_err(|_| wanted())?,
        2 => arr,
        _ => return Err(wanted()),
    };
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
    let arr: numpy::PyReadonlyArray1<f64> = float64(obj, what)?
        .extract()
        .map_err(|_| bad_input(format!("{what} must be a 1-D array of numbers")))?;
    Ok(arr.as_array().to_vec())
}

/// `obj` as a C-contiguous float64 array.
fn float64<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Bound<'py, PyAny>> {
    let kwargs = PyDict::new(obj.py());
    kwargs.set_item("dtype", "float64")?;
    obj.py()
        .import("numpy")?
        .call_method("ascontiguousarray", (obj,), Some(&kwargs))
        .map_err(|e| bad_input(format!("{what}: not an array of numbers ({e})")))
}

/// Warns (`VolcompWarning`) that no work offset was given, as the CLI does.
pub fn warn_without_work_offset(py: Python<'_>, m: &Machine) -> PyResult<()> {
    match m.work_offset_warning() {
        Some(w) => warn(py, &crate::request::keywords(&w)),
        None => Ok(()),
    }
}

/// Issues a `VolcompWarning`.
pub fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let cat = py.get_type::<crate::errors::VolcompWarning>();
    let c = std::ffi::CString::new(message.replace('\0', " "))
        .unwrap_or_else(|_| c"volcomp warning".to_owned());
    PyErr::warn(py, &cat, &c, 1)
}

/// The library's named fields as a dict: columns as numpy arrays (rows of
/// three as (N, 3)), free texts as lists, figures as numbers, groups as
/// dicts.
pub fn fields<'py>(py: Python<'py>, f: &Fields) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, v) in &f.0 {
        let v: Bound<'py, PyAny> = match v {
            Field::Numbers(v) => PyArray1::from_slice(py, v).into_any(),
            Field::Counts(v) => PyArray1::from_slice(py, v).into_any(),
            Field::Small(v) => PyArray1::from_slice(py, v).into_any(),
            Field::Flags(v) => PyArray1::from_slice(py, v).into_any(),
            Field::Rows3(v) => vec3_rows(py, v).into_any(),
            Field::Words(v) => py.import("numpy")?.call_method1("array", (v,))?,
            Field::Texts(v) => v.into_pyobject(py)?.into_any(),
            Field::Number(x) => x.into_pyobject(py)?.into_any(),
            Field::Count(n) => n.into_pyobject(py)?.into_any(),
            Field::Group(g) => fields(py, g)?.into_any(),
        };
        d.set_item(name, v)?;
    }
    Ok(d)
}

/// Vectors as an array of shape (N, 3).
pub fn vec3_rows<'py>(py: Python<'py>, v: &[Vec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = v.iter().flat_map(|e| [e.x, e.y, e.z]).collect();
    Array2::from_shape_vec((v.len(), 3), flat)
        .unwrap_or_else(|_| Array2::zeros((0, 3)))
        .into_pyarray(py)
}

/// A value of the library as Python's `json.loads` of its JSON (the CLI's
/// `--json` objects).
pub fn from_json<'py>(py: Python<'py>, v: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_string(v).map_err(|e| bad_input(e.to_string()))?;
    py.import("json")?.call_method1("loads", (json,))
}
