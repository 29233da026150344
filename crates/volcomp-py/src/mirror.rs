//! Free-form surfaces: mirror compensation of a ball-end finishing program
//! from on-machine probing (docs/mirror.md, [Mirror study]), with the
//! options of the library's mirror request (the CLI's `surface mirror`).

use crate::errors::bad_input;
use crate::inputs::warn;
use crate::request::{from_kwargs, input, keywords, library_error, Keywords};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::io::provenance::now_utc;
use volcomp_core::request::{Input, MirrorRequest, Value};
use volcomp_core::surface::mirror::report::summary_json;

/// Mirror compensation (docs/mirror.md): the deviation field of the
/// semi-finished surface from `measured` probe points against the
/// `nominal` surface, and, with `finishing` and `tool_radius_mm`, the
/// finishing program compensated for it.
///
/// `nominal`, `measured` (and `finishing`): paths (str or pathlib.Path) or
/// file objects; a nominal given as a file object needs `nominal_format`.
/// The options are those of the CLI's `surface mirror` (help(volcomp.mirror)
/// lists them); `date_utc` dates the finishing program's header (default:
/// now, or SOURCE_DATE_EPOCH).
///
/// Returns a dict: `summary` (the CLI's `--json` object: statistics
/// before and predicted after, the fit, the finishing run), `program` (the
/// compensated finishing program's text, or None), `surface_grid_csv` and
/// `surface_bspline_toml` (the compensated surface's files' text),
/// `predicted_worse` (the leave-one-out prediction says compensating is
/// worse than not).
#[pyfunction]
#[pyo3(signature = (nominal, measured, *, date_utc = None, **options))]
pub fn mirror<'py>(
    py: Python<'py>,
    nominal: &Bound<'py, PyAny>,
    measured: &Bound<'py, PyAny>,
    date_utc: Option<String>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut request: MirrorRequest = from_kwargs(options)?;
    for (name, obj) in [("nominal", nominal), ("measured", measured)] {
        let value = match input(obj, name)? {
            Input::File(p) => Value::Path(p),
            Input::Content { name, bytes } => Value::Content { name, bytes },
        };
        volcomp_core::request::Request::set(&mut request, name, value)
            .map_err(|e| bad_input(e.render(&Keywords)))?;
    }
    let plan = request.plan().map_err(|e| library_error(e.into()))?;
    let run = py
        .detach(|| request.run(&plan).map_err(Box::new))
        .map_err(|e| library_error(*e))?;
    if let Some(w) = &run.worse {
        warn(py, &keywords(w))?;
    }
    let date = || date_utc.unwrap_or_else(now_utc);
    let out = py
        .detach(|| {
            request
                .outputs(&plan, &run, date, &Keywords)
                .map_err(Box::new)
        })
        .map_err(|e| library_error(*e))?;
    let (program, finishing_json) = match out.finishing {
        Some((p, json)) => (Some(String::from_utf8_lossy(&p).into_owned()), Some(json)),
        None => (None, None),
    };
    let summary = summary_json(
        &run.inputs,
        &run.result,
        Some(&out.surface),
        finishing_json,
        None,
        false,
    );
    let d = PyDict::new(py);
    d.set_item("summary", crate::inputs::from_json(py, &summary)?)?;
    d.set_item("program", program)?;
    d.set_item("surface_grid_csv", out.text.grid_csv)?;
    d.set_item("surface_bspline_toml", out.text.bspline_toml)?;
    d.set_item("predicted_worse", run.result.compensation_predicted_worse())?;
    Ok(d)
}
