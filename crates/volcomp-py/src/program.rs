//! Programs: `compensate`, `simulate` and `moves`, with the options of the
//! CLI's commands of the same names (docs/compensation.md, docs/design.md).

use crate::errors::{bad_input, to_py, IntoPy};
use crate::inputs::{machine, source, warn, warn_without_work_offset, Machine, MachineArgs};
use crate::model::Model;
use numpy::ndarray::Array2;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use volcomp_core::compensate::solve::Method;
use volcomp_core::compensate::{
    file_name, header_for_map, CompensateOptions, Compensator, DirectionPolicy, PointRecord,
    Segmentation,
};
use volcomp_core::error::CompensationError;
use volcomp_core::io::provenance::{iso8601_utc, sha256_hex, ProgramHeader};
use volcomp_core::io::LoadedModel;
use volcomp_core::limits::LimitedWriter;
use volcomp_core::simulate::report::SegmentError;
use volcomp_core::{Error, Simulation};
use volcomp_gcode::{MotionKind, Vec3, Warning};

/// Default largest output of `compensate` (bytes): the CLI's default of
/// `--max-output-size`, 256 MiB.
const DEFAULT_MAX_OUTPUT_BYTES: u64 = 256 << 20;

/// The library's error, with the note the CLI adds when a point falls
/// outside the model and no work offset was given (docs/errors.md).
fn explain(e: Error, m: &Machine) -> PyErr {
    let note = m.setup.no_work_offset
        && matches!(&e, Error::Compensation(CompensationError::Model { .. }));
    let text = note.then(|| {
        format!(
            "no work offset was given (G54 = 0): {e}\n  help: give the program's work offsets with setup= or work_offset_mm= first; Model.load(..., clamp=True) holds the error at the table ends"
        )
    });
    let err = to_py(e);
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

fn rows3(py: Python<'_>, v: Vec<f64>) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let n = v.len() / 3;
    Ok(Array2::from_shape_vec((n, 3), v)
        .map_err(|e| bad_input(e.to_string()))?
        .into_pyarray(py))
}

/// Now as ISO 8601 UTC, or `SOURCE_DATE_EPOCH` when set (the
/// reproducible-builds convention, as the CLI does).
fn date_now_utc() -> String {
    let secs = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs() as i64)
                .unwrap_or(0)
        });
    iso8601_utc(secs)
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
    /// `(line, axis)` where an axis was held (first 100).
    pub held: Vec<(u64, char)>,
    /// Total number of holds.
    pub held_count: u64,
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
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("lines_in", self.lines_in)?;
        d.set_item("lines_out", self.lines_out)?;
        d.set_item("points", self.points)?;
        d.set_item("max_residual_um", self.max_residual_um)?;
        d.set_item("max_correction_um", self.max_correction_um)?;
        d.set_item("take_ups", self.take_ups)?;
        d.set_item("take_ups_folded", self.take_ups_folded)?;
        d.set_item("held", self.held.clone())?;
        d.set_item("held_count", self.held_count)?;
        d.set_item("warnings", self.warnings.clone_ref(py))?;
        d.set_item("machining_time", self.machining_time.clone_ref(py))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "CompensateResult(lines_in={}, lines_out={}, points={}, max_correction_um={:.3}, max_residual_um={:.4}, take_ups={}, held_count={})",
            self.lines_in, self.lines_out, self.points, self.max_correction_um, self.max_residual_um, self.take_ups, self.held_count
        )
    }
}

