//! Python keyword arguments → the library's requests
//! (`volcomp_core::request`): each keyword is an option of the library's
//! table, read by its kind and checked by the library; its name, default
//! and help come from that table too (`volcomp/__init__.py` gives the
//! functions their signature and docstring from [`options`]).

use crate::errors::bad_input;
use crate::inputs::{is_path_like, path_of};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString};
use volcomp_core::request::{
    self, CompensateRequest, Input, Kind, MachineRequest, MirrorRequest, OptionInfo, Request,
    SimulateRequest, Spelling, StraightnessFitRequest, ThermalFitRequest, ThermalPredictRequest,
    Value,
};

/// Option names as Python writes them: the keyword, a switch with the
/// value that turns it from its default (`take_up=False`).
pub struct Keywords;

impl Spelling for Keywords {
    fn option(&self, name: &str) -> String {
        match request::find(name) {
            Some(info) if info.kind == Kind::Switch => {
                let on = info.on_by_default();
                format!("{name}={}", if on { "False" } else { "True" })
            }
            Some(_) => name.to_string(),
            // The map's own options are the model's in Python.
            None if name == "clamp" => "Model.load(..., clamp=True)".into(),
            None => name.to_string(),
        }
    }
}

/// A library text with its options said as keywords.
pub fn keywords(text: &str) -> String {
    request::render(text, &Keywords)
}

/// The library's error as the exception of its kind, options said as
/// keywords.
pub use crate::errors::to_py as library_error;

/// An input file: a path (str or os.PathLike) is read by the library, a
/// file object's content is taken as it is (named by its `name`, or
/// `<what>`).
pub fn input(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Input> {
    if is_path_like(obj) {
        return Ok(Input::File(path_of(obj)?));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        let s = s.to_str()?;
        if s.contains('\n') && !std::path::Path::new(s).exists() {
            return Err(crate::errors::VolcompIOError::new_err(format!("{what}: a str names a file, and no file is named by this text of {} lines; give text in a file object: io.StringIO(text)", s.lines().count())));
        }
        return Ok(Input::File(s.into()));
    }
    if obj.hasattr("read")? {
        let content = obj.call_method0("read")?;
        let bytes = if let Ok(s) = content.cast::<PyString>() {
            s.to_str()?.as_bytes().to_vec()
        } else if let Ok(b) = content.cast::<PyBytes>() {
            b.as_bytes().to_vec()
        } else {
            return Err(bad_input(format!(
                "{what}: the file object's read() gave neither text nor bytes"
            )));
        };
        let name = obj
            .getattr("name")
            .ok()
            .and_then(|n| n.extract::<String>().ok())
            .unwrap_or_else(|| format!("<{what}>"));
        return Ok(Input::Content { name, bytes });
    }
    let hint = if obj.cast::<PyBytes>().is_ok() {
        " (for content in memory, pass a file object: io.BytesIO(data) or io.StringIO(text))"
    } else {
        ""
    };
    Err(PyTypeError::new_err(format!(
        "{what} must be a path (str or pathlib.Path) or a file object; got {}{hint}",
        obj.get_type().name()?
    )))
}

fn wrong(info: &OptionInfo, want: &str, obj: &Bound<'_, PyAny>) -> PyErr {
    let got = obj
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into());
    PyTypeError::new_err(format!("{} must be {want}; got {got}", info.name))
}

/// The value of option `info` from a Python object; `None` leaves an
/// option without a default unset.
fn value(info: &OptionInfo, obj: &Bound<'_, PyAny>) -> PyResult<Option<Value>> {
    let is_int = obj.cast::<PyInt>().is_ok() && obj.cast::<PyBool>().is_err();
    if obj.is_none() {
        return match (info.kind, info.default) {
            (Kind::Size, _) => Ok(Some(Value::Size(None))),
            (_, None) => Ok(None),
            (_, Some(_)) => Err(wrong(info, "given (it has a default)", obj)),
        };
    }
    Ok(Some(match info.kind {
        Kind::Switch if obj.cast::<PyBool>().is_ok() => Value::Bool(obj.extract()?),
        Kind::Switch => return Err(wrong(info, "True or False", obj)),
        Kind::Number if is_int || obj.cast::<PyFloat>().is_ok() => Value::Number(obj.extract()?),
        Kind::Number => return Err(wrong(info, "a number", obj)),
        Kind::Count | Kind::Size if is_int => {
            let n: i128 = obj.extract()?;
            let n = u64::try_from(n).map_err(|_| {
                bad_input(format!("{} must be a whole number ≥ 0; got {n}", info.name))
            })?;
            match info.kind {
                Kind::Size => Value::Size(Some(n)),
                _ => Value::Count(n),
            }
        }
        Kind::Count | Kind::Size => return Err(wrong(info, "a whole number", obj)),
        Kind::Choice if obj.cast::<PyString>().is_ok() => Value::Text(obj.extract()?),
        Kind::Choice => return Err(wrong(info, "text", obj)),
        Kind::Path if is_path_like(obj) => Value::Path(path_of(obj)?),
        Kind::Path if obj.cast::<PyString>().is_ok() => {
            Value::Path(obj.extract::<String>()?.into())
        }
        Kind::Path => return Err(wrong(info, "a path (str or pathlib.Path)", obj)),
        Kind::Input => match input(obj, info.name)? {
            Input::File(p) => Value::Path(p),
            Input::Content { name, bytes } => Value::Content { name, bytes },
        },
        Kind::Text if obj.cast::<PyString>().is_ok() => Value::Text(obj.extract()?),
        Kind::Text => return Err(wrong(info, "text", obj)),
        Kind::Ranges => {
            let r: [[f64; 2]; 3] = obj
                .extract()
                .map_err(|_| wrong(info, "three ranges (lo, hi) for X, Y, Z", obj))?;
            Value::Ranges(r)
        }
        Kind::Triple => {
            let v: Vec<f64> = obj
                .extract()
                .map_err(|_| wrong(info, "three numbers (X, Y, Z)", obj))?;
            let t = <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
                bad_input(format!(
                    "{} must be three numbers (X, Y, Z); got {}",
                    info.name,
                    v.len()
                ))
            })?;
            Value::Triple(t)
        }
    }))
}

