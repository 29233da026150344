//! Calibration with a touch probe (docs/probing.md): `probe_plan`, the
//! probing program of an artifact and its time on the machine; `probe_fit`,
//! the machine identified from probing logs, as a `Model` and a dict.

use crate::errors::bad_input;
use crate::model::Model;
use crate::request::{from_kwargs, input, library_error, Keywords};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use volcomp_core::identify::probe::fit::Estimate;
use volcomp_core::identify::probe::identify::Status;
use volcomp_core::identify::probe::request::{FitRequest, Input as Text, PlanRequest};
use volcomp_core::io::LoadedModel;
use volcomp_core::model::setup::MachineSetup;
use volcomp_core::request::{ProbeFitRequest, ProbePlanRequest};

/// Every input (paths or file objects) read whole as text.
fn texts(list: &[Bound<'_, PyAny>], what: &str) -> PyResult<Vec<Text>> {
    list.iter()
        .map(|o| {
            let i = input(o, what)?;
            let name = i.name();
            let bytes = i.bytes().map_err(library_error)?;
            let text = volcomp_core::io::table::utf8(&bytes, &name)
                .map_err(|e| library_error(e.into()))?;
            Ok(Text::new(name, text))
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
) -> PyResult<(String, Bound<'py, PyDict>)> {
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
        title: format!(
            "volcomp {} probe plan {}",
            env!("CARGO_PKG_VERSION"),
            artifact.name
        ),
        artifact,
        setup,
        placement: r.placement.clone(),
        options: o,
    };
    let out = py
        .detach(|| request.run())
        .map_err(|e| library_error(e.into()))?;
    let placements = PyList::empty(py);
    for (name, t) in &out.plan.placement_time_s {
        let d = PyDict::new(py);
        d.set_item("name", name)?;
        let n = out.plan.touches.iter().filter(|x| &x.placement == name);
        d.set_item("touches", n.count())?;
        d.set_item("time_s", t)?;
        placements.append(d)?;
    }
    let plan = PyDict::new(py);
    plan.set_item("touches", out.plan.touches.len())?;
    plan.set_item("time_s", out.plan.time_s)?;
    plan.set_item("placements", placements)?;
    Ok((out.program, plan))
}

fn estimate<'py>(py: Python<'py>, e: &Estimate) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("value", e.value)?;
    d.set_item("std", e.sigma)?;
    Ok(d)
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
) -> PyResult<(Model, Bound<'py, PyDict>)> {
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
    let params = PyList::empty(py);
    for p in &out.identified.params {
        let d = PyDict::new(py);
        d.set_item("name", &p.name)?;
        d.set_item("unit", p.unit)?;
        let (status, e) = match p.status {
            Status::Identified(e) => ("identified", Some(e)),
            Status::NotSeen => ("not seen", None),
            Status::NotInModel => ("not in model", None),
        };
        d.set_item("status", status)?;
        d.set_item("value", e.map(|e| e.value))?;
        d.set_item("std", e.map(|e| e.sigma))?;
        params.append(d)?;
    }
    let reversal = PyList::empty(py);
    for e in &out.reversal_um {
        match e {
            Some(e) => reversal.append(estimate(py, e)?)?,
            None => reversal.append(py.None())?,
        }
    }
    let held_out = PyList::empty(py);
    for h in &out.held_out {
        let d = PyDict::new(py);
        d.set_item("artifact", &h.artifact)?;
        d.set_item("placement", &h.placement)?;
        d.set_item("before_um", h.before_um)?;
        d.set_item("after_um", h.after_um)?;
        held_out.append(d)?;
    }
    let report = PyDict::new(py);
    report.set_item("params", params)?;
    report.set_item("reversal_um", reversal)?;
    report.set_item("sigma0_um", out.identified.ident.sigma0_um)?;
    report.set_item("notes", &out.identified.notes)?;
    report.set_item("warnings", &out.fitted.warnings)?;
    report.set_item("held_out", held_out)?;
    report.set_item("summary", out.summary(ranges))?;
    let model = Model {
        loaded: LoadedModel::Kinematic(Box::new(out.model)),
        path: None,
    };
    Ok((model, report))
}