/// The compensation options from the arguments, validated as the CLI
/// validates its flags.
#[allow(clippy::too_many_arguments)]
fn options(
    method: &str,
    gain: f64,
    max_iterations: u32,
    segment_length_mm: Option<f64>,
    segments: Option<u32>,
    no_split: bool,
    contour_tolerance_um: Option<f64>,
    min_segment_length_mm: f64,
    max_residual_um: f64,
    chord_tolerance_mm: f64,
    decimals: Option<u8>,
    max_correction_mm: f64,
    nominal_directions: bool,
    take_up: bool,
    separate_take_ups: bool,
    take_up_tolerance_um: Option<f64>,
    trace: bool,
    arcs_as_lines: bool,
) -> PyResult<CompensateOptions> {
    if let Some(t) = take_up_tolerance_um {
        if !(t.is_finite() && t > 0.0) {
            return Err(bad_input(format!(
                "take_up_tolerance_um must be a positive number of µm; got {t}"
            )));
        }
    }
    if separate_take_ups && !take_up {
        return Err(bad_input(
            "separate_take_ups=True needs take_up=True (there are no take-ups to write)",
        ));
    }
    let method = match method {
        "exact" => Method::Exact,
        "direct" => Method::Direct,
        "pitch" => Method::Pitch,
        "ilc" => {
            if !(gain > 0.0 && gain <= 1.0) {
                return Err(bad_input(format!(
                    "gain must satisfy 0 < γ ≤ 1; got {gain}"
                )));
            }
            if max_iterations == 0 {
                return Err(bad_input(
                    "max_iterations must be at least 1 (ILC needs one step to move any point)",
                ));
            }
            Method::Ilc {
                gain,
                max_iterations,
            }
        }
        m => {
            return Err(bad_input(format!(
                "method must be \"exact\", \"ilc\", \"direct\" or \"pitch\"; got {m:?}"
            )))
        }
    };
    let given = [
        no_split,
        segments.is_some(),
        segment_length_mm.is_some(),
        contour_tolerance_um.is_some(),
    ];
    if given.iter().filter(|g| **g).count() > 1 {
        return Err(bad_input(
            "give at most one of no_split, segments, segment_length_mm and contour_tolerance_um",
        ));
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let segmentation = if no_split {
        Segmentation::Off
    } else if let Some(n) = segments {
        if n == 0 {
            return Err(bad_input("segments must be at least 1"));
        }
        Segmentation::Count(n)
    } else if let Some(l) = segment_length_mm {
        if !positive(l) {
            return Err(bad_input(format!(
                "segment_length_mm must be a positive length in mm; got {l}"
            )));
        }
        Segmentation::MaxLength(l)
    } else {
        let t =
            contour_tolerance_um.unwrap_or(volcomp_core::compensate::DEFAULT_CONTOUR_TOLERANCE_UM);
        if !(positive(t) && positive(min_segment_length_mm)) {
            return Err(bad_input(
                "contour_tolerance_um and min_segment_length_mm must be positive",
            ));
        }
        Segmentation::Adaptive {
            tolerance_mm: t * 1e-3,
            min_length_mm: min_segment_length_mm,
        }
    };
    if !positive(max_correction_mm) {
        return Err(bad_input(format!(
            "max_correction_mm must be a positive length in mm; got {max_correction_mm}"
        )));
    }
    if !positive(max_residual_um) {
        return Err(bad_input(format!(
            "max_residual_um must be a positive number of µm; got {max_residual_um}"
        )));
    }
    if decimals.is_some_and(|d| !(1..=9).contains(&d)) {
        return Err(bad_input("decimals must be 1 … 9"));
    }
    Ok(CompensateOptions {
        method,
        segmentation,
        chord_tolerance_mm,
        arcs_as_arcs: !arcs_as_lines,
        decimals,
        max_correction_mm,
        directions: if nominal_directions {
            DirectionPolicy::Nominal
        } else {
            DirectionPolicy::Commanded
        },
        take_up,
        fold_take_ups: !separate_take_ups,
        take_up_tolerance_mm: take_up_tolerance_um.map(|t| t * 1e-3),
        trace_comments: trace,
        // Direct and pitch do not aim at the full model's target: their
        // residual is the method's own error, checked for finiteness only.
        max_residual_um: matches!(method, Method::Exact | Method::Ilc { .. })
            .then_some(max_residual_um),
    })
}

/// The provenance header: the model's file (and the tables it names) with
/// their SHA-256, or, for a model built in memory, that of its file text
/// (the axis tables' CSV, the straightness model's TOML, the 21-component
/// model's TOML and table CSV).
fn header(
    model: &Model,
    m: &Machine,
    opts: &CompensateOptions,
    date_utc: String,
) -> PyResult<ProgramHeader> {
    let mut h = match (&model.path, &model.loaded) {
        (Some(p), _) => {
            header_for_map(p, m.setup_file.as_deref(), &m.setup.setup, opts, date_utc).py_err()?
        }
        (None, LoadedModel::AxisTables(t)) => ProgramHeader::for_compensation(
            vec![("arrays".into(), sha256_hex(t.to_csv().as_bytes()))],
            m.setup_file.as_deref().map(file_name),
            m.setup.setup.clone(),
            opts,
            date_utc,
        ),
        (None, LoadedModel::Straightness(t)) => ProgramHeader::for_compensation(
            vec![("arrays".into(), sha256_hex(t.to_toml().as_bytes()))],
            m.setup_file.as_deref().map(file_name),
            m.setup.setup.clone(),
            opts,
            date_utc,
        ),
        (None, LoadedModel::Kinematic(k)) => {
            let csv = volcomp_core::io::model_file::components_to_csv(&k.axes);
            let toml = volcomp_core::io::model_file::model_to_toml(k, "arrays.csv", None);
            ProgramHeader::for_compensation(
                vec![(
                    "arrays".into(),
                    sha256_hex(format!("{toml}{csv}").as_bytes()),
                )],
                m.setup_file.as_deref().map(file_name),
                m.setup.setup.clone(),
                opts,
                date_utc,
            )
        }
    };
    if m.work_offset_given {
        h.work_offset_note = Some("G54 from work_offset_mm".into());
    }
    Ok(h)
}

/// Compensates a part program for `model`'s errors (docs/compensation.md)
/// and returns the program and what was done.
///
/// `program`: its text (str or bytes) or a file (pathlib.Path). The machine:
/// `setup` (a set-up TOML file as pathlib.Path, or its text), or
/// `work_offset_mm` (G54 in machine coordinates), `absolute_arc_centers`,
/// `accept_k0`, `allow_no_program_end`. The method: `"exact"` (default),
/// `"ilc"` (with `gain`, `max_iterations`), `"direct"`, `"pitch"`.
/// Splitting: adaptive within `contour_tolerance_um` (default 0.1 µm, with
/// `min_segment_length_mm`), or `segment_length_mm`, `segments`,
/// `no_split`; arcs are written as arcs unless `arcs_as_lines`.
/// Limits: `max_residual_um`, `max_correction_mm`, `max_output_bytes`
/// (None: no limit). Output: `decimals`, `trace` (the `(volcomp Ln)`
/// comments), `take_up` (backlash take-up moves; `separate_take_ups`
/// writes each as a block of its own instead of folding into the move
/// those it can; `take_up_tolerance_um` lets a fold leave more than the
/// contour tolerance), `nominal_directions`.
/// `points=True` adds the per-point records. `date_utc` dates the header
/// (default: now, or SOURCE_DATE_EPOCH).
#[pyfunction]
#[pyo3(signature = (program, model, *, setup = None, work_offset_mm = None, absolute_arc_centers = false, accept_k0 = false, allow_no_program_end = false, method = "exact", gain = 0.5, max_iterations = 20, segment_length_mm = None, segments = None, no_split = false, contour_tolerance_um = None, min_segment_length_mm = 0.01, max_residual_um = 1.0, chord_tolerance_mm = 1e-4, decimals = None, max_correction_mm = 0.1, nominal_directions = false, take_up = true, separate_take_ups = false, take_up_tolerance_um = None, trace = true, arcs_as_lines = false, allow_recompensate = false, max_output_bytes = Some(DEFAULT_MAX_OUTPUT_BYTES), points = false, name = None, date_utc = None))]
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    py: Python<'_>,
    program: &Bound<'_, PyAny>,
    model: &Bound<'_, Model>,
    setup: Option<&Bound<'_, PyAny>>,
    work_offset_mm: Option<Vec<f64>>,
    absolute_arc_centers: bool,
    accept_k0: bool,
    allow_no_program_end: bool,
    method: &str,
    gain: f64,
    max_iterations: u32,
    segment_length_mm: Option<f64>,
    segments: Option<u32>,
    no_split: bool,
    contour_tolerance_um: Option<f64>,
    min_segment_length_mm: f64,
    max_residual_um: f64,
    chord_tolerance_mm: f64,
    decimals: Option<u8>,
    max_correction_mm: f64,
    nominal_directions: bool,
    take_up: bool,
    separate_take_ups: bool,
    take_up_tolerance_um: Option<f64>,
    trace: bool,
    arcs_as_lines: bool,
    allow_recompensate: bool,
    max_output_bytes: Option<u64>,
    points: bool,
    name: Option<&str>,
    date_utc: Option<String>,
) -> PyResult<CompensateResult> {
    let m = machine(MachineArgs {
        setup,
        work_offset_mm,
        absolute_arc_centers,
        accept_k0,
        allow_no_program_end,
        chord_tolerance_mm,
    })?;
    warn_without_work_offset(py, &m)?;
    let opts = options(
        method,
        gain,
        max_iterations,
        segment_length_mm,
        segments,
        no_split,
        contour_tolerance_um,
        min_segment_length_mm,
        max_residual_um,
        chord_tolerance_mm,
        decimals,
        max_correction_mm,
        nominal_directions,
        take_up,
        separate_take_ups,
        take_up_tolerance_um,
        trace,
        arcs_as_lines,
    )?;
    let model = model.get();
    let src = source(program, "program", name)?;
    let head = header(model, &m, &opts, date_utc.unwrap_or_else(date_now_utc))?;
    let mut out = Vec::new();
    let mut records: Vec<PointRecord> = Vec::new();
    let mut warnings: Vec<Warning> = Vec::new();
    let file = src.name.clone();
    let result = py.detach(|| {
        let mut limited = LimitedWriter::new(&mut out, max_output_bytes);
        Compensator::new(model.model())
            .setup(m.setup.clone())
            .options(opts)
            .header(head)
            .file_name(file.as_str())
            .allow_recompensate(allow_recompensate)
            .on_point(|p| {
                if points {
                    records.push(*p);
                }
            })
            .on_warning(|w| warnings.push(w.clone()))
            .run(src.bytes.as_slice(), &mut limited)
            .map_err(Box::new)
    });
    let summary = result.map_err(|e| explain(*e, &m))?;
    let machining_time = times_dict(py, &out, Some(&src.bytes), &m)?;
    let point_records = if points {
        Some(point_dict(py, &records)?.unbind())
    } else {
        None
    };
    Ok(CompensateResult {
        data: PyBytes::new(py, &out).unbind(),
        lines_in: summary.lines_in,
        lines_out: summary.lines_out,
        points: summary.points,
        max_residual_um: summary.max_residual_um,
        max_correction_um: summary.max_correction_um,
        take_ups: summary.take_ups,
        take_ups_folded: summary.take_ups_folded,
        held: summary.held,
        held_count: summary.held_count,
        warnings: warnings_list(py, &src.name, &warnings)?.unbind(),
        point_records,
        machining_time,
    })
}