/// A request from keyword arguments.
pub fn from_kwargs<R: Request>(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<R> {
    let mut r = R::default();
    let Some(kwargs) = kwargs else {
        return Ok(r);
    };
    for (k, v) in kwargs.iter() {
        let name: String = k.extract()?;
        let Some(info) = R::info(&name) else {
            let e = r.set_named(&name, Value::Bool(false)).unwrap_err();
            return Err(PyTypeError::new_err(e.render(&Keywords)));
        };
        if let Some(value) = value(info, &v)? {
            r.set(info.name, value)
                .map_err(|e| bad_input(e.render(&Keywords)))?;
        }
    }
    Ok(r)
}

/// The Python value of an option's default.
fn default_value<'py>(py: Python<'py>, info: &OptionInfo) -> PyResult<Bound<'py, PyAny>> {
    let Some(text) = info.default else {
        return Ok(match info.kind {
            Kind::Switch => PyBool::new(py, false).to_owned().into_any(),
            _ => py.None().into_bound(py),
        });
    };
    let v = info
        .parse(text)
        .map_err(|e| bad_input(format!("{}: {e}", info.name)))?;
    Ok(match v {
        Value::Bool(b) => PyBool::new(py, b).to_owned().into_any(),
        Value::Number(x) => PyFloat::new(py, x).into_any(),
        Value::Count(n) | Value::Size(Some(n)) => n.into_pyobject(py)?.into_any(),
        Value::Text(t) => PyString::new(py, &t).into_any(),
        _ => py.None().into_bound(py),
    })
}

/// The Python type of an option's value, as the stubs write it.
fn type_name(info: &OptionInfo) -> &'static str {
    let optional = info.default.is_none() || info.kind == Kind::Size;
    match (info.kind, optional) {
        (Kind::Switch, _) => "bool",
        (Kind::Number, false) => "float",
        (Kind::Number, true) => "float | None",
        (Kind::Count, false) => "int",
        (Kind::Count, true) | (Kind::Size, _) => "int | None",
        (Kind::Choice, _) => "str",
        (Kind::Path, _) => "str | os.PathLike[str] | None",
        (Kind::Input, _) => "str | os.PathLike[str] | IO[str] | IO[bytes] | None",
        (Kind::Triple, _) => "Sequence[float] | None",
        (Kind::Text, _) => "str",
        (Kind::Ranges, _) => "Sequence[Sequence[float]] | None",
    }
}

/// The options of a job (`"compensate"`, `"simulate"`, `"moves"`) as
/// dicts: `name`, `default` (a Python value), `type` (as the stubs write
/// it), `help` (said with keywords), `choices`.
#[pyfunction]
#[pyo3(name = "_options")]
pub fn options<'py>(py: Python<'py>, job: &str) -> PyResult<Bound<'py, PyList>> {
    let groups: &[&[OptionInfo]] = match job {
        "compensate" => CompensateRequest::OPTIONS,
        "simulate" => SimulateRequest::OPTIONS,
        "moves" => MachineRequest::OPTIONS,
        "machining_time" => volcomp_core::request::TimeRequest::OPTIONS,
        "mirror" => MirrorRequest::OPTIONS,
        "thermal_fit" => ThermalFitRequest::OPTIONS,
        "thermal_predict" => ThermalPredictRequest::OPTIONS,
        "straightness_fit" => StraightnessFitRequest::OPTIONS,
        "export" => volcomp_core::request::MapExportRequest::OPTIONS,
        "ballbar_predict" => volcomp_core::request::BallbarPredictRequest::OPTIONS,
        "ballbar_fit" => volcomp_core::request::BallbarFitRequest::OPTIONS,
        "probe_fit" => volcomp_core::request::ProbeFitRequest::OPTIONS,
        "probe_plan" => volcomp_core::request::ProbePlanRequest::OPTIONS,
        _ => return Err(bad_input(format!("no job `{job}`"))),
    };
    let list = PyList::empty(py);
    for info in groups.iter().flat_map(|g| g.iter()).filter(|i| !i.hidden) {
        let d = PyDict::new(py);
        d.set_item("name", info.name)?;
        d.set_item("default", default_value(py, info)?)?;
        d.set_item("type", type_name(info))?;
        d.set_item("help", keywords(info.help))?;
        let choices: Vec<&str> = info.choices.iter().map(|(c, _)| *c).collect();
        d.set_item("choices", choices)?;
        list.append(d)?;
    }
    Ok(list)
}
