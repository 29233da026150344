//! The circular test (docs/ballbar.md): `ballbar_predict` and
//! `ballbar_fit`, their results as the CLI's `--json` objects (dicts).

use crate::errors::bad_input;
use crate::inputs::from_json;
use crate::request::{from_kwargs, input, library_error};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::request::{BallbarFitRequest, BallbarPredictRequest, Input};

/// The trace a ballbar records on the machine of `map` (a path), its
/// ISO 230-4 figures and the test's LinuxCNC program: a dict with
/// `figures`, `trace` and `program`.
#[pyfunction]
#[pyo3(signature = (map, **options))]
pub fn ballbar_predict<'py>(
    py: Python<'py>,
    map: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r: BallbarPredictRequest = from_kwargs(options)?;
    let path = match input(map, "map")? {
        Input::File(p) => p,
        Input::Content { .. } => return Err(bad_input("map must be a path (str or pathlib.Path)")),
    };
    let p = r.run(&path).map_err(library_error)?;
    // Through `serde_json::Value`: its objects' keys sorted, as before.
    let value = |v: serde_json::Result<serde_json::Value>| v.map_err(|e| bad_input(e.to_string()));
    let value = serde_json::json!({
        "figures": value(serde_json::to_value(&p.figures))?,
        "trace": value(serde_json::to_value(&p.trace))?,
        "program": p.program,
    });
    from_json(py, &value)
}

/// The ISO 230-4 figures of a trace file (a path or a file object) and the
/// causes fitted to it: a dict with `figures`, `causes` (each `id`,
/// `label`, `unit`, `value`, `std`, `rms_um`, `share_pct`),
/// `residual_rms_um`, `samples`, `residual`.
#[pyfunction]
#[pyo3(signature = (trace, **options))]
pub fn ballbar_fit<'py>(
    py: Python<'py>,
    trace: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r: BallbarFitRequest = from_kwargs(options)?;
    let t = input(trace, "trace")?;
    let text = t.text().map_err(library_error)?;
    let f = r.run(&text, &t.name()).map_err(library_error)?;
    let value = serde_json::to_value(&f).map_err(|e| bad_input(e.to_string()))?;
    from_json(py, &value)
}
