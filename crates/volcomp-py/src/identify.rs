//! Identification: ISO 230-2 figures of positioning from run arrays.

use crate::errors::{bad_input, IntoPy};
use crate::inputs::{f64_rows, f64_vec, source};
use numpy::prelude::*;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::identify::iso230_2 as iso;
use volcomp_core::identify::iso230_2::Iso230_2Report;

/// The report as `{"targets": {column: array}, "axis": {figure: float},
/// "notes": [str]}`.
fn report_dict<'py>(py: Python<'py>, r: &Iso230_2Report) -> PyResult<Bound<'py, PyDict>> {
    let t = PyDict::new(py);
    let col =
        |f: &dyn Fn(&iso::TargetStats) -> f64| -> Vec<f64> { r.targets.iter().map(f).collect() };
    t.set_item("target_mm", PyArray1::from_vec(py, col(&|s| s.target_mm)))?;
    t.set_item(
        "n_up",
        PyArray1::from_vec(py, r.targets.iter().map(|s| s.n_up as u64).collect()),
    )?;
    t.set_item(
        "n_down",
        PyArray1::from_vec(py, r.targets.iter().map(|s| s.n_down as u64).collect()),
    )?;
    for (name, f) in [
        (
            "mean_up_um",
            (|s: &iso::TargetStats| s.mean_up_um) as fn(&_) -> f64,
        ),
        ("mean_down_um", |s| s.mean_down_um),
        ("s_up_um", |s| s.s_up_um),
        ("s_down_um", |s| s.s_down_um),
        ("reversal_um", |s| s.reversal_um),
        ("mean_um", |s| s.mean_um),
        ("repeatability_up_um", |s| s.repeatability_up_um),
        ("repeatability_down_um", |s| s.repeatability_down_um),
        ("repeatability_um", |s| s.repeatability_um),
    ] {
        t.set_item(name, PyArray1::from_vec(py, col(&f)))?;
    }
    let a = &r.axis;
    let ax = PyDict::new(py);
    for (name, v) in [
        ("reversal_b_um", a.reversal_b_um),
        ("mean_reversal_um", a.mean_reversal_um),
        ("repeatability_up_um", a.repeatability_up_um),
        ("repeatability_down_um", a.repeatability_down_um),
        ("repeatability_um", a.repeatability_um),
        ("systematic_up_um", a.systematic_up_um),
        ("systematic_down_um", a.systematic_down_um),
        ("systematic_um", a.systematic_um),
        ("mean_range_um", a.mean_range_um),
        ("accuracy_up_um", a.accuracy_up_um),
        ("accuracy_down_um", a.accuracy_down_um),
        ("accuracy_um", a.accuracy_um),
    ] {
        ax.set_item(name, v)?;
    }
    let d = PyDict::new(py);
    d.set_item("targets", t)?;
    d.set_item("axis", ax)?;
    d.set_item("notes", r.notes.clone())?;
    Ok(d)
}

/// ISO 230-2:2014 figures of a bidirectional positioning test (clause 3).
///
/// `target_mm`: the m target positions P_i, shape (m,). `up_um`, `down_um`:
/// the positional deviations x_ij = P_ij − P_i (µm, actual minus target)
/// approaching in the positive and the negative direction, shape (m, n),
/// one row per target, one column per run (NaN: no approach in that run).
/// Each target needs at least two approaches per direction.
/// Returns `{"targets": {...arrays per target...}, "axis": {"reversal_b_um",
/// "repeatability_um", "systematic_um", "accuracy_um", ...}, "notes": [...]}`.
#[pyfunction]
pub fn iso230_2<'py>(
    py: Python<'py>,
    target_mm: &Bound<'py, PyAny>,
    up_um: &Bound<'py, PyAny>,
    down_um: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let targets = f64_vec(target_mm, "target_mm")?;
    let m = targets.len();
    let rows = |obj: &Bound<'py, PyAny>, what: &str| -> PyResult<Vec<Vec<f64>>> {
        let np = py.import("numpy")?;
        let arr = np.call_method1("asarray", (obj,))?;
        let ndim: usize = arr.getattr("ndim")?.extract()?;
        if ndim != 2 {
            return Err(bad_input(format!(
                "{what} must have shape ({m}, n): one row per target, one column per run"
            )));
        }
        let cols: usize = arr.getattr("shape")?.get_item(1)?.extract()?;
        let a = f64_rows(&arr, what, cols)?;
        if a.shape()[0] != m {
            return Err(bad_input(format!(
                "{what} has {} rows but target_mm has {m} targets",
                a.shape()[0]
            )));
        }
        let v = a.as_array();
        let mut out = Vec::with_capacity(m);
        for (i, row) in v.rows().into_iter().enumerate() {
            let mut r = Vec::with_capacity(cols);
            for (j, x) in row.iter().enumerate() {
                if x.is_nan() {
                    continue;
                }
                if !x.is_finite() {
                    return Err(bad_input(format!(
                        "{what}[{i}, {j}] is {x}; give finite deviations in µm (NaN for a missing approach)"
                    )));
                }
                r.push(*x);
            }
            out.push(r);
        }
        Ok(out)
    };
    if let Some(i) = targets.iter().position(|t| !t.is_finite()) {
        return Err(bad_input(format!(
            "target_mm[{i}] is {}; give finite positions in mm",
            targets[i]
        )));
    }
    let up = rows(up_um, "up_um")?;
    let down = rows(down_um, "down_um")?;
    let data: Vec<(f64, Vec<f64>, Vec<f64>)> = targets
        .into_iter()
        .zip(up)
        .zip(down)
        .map(|((t, u), d)| (t, u, d))
        .collect();
    let report = iso::evaluate(&data).map_err(|e| bad_input(e.to_string()))?;
    report_dict(py, &report)
}

/// ISO 230-2 figures from a test CSV (`target_mm,cycle,direction,
/// deviation_um` or `actual_mm`, docs/kinematic.md): its text (str) or a
/// file (pathlib.Path). Returns what `iso230_2` returns.
#[pyfunction]
#[pyo3(signature = (runs, *, name = None))]
pub fn iso230_2_csv<'py>(
    py: Python<'py>,
    runs: &Bound<'py, PyAny>,
    name: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let src = source(runs, "runs", name)?;
    let text = String::from_utf8(src.bytes)
        .map_err(|_| bad_input(format!("{}: not UTF-8 text", src.name)))?;
    let report = iso::from_csv(&text, &src.name).py_err()?;
    report_dict(py, &report)
}
