//! Programs: `compensate`, `simulate` and `moves`, with the options of the
//! library's requests (`volcomp_core::request`; the same as the CLI's
//! commands of the same names, docs/compensation.md, docs/design.md).

use crate::errors::{bad_input, to_py};
use crate::inputs::{fields, warn, warn_without_work_offset};
use crate::model::Model;
use crate::request::{from_kwargs, input, keywords, library_error, Keywords};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use volcomp_core::io::provenance::now_utc;
use volcomp_core::plan::TimeComparison;
use volcomp_core::report::columns;
use volcomp_core::request::{
    CompensateRequest, Input, Machine, MachineRequest, ModelSource, SimulateRequest, TimeRequest,
};
use volcomp_core::Error;
use volcomp_gcode::Warning;

/// The library's error; a point outside the model gets the help that
/// names the set-up and the work offset (docs/errors.md).
fn explain(e: Error, m: &Machine) -> PyErr {
    let text = m.explain(&e).map(|t| keywords(&t));
    let err = library_error(e);
    if let Some(text) = text {
        Python::attach(|py| {
            let v = err.value(py);
            let _ = v.setattr("message", text.clone());
            let _ = v.setattr("args", (text,));
        });
    }
    err
}

fn warnings_list<'py>(py: Python<'py>, file: &str, ws: &[Warning]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for w in ws {
        let d = PyDict::new(py);
        d.set_item("file", file)?;
        d.set_item("line", w.line)?;
        d.set_item("column", w.column)?;
        d.set_item("message", &w.message)?;
        list.append(d)?;
    }
    Ok(list)
}

/// A program: its bytes and the name messages give it (`name` overrides).
fn program_bytes(obj: &Bound<'_, PyAny>, name: Option<&str>) -> PyResult<(Vec<u8>, String)> {
    let inp = input(obj, "program")?;
    let shown = name.map(str::to_string).unwrap_or_else(|| inp.name());
    let bytes = match inp {
        Input::File(p) => {
            volcomp_core::io::inputs::read(&p, "the program").map_err(|e| to_py(Error::io(p, e)))?
        }
        Input::Content { bytes, .. } => bytes,
    };
    Ok((bytes, shown))
}

/// The attributes `names` (separated by spaces) of `obj` as a dict.
fn attributes<'py, T>(obj: &Bound<'py, T>, names: &str) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(obj.py());
    for name in names.split_whitespace() {
        d.set_item(name, obj.as_any().getattr(name)?)?;
    }
    Ok(d)
}

/// What `compensate` did: the compensated program and its summary.
#[pyclass(module = "volcomp", frozen, get_all)]
pub struct CompensateResult {
    /// The compensated program (bytes; `text` decodes it).
    pub data: Py<PyBytes>,
    /// Lines read.
    pub lines_in: u64,
    /// Lines written.
    pub lines_out: u64,
    /// Target points compensated.
    pub points: u64,
    /// Largest model residual (µm).
    pub max_residual_um: f64,
    /// Largest correction |q − t| (µm).
    pub max_correction_um: f64,
    /// Take-up moves written.
    pub take_ups: u64,
    /// Take-ups folded into the move that reverses (no block written).
    pub take_ups_folded: u64,
    /// The largest excursion from the path a folded take-up leaves (µm).
    pub max_fold_excursion_um: f64,
    /// `(line, axis)` where an axis was held (first 100).
    pub held: Vec<(u64, char)>,
    /// Total number of holds.
    pub held_count: u64,
    /// Feed moves written without compensation because an axis was never
    /// set (with `allow_uncompensated_axes=True`; else the program is
    /// refused).
    pub uncompensated_moves: u64,
    /// What was not compensated and what to do, or None.
    pub uncompensated: Option<String>,
    /// What the interpreter assumed: dicts with `file`, `line`, `column`, `message`.
    pub warnings: Py<PyList>,
    /// Per-point records (dict of arrays) when asked for with `points=True`, else None.
    pub point_records: Option<Py<PyDict>>,
    /// Machining time of the original and the compensated program on the
    /// planner model (docs/planner.md): the keys of `volcomp time --json`
    /// (`program`, `original`, `limits`, `limits_from_setup`).
    pub machining_time: Py<PyDict>,
}