/// The machining time of `program` (and `original`) on the planner model,
/// as the dict of `volcomp time --json`.
fn times_dict(
    py: Python<'_>,
    program: &[u8],
    original: Option<&[u8]>,
    m: &Machine,
) -> PyResult<Py<PyDict>> {
    let t = py
        .detach(|| {
            volcomp_core::plan::compare_programs(
                (program, "<program>"),
                original.map(|o| (Box::new(o) as Box<dyn std::io::Read>, "<original>")),
                &m.setup,
            )
            .map_err(Box::new)
        })
        .map_err(|e| explain(*e, m))?;
    let json = serde_json::to_string(&t).map_err(|e| bad_input(e.to_string()))?;
    let d = py.import("json")?.call_method1("loads", (json,))?;
    Ok(d.cast_into::<PyDict>()?.unbind())
}

/// The per-point report as columns (the CLI's `--report` CSV).
fn point_dict<'py>(py: Python<'py>, r: &[PointRecord]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let v3 = |f: &dyn Fn(&PointRecord) -> Vec3| -> Vec<f64> {
        r.iter()
            .flat_map(|p| {
                let v = f(p);
                [v.x, v.y, v.z]
            })
            .collect()
    };
    let axes = |f: [bool; 3]| -> String {
        ['X', 'Y', 'Z']
            .iter()
            .zip(f)
            .filter(|(_, b)| *b)
            .map(|(c, _)| *c)
            .collect()
    };
    d.set_item(
        "line",
        PyArray1::from_vec(py, r.iter().map(|p| p.line).collect()),
    )?;
    d.set_item("target_mm", rows3(py, v3(&|p| p.target_mm))?)?;
    d.set_item("command_mm", rows3(py, v3(&|p| p.command_mm))?)?;
    d.set_item(
        "iterations",
        PyArray1::from_vec(py, r.iter().map(|p| p.iterations).collect()),
    )?;
    d.set_item(
        "residual_um",
        PyArray1::from_vec(py, r.iter().map(|p| p.residual_um).collect()),
    )?;
    d.set_item(
        "reversed",
        r.iter().map(|p| axes(p.reversed)).collect::<Vec<_>>(),
    )?;
    d.set_item("held", r.iter().map(|p| axes(p.held)).collect::<Vec<_>>())?;
    d.set_item(
        "take_up",
        PyArray1::from_vec(py, r.iter().map(|p| p.take_up).collect()),
    )?;
    d.set_item(
        "rapid",
        PyArray1::from_vec(py, r.iter().map(|p| p.rapid).collect()),
    )?;
    Ok(d)
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
    fn as_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("point_rms_um", self.point_rms_um)?;
        d.set_item("point_max_um", self.point_max_um)?;
        d.set_item("contour_rms_um", self.contour_rms_um)?;
        d.set_item("contour_max_um", self.contour_max_um)?;
        d.set_item("blocks", self.blocks)?;
        d.set_item("points", self.points)?;
        d.set_item("samples", self.samples)?;
        d.set_item("feed_length_mm", self.feed_length_mm)?;
        d.set_item("nominal", &self.nominal)?;
        d.set_item("point_definition", &self.point_definition)?;
        d.set_item("contour_definition", &self.contour_definition)?;
        d.set_item("machining_time", self.machining_time.clone_ref(py))?;
        Ok(d)
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
/// `program`, `reference`, `setup`: text or pathlib.Path. Machine options
/// as in `compensate`. `segments=True` adds the per-command arrays.
#[pyfunction]
#[pyo3(signature = (program, model, *, reference = None, setup = None, work_offset_mm = None, absolute_arc_centers = false, accept_k0 = false, allow_no_program_end = false, chord_tolerance_mm = 1e-5, segments = false, name = None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    program: &Bound<'_, PyAny>,
    model: &Bound<'_, Model>,
    reference: Option<&Bound<'_, PyAny>>,
    setup: Option<&Bound<'_, PyAny>>,
    work_offset_mm: Option<Vec<f64>>,
    absolute_arc_centers: bool,
    accept_k0: bool,
    allow_no_program_end: bool,
    chord_tolerance_mm: f64,
    segments: bool,
    name: Option<&str>,
) -> PyResult<SimulationResult> {
    let m = machine(MachineArgs {
        setup,
        work_offset_mm,
        absolute_arc_centers,
        accept_k0,
        allow_no_program_end,
        chord_tolerance_mm,
    })?;
    warn_without_work_offset(py, &m)?;
    let src = source(program, "program", name)?;
    let reference = reference
        .map(|r| source(r, "reference", None))
        .transpose()?;
    let model = model.get();
    let mut rows: Vec<SegmentError> = Vec::new();
    let mut warnings: Vec<Warning> = Vec::new();
    let result = py.detach(|| {
        let mut sim = Simulation::new(model.model())
            .setup(m.setup.clone())
            .file_name(src.name.as_str())
            .chord_tolerance_mm(chord_tolerance_mm)
            .on_warning(|w| warnings.push(w.clone()));
        if segments {
            sim = sim.on_segment(|s| rows.push(*s));
        }
        if let Some(r) = &reference {
            sim = sim.reference_named(r.name.clone(), r.bytes.as_slice());
        }
        sim.run(src.bytes.as_slice()).map_err(Box::new)
    });
    let report = result.map_err(|e| explain(*e, &m))?;
    let machining_time = times_dict(
        py,
        &src.bytes,
        reference.as_ref().map(|r| r.bytes.as_slice()),
        &m,
    )?;
    let segments = if segments {
        let d = PyDict::new(py);
        let v3 = |f: &dyn Fn(&SegmentError) -> Vec3| -> Vec<f64> {
            rows.iter()
                .flat_map(|s| {
                    let v = f(s);
                    [v.x, v.y, v.z]
                })
                .collect()
        };
        let nan = Vec3::new(f64::NAN, f64::NAN, f64::NAN);
        d.set_item(
            "line",
            PyArray1::from_vec(py, rows.iter().map(|s| s.line).collect()),
        )?;
        d.set_item(
            "nominal_line",
            PyArray1::from_vec(py, rows.iter().map(|s| s.nominal_line).collect()),
        )?;
        d.set_item("command_mm", rows3(py, v3(&|s| s.command_mm))?)?;
        d.set_item("actual_mm", rows3(py, v3(&|s| s.actual_mm))?)?;
        d.set_item("target_mm", rows3(py, v3(&|s| s.target_mm.unwrap_or(nan)))?)?;
        d.set_item(
            "point_um",
            PyArray1::from_vec(
                py,
                rows.iter()
                    .map(|s| s.point_um.unwrap_or(f64::NAN))
                    .collect(),
            ),
        )?;
        d.set_item(
            "contour_max_um",
            PyArray1::from_vec(py, rows.iter().map(|s| s.contour_max_um).collect()),
        )?;
        Some(d.unbind())
    } else {
        None
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
        warnings: warnings_list(py, &src.name, &warnings)?.unbind(),
        segments,
        machining_time,
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
#[pyo3(signature = (program, *, setup = None, work_offset_mm = None, absolute_arc_centers = false, accept_k0 = false, allow_no_program_end = false, extra_axes = false, name = None))]
#[allow(clippy::too_many_arguments)]
pub fn moves<'py>(
    py: Python<'py>,
    program: &Bound<'py, PyAny>,
    setup: Option<&Bound<'py, PyAny>>,
    work_offset_mm: Option<Vec<f64>>,
    absolute_arc_centers: bool,
    accept_k0: bool,
    allow_no_program_end: bool,
    extra_axes: bool,
    name: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = machine(MachineArgs {
        setup,
        work_offset_mm,
        absolute_arc_centers,
        accept_k0,
        allow_no_program_end,
        chord_tolerance_mm: volcomp_gcode::InterpOptions::default().spline_tolerance_mm,
    })?;
    let src = source(program, "program", name)?;
    #[derive(Default)]
    struct Columns {
        line: Vec<u64>,
        column: Vec<u64>,
        kind: Vec<&'static str>,
        source: Vec<&'static str>,
        end: [Vec<f64>; 3],
        center: [Vec<f64>; 3],
        extra: [Vec<f64>; 6],
    }
    let mut c = Columns::default();
    let mut warnings = Vec::new();
    let result = py.detach(|| -> Result<(), volcomp_gcode::GcodeError> {
        let mut walker = m.setup.walker(src.bytes.as_slice(), &src.name);
        let r = (|| {
            while let Some(ev) = walker.next_line()? {
                for mo in ev.motions {
                    c.line.push(mo.line);
                    c.column.push(mo.column as u64);
                    c.kind.push(mo.kind.name());
                    c.source.push(mo.source.name());
                    let centre = match mo.kind {
                        MotionKind::Arc(arc) => arc.center,
                        _ => Vec3::new(f64::NAN, f64::NAN, f64::NAN),
                    };
                    for k in 0..3 {
                        c.end[k].push(mo.end[k]);
                        c.center[k].push(centre[k]);
                    }
                    if extra_axes {
                        for k in 0..6 {
                            c.extra[k].push(mo.extra.end[k]);
                        }
                    }
                }
            }
            Ok(())
        })();
        warnings = walker.warnings().to_vec();
        r
    });
    for w in &warnings {
        warn(py, &format!("{}:{w}", src.name))?;
    }
    result.map_err(|e| to_py(Error::Gcode(e)))?;
    let d = PyDict::new(py);
    d.set_item("line", PyArray1::from_vec(py, c.line))?;
    d.set_item("column", PyArray1::from_vec(py, c.column))?;
    let np = py.import("numpy")?;
    d.set_item("kind", np.call_method1("array", (c.kind,))?)?;
    d.set_item("source", np.call_method1("array", (c.source,))?)?;
    let [x, y, z] = c.end;
    d.set_item("x_mm", PyArray1::from_vec(py, x))?;
    d.set_item("y_mm", PyArray1::from_vec(py, y))?;
    d.set_item("z_mm", PyArray1::from_vec(py, z))?;
    let [cx, cy, cz] = c.center;
    d.set_item("cx_mm", PyArray1::from_vec(py, cx))?;
    d.set_item("cy_mm", PyArray1::from_vec(py, cy))?;
    d.set_item("cz_mm", PyArray1::from_vec(py, cz))?;
    if extra_axes {
        for (name, v) in ["a_deg", "b_deg", "c_deg", "u_mm", "v_mm", "w_mm"]
            .iter()
            .zip(c.extra)
        {
            d.set_item(*name, PyArray1::from_vec(py, v))?;
        }
    }
    Ok(d)
}
