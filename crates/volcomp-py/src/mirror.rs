//! Free-form surfaces: mirror compensation of a ball-end finishing program
//! from on-machine probing (docs/mirror.md, [Mirror study]), with the
//! options of the library's mirror request (the CLI's `surface mirror`).

use crate::errors::bad_input;
use crate::inputs::warn;
use crate::request::{from_kwargs, input, keywords, library_error, Keywords};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::io::provenance::now_utc;
use volcomp_core::request::{Input, MirrorPlan, MirrorRequest, MirrorRun, Value};
use volcomp_core::surface::mirror::report::{
    compensated_surface_text, summary_json, FinishingJson, SurfaceFiles,
};
use volcomp_core::surface::mirror::BallTool;
use volcomp_core::surface::mirror::CompensatedSurface;

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
    let comp = CompensatedSurface {
        nominal: &run.nominal,
        field: &run.result.field,
    };
    let text = compensated_surface_text(&run.inputs, &comp, plan.grid_size)
        .map_err(|e| library_error(e.into()))?;
    let surface = SurfaceFiles {
        grid: "<surface_grid_csv>".into(),
        grid_nodes: text.grid_nodes,
        bspline: "<surface_bspline_toml>".into(),
        bspline_net: text.bspline_net,
        bspline_error_um: text.bspline_error_um,
    };
    let (program, finishing_json) = match (&request.finishing, &plan.tool) {
        (Some(f), Some(tool)) => {
            let (program, json) = finishing(py, &request, &plan, &run, (f, tool), date_utc)?;
            (Some(program), Some(json))
        }
        _ => (None, None),
    };
    let summary = summary_json(
        &run.inputs,
        &run.result,
        Some(&surface),
        finishing_json,
        None,
        false,
    );
    let json = serde_json::to_string(&summary).map_err(|e| bad_input(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item(
        "summary",
        py.import("json")?.call_method1("loads", (json,))?,
    )?;
    d.set_item("program", program)?;
    d.set_item("surface_grid_csv", text.grid_csv)?;
    d.set_item("surface_bspline_toml", text.bspline_toml)?;
    d.set_item("predicted_worse", run.result.compensation_predicted_worse())?;
    Ok(d)
}

/// The compensated finishing program's text and its summary.
fn finishing(
    py: Python<'_>,
    request: &MirrorRequest,
    plan: &MirrorPlan,
    run: &MirrorRun,
    (f, tool): (&Input, &BallTool),
    date_utc: Option<String>,
) -> PyResult<(String, FinishingJson)> {
    let machine = request.machine.machine().map_err(library_error)?;
    let file = f.name();
    let bytes = f.bytes().map_err(library_error)?;
    let frame = request
        .finishing_frame(&machine, bytes.as_ref(), &file)
        .map_err(library_error)?;
    let date = date_utc.unwrap_or_else(now_utc);
    let header = request
        .finishing_header(plan, tool, &machine, false, date, &Keywords)
        .map_err(library_error)?;
    let mut out = Vec::new();
    let summary = py
        .detach(|| {
            request
                .compensate_finishing(
                    plan,
                    run,
                    &run.result.field,
                    &machine,
                    frame,
                    (bytes.as_ref(), &file),
                    &header,
                    &mut out,
                )
                .map_err(Box::new)
        })
        .map_err(|e| library_error(*e))?;
    Ok((
        String::from_utf8_lossy(&out).into_owned(),
        FinishingJson::new("<program>", &summary),
    ))
}
