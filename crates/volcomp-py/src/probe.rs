//! Calibration with a touch probe (docs/probing.md): `probe_plan`, the
//! probing program of an artifact and its time on the machine; `probe_fit`,
//! the machine identified from probing logs, as a `Model` and a dict.

use crate::errors::bad_input;
use crate::inputs::from_json;
use crate::model::Model;
use crate::request::{from_kwargs, input, library_error, Keywords};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::identify::probe::request::{FitRequest, Input as Text, PlanRequest};
use volcomp_core::io::LoadedModel;
use volcomp_core::model::setup::MachineSetup;
use volcomp_core::request::probe::{plan_title, FitFigures, PlanFigures};
use volcomp_core::request::{ProbeFitRequest, ProbePlanRequest};

/// Every input (paths or file objects) read whole as text.
fn texts(list: &[Bound<'_, PyAny>], what: &str) -> PyResult<Vec<Text>> {
    list.iter()
        .map(|o| {
            let i = input(o, what)?;
            Ok(Text::new(i.name(), i.text().map_err(library_error)?))
        })
        .collect()
}

/// The probing program of `artifact` (a path or file object), as
/// `volcomp probe plan` writes it, checked by volcomp's interpreter:
/// `setup` (optional) is the set-up file with the work offset and the
/// probe's tool length. Returns `(program, plan)`: the program text and a
/// dict of `touches`, `time_s` (on the machine: probing moves at the chosen
/// feeds, rapids, operator pauses not counted) and `placements` (each
/// `name`, `touches`, `time_s`).
#[pyfunction]
#[pyo3(signature = (artifact, setup = None, **options))]
pub fn probe_plan<'py>(
    py: Python<'py>,
    artifact: Bound<'py, PyAny>,
    setup: Option<Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(String, Bound<'py, PyAny>)> {
    let r: ProbePlanRequest = from_kwargs(options)?;
    let o = r.options().map_err(|e| bad_input(e.render(&Keywords)))?;
    let artifact = texts(&[artifact], "artifact")?.remove(0);
    let setup = match setup {
        Some(s) => {
            let s = texts(&[s], "setup")?.remove(0);
            MachineSetup::from_setup_toml(&s.text, &s.name).map_err(library_error)?
        }
        None => MachineSetup::unset(),
    };
    let request = PlanRequest {
        title: plan_title(&artifact.name),
        artifact,
        setup,
        placement: r.placement.clone(),
        options: o,
    };
    let out = py
        .detach(|| request.run())
        .map_err(|e| library_error(e.into()))?;
    let plan = from_json(py, &PlanFigures::of(&out.plan))?;
    Ok((out.program, plan))
}

/// The machine identified from probing logs (docs/probing.md): `artifacts`
/// and `logs` are lists of paths (or file objects) — every artifact the
/// logs touched, LinuxCNC probe logs or CSV points.
///
/// Returns `(model, report)`: the 21-component model with the axes'
/// reversal (a `Model` of kind "kinematic", the file `volcomp probe fit`
/// writes) and a dict: `params` (each `name`, `unit`, `status`
/// "identified", "not seen" or "not in model", `value`, `std`),
/// `reversal_um` (per axis `{value, std}` or None), `sigma0_um`,
/// `notes`, `warnings`, `held_out` (with leave_one_out=True), `summary`
/// (the lines the CLI prints).
#[pyfunction]
#[pyo3(signature = (artifacts, logs, **options))]
pub fn probe_fit<'py>(
    py: Python<'py>,
    artifacts: Vec<Bound<'py, PyAny>>,
    logs: Vec<Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Model, Bound<'py, PyAny>)> {
    let r: ProbeFitRequest = from_kwargs(options)?;
    let o = r
        .identify
        .options()
        .map_err(|e| bad_input(e.render(&Keywords)))?;
    let ranges = o.ranges_mm;
    let request = FitRequest {
        artifacts: texts(&artifacts, "artifacts")?,
        logs: texts(&logs, "logs")?,
        options: o,
        leave_one_out: r.leave_one_out,
        monte_carlo: r.monte_carlo as usize,
    };
    let out = py
        .detach(|| request.run())
        .map_err(|e| library_error(e.into()))?;
    let report = from_json(py, &FitFigures::of(&out, ranges))?;
    let model = Model {
        loaded: LoadedModel::Kinematic(Box::new(out.model)),
        path: None,
    };
    Ok((model, report))
}
