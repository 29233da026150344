//! Identification: ISO 230-2 figures of positioning from run arrays;
//! straightness models from profiles at several feed rates.

use crate::errors::{bad_input, IntoPy};
use crate::inputs::{f64_rows, f64_vec, fields, source};
use crate::model::Model;
use crate::request::{from_kwargs, library_error};
use numpy::prelude::*;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::identify::iso230_2 as iso;
use volcomp_core::identify::straightness;
use volcomp_core::io::LoadedModel;
use volcomp_core::report::columns;
use volcomp_core::request::StraightnessFitRequest;

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
        iso::approaches(a.as_slice()?, (m, cols), what).map_err(bad_input)
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
    fields(py, &columns::iso230_2(&report))
}

/// ISO 230-2 figures from a test CSV (`target_mm,cycle,direction,
/// deviation_um` or `actual_mm`, docs/kinematic.md): a path (str or pathlib.Path)
/// or a file object. Returns what `iso230_2` returns.
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
    fields(py, &columns::iso230_2(&report))
}

/// One run of `straightness_fit`: a CSV (a path or a file object) or a
/// dict of arrays.
fn straightness_run(obj: &Bound<'_, PyAny>, k: usize) -> PyResult<straightness::run::Run> {
    let run = if let Ok(d) = obj.cast::<PyDict>() {
        let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
            d.get_item(key)?.ok_or_else(|| {
                bad_input(format!(
                    "runs[{k}]: the dict needs \"positions_mm\", \"displacement_um\" and \"feed_mm_per_min\" (and may give \"axis\", \"name\")"
                ))
            })
        };
        let name: String = match d.get_item("name")? {
            Some(n) => n.extract()?,
            None => format!("runs[{k}]"),
        };
        let axis = match d.get_item("axis")? {
            None => None,
            Some(a) => Some(straightness_axis(&a.extract::<String>()?)?),
        };
        let feed: f64 = get("feed_mm_per_min")?.extract().map_err(|_| {
            bad_input(format!(
                "runs[{k}]: feed_mm_per_min must be a number (mm/min)"
            ))
        })?;
        straightness::run::Run::from_arrays(
            &name,
            axis,
            feed,
            f64_vec(&get("positions_mm")?, &format!("runs[{k}] positions_mm"))?,
            f64_vec(
                &get("displacement_um")?,
                &format!("runs[{k}] displacement_um"),
            )?,
        )
        .py_err()?
    } else {
        let src = source(obj, &format!("runs[{k}]"), None)?;
        let text = String::from_utf8(src.bytes)
            .map_err(|_| bad_input(format!("{}: not UTF-8 text", src.name)))?;
        straightness::run::Run::from_csv(&text, &src.name).py_err()?
    };
    Ok(run)
}

fn straightness_axis(text: &str) -> PyResult<straightness::Axis> {
    straightness::Axis::parse(text).ok_or_else(|| {
        bad_input(format!(
            "axis {text:?}: straightness runs are profiles along X or Y; give \"X\" or \"Y\""
        ))
    })
}

/// Identifies a straightness model from profiles at several feed rates,
/// the geometric error told from vibration by comparing them
/// (docs/straightness.md, [Straightness study]).
///
/// `runs`: a list of runs, each a CSV (a path or a file object; the layout
/// of docs/straightness.md) or a dict `{"positions_mm": (n,),
/// "displacement_um": (n,), "feed_mm_per_min": float, "axis": "X"|"Y",
/// "name": str}` (positions evenly spaced; the Z deviation actual −
/// commanded in µm). The options are those of the CLI's `straightness
/// fit` (help(volcomp.straightness_fit) lists them).
///
/// Returns `(model, report)`: the model (a `Model` of kind
/// "straightness": `model.deviation_um(q)[:, 2]` is its prediction e_z) and
/// per axis a dict of what was found (`harmonics`, `cutoff_wavelength_mm`,
/// `residual_rms_um`, `positions_mm`, `mean_profile_um`,
/// `model_profile_um`, `feeds_mm_per_min`, `mean_power`, `sigma`, ...).
#[pyfunction]
#[pyo3(signature = (runs, **options))]
pub fn straightness_fit<'py>(
    py: Python<'py>,
    runs: Vec<Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Model, Bound<'py, PyDict>)> {
    let request: StraightnessFitRequest = from_kwargs(options)?;
    let runs = runs
        .iter()
        .enumerate()
        .map(|(k, r)| straightness_run(r, k))
        .collect::<PyResult<Vec<_>>>()?;
    let fit = py
        .detach(|| request.fit(runs).map_err(Box::new))
        .map_err(|e| library_error(*e))?;
    let report = fields(py, &columns::straightness(&fit.axes))?;
    let model = Model {
        loaded: LoadedModel::Straightness(Box::new(fit.model)),
        path: None,
    };
    Ok((model, report))
}