#[pymethods]
impl CompensateResult {
    /// The compensated program as text (UTF-8).
    #[getter]
    fn text(&self, py: Python<'_>) -> PyResult<String> {
        String::from_utf8(self.data.bind(py).as_bytes().to_vec()).map_err(|_| {
            bad_input(
                "the compensated program is not UTF-8 text (nor was the input); read .data (bytes)",
            )
        })
    }

    /// The summary as a dict (without the program).
    fn summary<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyDict>> {
        attributes(
            slf,
            "lines_in lines_out points max_residual_um max_correction_um take_ups \
             take_ups_folded max_fold_excursion_um held held_count \
             uncompensated_moves uncompensated warnings machining_time",
        )
    }

    fn __repr__(&self) -> String {
        format!(
            "CompensateResult(lines_in={}, lines_out={}, points={}, max_correction_um={:.3}, max_residual_um={:.4}, take_ups={}, held_count={})",
            self.lines_in, self.lines_out, self.points, self.max_correction_um, self.max_residual_um, self.take_ups, self.held_count
        )
    }
}

/// Compensates a part program for `model`'s errors (docs/compensation.md)
/// and returns the program and what was done.
///
/// `program`: a path (str or pathlib.Path) or a file object
/// (`io.StringIO(text)`); `name` names it in messages.
/// `point_records=True` adds the per-point records; `date_utc` dates the
/// header (default: now, or SOURCE_DATE_EPOCH). The options (the machine,
/// the method, the splitting, the limits, the output) are those of the
/// CLI's `compensate`: see `help(volcomp.compensate)`.
#[pyfunction]
#[pyo3(signature = (program, model, *, point_records = false, name = None, date_utc = None, **options))]
pub fn compensate(
    py: Python<'_>,
    program: &Bound<'_, PyAny>,
    model: &Bound<'_, Model>,
    point_records: bool,
    name: Option<&str>,
    date_utc: Option<String>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<CompensateResult> {
    let request: CompensateRequest = from_kwargs(options)?;
    let machine = request.machine.machine().map_err(library_error)?;
    warn_without_work_offset(py, &machine)?;
    let model = model.get();
    let source = match &model.path {
        Some(p) => ModelSource::File(p),
        None => ModelSource::Built(&model.loaded),
    };
    let job = request
        .prepare(machine, source, date_utc.unwrap_or_else(now_utc), &Keywords)
        .map_err(library_error)?;
    let (bytes, file) = program_bytes(program, name)?;
    let run = py
        .detach(|| {
            job.run_in_memory(model.model(), (&bytes, &file), point_records)
                .map_err(Box::new)
        })
        .map_err(|e| explain(*e, &job.machine))?;
    let (summary, records) = (run.summary, run.points);
    let point_records = match point_records {
        true => Some(fields(py, &columns::points(&records))?.unbind()),
        false => None,
    };
    Ok(CompensateResult {
        data: PyBytes::new(py, &run.program).unbind(),
        lines_in: summary.lines_in,
        lines_out: summary.lines_out,
        points: summary.points,
        max_residual_um: summary.max_residual_um,
        max_correction_um: summary.max_correction_um,
        take_ups: summary.take_ups,
        take_ups_folded: summary.take_ups_folded,
        max_fold_excursion_um: summary.max_fold_excursion_um,
        uncompensated_moves: summary.uncompensated_moves,
        uncompensated: volcomp_core::report::compensation::uncompensated_warning(&summary)
            .map(|w| crate::request::keywords(&w)),
        held: summary.held,
        held_count: summary.held_count,
        warnings: warnings_list(py, &file, &run.warnings)?.unbind(),
        point_records,
        machining_time: time_dict(py, &run.time)?,
    })
}

/// A machining time as the dict of `volcomp time --json`.
fn time_dict(py: Python<'_>, t: &TimeComparison) -> PyResult<Py<PyDict>> {
    Ok(crate::inputs::from_json(py, t)?
        .cast_into::<PyDict>()?
        .unbind())
}

/// The machining time of a program on a model of LinuxCNC 2.9's
/// trajectory planner (docs/planner.md), with the machine's limits from
/// the set-up's `[limits]`: a dict with `program` (its estimate: `motion`
/// with `total_s`, `cutting_s`, `rapid_s`, …; `dwell_s`), `original` (the
/// same for `reference`, or None), `limits` and `limits_from_setup`, the
/// keys of `volcomp time --json`.
///
/// `program`: a path or a file object, as in `compensate`; `name` names
/// it in messages. The options (the machine, `reference`) are those of the
/// CLI's `time`: see `help(volcomp.machining_time)`.
#[pyfunction]
#[pyo3(signature = (program, *, name = None, **options))]
pub fn machining_time(
    py: Python<'_>,
    program: &Bound<'_, PyAny>,
    name: Option<&str>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Py<PyDict>> {
    let request: TimeRequest = from_kwargs(options)?;
    let machine = request.machine.machine().map_err(library_error)?;
    let (bytes, file) = program_bytes(program, name)?;
    let t = py
        .detach(|| {
            request
                .run(&machine, bytes.as_slice(), &file)
                .map_err(Box::new)
        })
        .map_err(|e| explain(*e, &machine))?;
    time_dict(py, &t)
}

/// The metrics of a simulated program (docs/design.md, "Simulation and
/// metrics"), and on request its measured feed commands as arrays.
#[pyclass(module = "volcomp", frozen, get_all)]
pub struct SimulationResult {
    /// RMS point error (µm).
    pub point_rms_um: f64,
    /// Largest point error (µm).
    pub point_max_um: f64,
    /// RMS contour error over the path length (µm).
    pub contour_rms_um: f64,
    /// Largest contour error (µm).
    pub contour_max_um: f64,
    /// Program lines that produced motions.
    pub blocks: u64,
    /// Points measured (ends of nominal feed moves).
    pub points: u64,
    /// Dense samples measured (≤ 0.05 mm apart).
    pub samples: u64,
    /// Length of the measured feed path (mm).
    pub feed_length_mm: f64,
    /// `"program"` or `"reference"`: where the nominal path comes from.
    pub nominal: String,
    /// How the point error is defined.
    pub point_definition: String,
    /// How the contour error is defined.
    pub contour_definition: String,
    /// What the interpreter assumed: dicts with `file`, `line`, `column`, `message`.
    pub warnings: Py<PyList>,
    /// With `segments=True`, one row per measured feed command: `line`,
    /// `nominal_line`, `command_mm` (N, 3), `actual_mm` (N, 3, the simulated
    /// tool position at its end), `target_mm` (N, 3, the nominal end point
    /// where the command ends a nominal feed move, else NaN), `point_um`
    /// (NaN where none), `contour_max_um`; else None.
    pub segments: Option<Py<PyDict>>,
    /// Machining time of the program (and of `reference`) on the planner
    /// model: the keys of `volcomp time --json`.
    pub machining_time: Py<PyDict>,
}

#[pymethods]
impl SimulationResult {
    /// The metrics as a dict (the CLI's `simulate --json` keys).
    fn as_dict<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyDict>> {
        attributes(
            slf,
            "point_rms_um point_max_um contour_rms_um contour_max_um blocks points \
             samples feed_length_mm nominal point_definition contour_definition \
             machining_time",
        )
    }

    fn __repr__(&self) -> String {
        format!(
            "SimulationResult(point_rms_um={:.4}, point_max_um={:.4}, contour_rms_um={:.4}, contour_max_um={:.4}, points={}, nominal={:?})",
            self.point_rms_um, self.point_max_um, self.contour_rms_um, self.contour_max_um, self.points, self.nominal
        )
    }
}

/// Simulates a program on a machine with `model`'s errors and measures it
/// against its nominal path: `reference` (the original of a program
/// compensated by volcomp) when given, else the program itself.
///
/// `program`: a path or a file object, as in `compensate`; `name` names
/// it in messages. `segments=True` adds the per-command arrays. The
/// options (the machine, `reference`, `chord_tolerance_mm`) are those of
/// the CLI's `simulate`: see `help(volcomp.simulate)`.
#[pyfunction]
#[pyo3(signature = (program, model, *, segments = false, name = None, **options))]
pub fn simulate(
    py: Python<'_>,
    program: &Bound<'_, PyAny>,
    model: &Bound<'_, Model>,
    segments: bool,
    name: Option<&str>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<SimulationResult> {
    let request: SimulateRequest = from_kwargs(options)?;
    let machine = request.machine.machine().map_err(library_error)?;
    let machine = request
        .prepare(machine)
        .map_err(|e| library_error(e.into()))?;
    warn_without_work_offset(py, &machine)?;
    let (bytes, file) = program_bytes(program, name)?;
    let model = model.get().model();
    let run = py
        .detach(|| {
            request
                .run_in_memory(model, &machine, (&bytes, &file), segments)
                .map_err(Box::new)
        })
        .map_err(|e| explain(*e, &machine))?;
    let report = run.report;
    let segments = match segments {
        true => Some(fields(py, &columns::segments(&run.segments))?.unbind()),
        false => None,
    };
    Ok(SimulationResult {
        point_rms_um: report.point_rms_um,
        point_max_um: report.point_max_um,
        contour_rms_um: report.contour_rms_um,
        contour_max_um: report.contour_max_um,
        blocks: report.blocks,
        points: report.points,
        samples: report.samples,
        feed_length_mm: report.feed_length_mm,
        nominal: report.nominal.to_string(),
        point_definition: report.point_definition.to_string(),
        contour_definition: report.contour_definition.to_string(),
        warnings: warnings_list(py, &file, &run.warnings)?.unbind(),
        segments,
        machining_time: time_dict(py, &run.time)?,
    })
}

/// What the interpreter understood: one row per motion, in machine
/// coordinates (mm), as a dict of 1-D columns (`pandas.DataFrame(...)`
/// takes it as is), the columns of the CLI's `volcomp moves` CSV: `line`,
/// `column`, `kind` (`rapid`, `feed`, `arc`), `source` (`program`, `g53`,
/// `reference`, `cycle`, `spline`), `x_mm`, `y_mm`, `z_mm` (end point),
/// `cx_mm`, `cy_mm`, `cz_mm` (arc centre; NaN for lines), and with
/// `extra_axes=True` `a_deg`, `b_deg`, `c_deg`, `u_mm`, `v_mm`, `w_mm`.
/// Interpreter warnings are issued as `VolcompWarning`.
#[pyfunction]
#[pyo3(signature = (program, *, extra_axes = false, name = None, **options))]
pub fn moves<'py>(
    py: Python<'py>,
    program: &Bound<'py, PyAny>,
    extra_axes: bool,
    name: Option<&str>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let request: MachineRequest = from_kwargs(options)?;
    let m = request.machine().map_err(library_error)?;
    let (bytes, file) = program_bytes(program, name)?;
    let (result, warnings) = py.detach(|| columns::motions(&m.setup, &bytes, &file, extra_axes));
    for w in &warnings {
        warn(py, &format!("{file}:{w}"))?;
    }
    fields(py, &result.map_err(|e| to_py(Error::Gcode(e)))?)
}
