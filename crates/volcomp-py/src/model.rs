//! `volcomp.Model`: any error model volcomp reads (axis tables, the
//! 21-component kinematic model, the straightness model), its vectorised
//! evaluation and its components as arrays.

use crate::errors::{bad_input, bad_input_at, IntoPy, Located};
use crate::inputs::{f64_rows, f64_vec, fields, text_or_file};
use numpy::ndarray::Array2;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::PathBuf;
use volcomp_core::io::{load_model, LoadOptions, LoadedModel};
use volcomp_core::model::arrays;
use volcomp_core::model::axis_table::AxisTables;
use volcomp_core::model::kinematic::{AxisComponents, KinematicModel};
use volcomp_core::model::{Components, ErrorModel};
use volcomp_core::report::columns;
use volcomp_core::AxisTableMap;

/// An error model of a 3-axis machine: `e(q, s) = actual − commanded` in µm
/// at axis positions `q` (mm, machine axis frame) with motion directions
/// `s` (docs/design.md).
#[pyclass(module = "volcomp", frozen)]
pub struct Model {
    pub loaded: LoadedModel,
    /// The file it was loaded from (for the compensated program's header).
    pub path: Option<PathBuf>,
}

impl Model {
    pub fn model(&self) -> &dyn ErrorModel {
        self.loaded.model()
    }
}

/// `o` as a tuple of `n` items (`wanted` when it is not).
fn items<'py>(o: &Bound<'py, PyAny>, n: usize, wanted: &str) -> PyResult<Bound<'py, PyTuple>> {
    match o.cast::<PyTuple>() {
        Ok(t) if t.len() == n => Ok(t.clone()),
        _ => Err(bad_input(wanted)),
    }
}

/// One axis' `(forward, reverse)`: `obj` for both directions, or a dict
/// of `"forward"` and `"reverse"` (`missing` says so when one is absent;
/// `strict` refuses other keys); `one` reads each, named in errors.
fn both_ways<T: Clone>(
    obj: &Bound<'_, PyAny>,
    axis: char,
    (missing, strict): (&str, bool),
    one: impl Fn(&Bound<'_, PyAny>, String) -> PyResult<T>,
) -> PyResult<(T, T)> {
    let Ok(d) = obj.cast::<PyDict>() else {
        let t = one(obj, format!("axis {axis}"))?;
        return Ok((t.clone(), t));
    };
    let get = |k: &str| -> PyResult<Bound<'_, PyAny>> {
        d.get_item(k)?.ok_or_else(|| {
            bad_input(format!(
                "axis {axis}: the dict needs both \"forward\" and \"reverse\"{missing}"
            ))
        })
    };
    let keys = d.keys().iter().map(|k| k.to_string()).collect::<Vec<_>>();
    if let Some(k) = keys
        .iter()
        .find(|k| strict && *k != "forward" && *k != "reverse")
    {
        return Err(bad_input(format!(
            "axis {axis}: unknown key {k:?}; use \"forward\" and \"reverse\""
        )));
    }
    let forward = one(&get("forward")?, format!("axis {axis} forward"))?;
    Ok((
        forward,
        one(&get("reverse")?, format!("axis {axis} reverse"))?,
    ))
}

/// One axis from `(positions_mm, errors_um)` (both directions) or a dict
/// `{"forward": (p, e), "reverse": (p, e)}`.
fn axis_tables(obj: &Bound<'_, PyAny>, axis: char) -> PyResult<AxisTables> {
    let missing =
        " tables (a single direction is not enough: the other direction's error would be a guess)";
    let (forward, reverse) = both_ways(obj, axis, (missing, true), |o, what| {
        let pair = format!("{what} must be a pair (positions_mm, errors_um)");
        let wanted = match o.cast::<PyTuple>() {
            Ok(_) => pair,
            Err(_) => format!("{pair}; positions of shape (n,), errors of shape (n, 3)"),
        };
        let t = items(o, 2, &wanted)?;
        let p = f64_vec(&t.get_item(0)?, &format!("{what} positions_mm"))?;
        let e = f64_rows(&t.get_item(1)?, &format!("{what} errors_um"), 3)?;
        arrays::table(p, e.as_slice()?, &what).map_err(bad_input)
    })?;
    Ok(AxisTables { forward, reverse })
}

/// An axis of a 21-component model: one triple `(positions_mm,
/// linear_um, angular_urad)` for both directions, or a dict of
/// `"forward"` and `"reverse"` triples, checked as axis tables are.
fn axis_components(obj: &Bound<'_, PyAny>, axis: char) -> PyResult<AxisComponents> {
    let (forward, reverse) = both_ways(obj, axis, ("", false), |o, what| {
        let wanted = format!("{what} must be a triple (positions_mm, linear_um, angular_urad)");
        let t = items(o, 3, &wanted)?;
        let p = f64_vec(&t.get_item(0)?, &format!("{what} positions_mm"))?;
        let l = f64_rows(&t.get_item(1)?, &format!("{what} linear_um"), 3)?;
        let a = f64_rows(&t.get_item(2)?, &format!("{what} angular_urad"), 3)?;
        arrays::component_table(p, l.as_slice()?, a.as_slice()?, &what).map_err(bad_input)
    })?;
    Ok(AxisComponents { forward, reverse })
}

/// `(position_mm, forward, reverse)` of one component.
type Series<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

#[pymethods]
impl Model {
    /// Loads any model file: an axis-table map (`.csv`), a 21-component
    /// kinematic model or a straightness model (`.toml`, told apart by their
    /// `model` key). `clamp=True` holds a position outside a table at the
    /// table's end instead of refusing it.
    #[staticmethod]
    #[pyo3(signature = (path, *, clamp = false))]
    fn load(path: &Bound<'_, PyAny>, clamp: bool) -> PyResult<Model> {
        let path = crate::inputs::file_path(path)?;
        let loaded = load_model(&path, &LoadOptions { clamp }).py_err()?;
        Ok(Model {
            loaded,
            path: Some(path),
        })
    }

    /// An axis-table map from its CSV text (`axis,direction,position_mm,
    /// ex_um,ey_um,ez_um`, docs/design.md); `name` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, *, name = "<map>", clamp = false))]
    fn from_csv(text: &Bound<'_, PyAny>, name: &str, clamp: bool) -> PyResult<Model> {
        let src = text_or_file(text, "map", Some(name))?;
        let text = String::from_utf8(src.bytes).map_err(|e| {
            bad_input_at(
                format!(
                    "{name}: the map is not UTF-8 text (byte {})",
                    e.utf8_error().valid_up_to()
                ),
                Located {
                    file: Some(name.to_string()),
                    ..Located::default()
                },
            )
        })?;
        let mut map = AxisTableMap::from_csv(&text, &src.name).py_err()?;
        map.clamp = clamp;
        Ok(Model {
            loaded: LoadedModel::AxisTables(Box::new(map)),
            path: src.path,
        })
    }

    /// An axis-table map from arrays. Each of `x`, `y`, `z` is a pair
    /// `(positions_mm, errors_um)` (positions of shape (n,), strictly
    /// increasing; errors of shape (n, 3): the error along X, Y, Z that the
    /// axis' motion causes, µm) used in both directions, or a dict
    /// `{"forward": (p, e), "reverse": (p, e)}`.
    #[staticmethod]
    #[pyo3(signature = (x, y, z, *, clamp = false))]
    fn from_axis_tables(
        x: &Bound<'_, PyAny>,
        y: &Bound<'_, PyAny>,
        z: &Bound<'_, PyAny>,
        clamp: bool,
    ) -> PyResult<Model> {
        let map = AxisTableMap {
            axes: [
                axis_tables(x, 'X')?,
                axis_tables(y, 'Y')?,
                axis_tables(z, 'Z')?,
            ],
            clamp,
        };
        Ok(Model {
            loaded: LoadedModel::AxisTables(Box::new(map)),
            path: None,
        })
    }

    /// A 21-component kinematic model (ISO 230-1, docs/kinematic.md) from
    /// arrays. Each of `x`, `y`, `z` is a triple `(positions_mm (n,),
    /// linear_um (n, 3), angular_urad (n, 3))` used in both directions (or a
    /// dict `{"forward": (...), "reverse": (...)}`): the axis' E_X, E_Y, E_Z
    /// (µm) and E_A, E_B, E_C (µrad) at strictly increasing positions.
    /// `chain` (workpiece to tool, default the model files' "w X' Y' b Z
    /// t"), `squareness_urad` (xy, yz, zx), `measuring_point_mm` and
    /// `measuring_tool_length_mm` (where the linear errors were measured),
    /// `angles` ("relative" or "moving-part") as the keys of a model file.
    #[staticmethod]
    #[pyo3(signature = (x, y, z, *, chain = "w X' Y' b Z t", squareness_urad = (0.0, 0.0, 0.0), measuring_point_mm = (0.0, 0.0, 0.0), measuring_tool_length_mm = 0.0, angles = "relative", clamp = false))]
    #[allow(clippy::too_many_arguments)]
    fn from_components(
        x: &Bound<'_, PyAny>,
        y: &Bound<'_, PyAny>,
        z: &Bound<'_, PyAny>,
        chain: &str,
        squareness_urad: (f64, f64, f64),
        measuring_point_mm: (f64, f64, f64),
        measuring_tool_length_mm: f64,
        angles: &str,
        clamp: bool,
    ) -> PyResult<Model> {
        let topology: volcomp_core::model::topology::Topology = chain.parse().py_err()?;
        let (sq, p) = (squareness_urad, measuring_point_mm);
        let k = arrays::kinematics(
            topology,
            [sq.0, sq.1, sq.2],
            [p.0, p.1, p.2],
            measuring_tool_length_mm,
            angles,
        )
        .map_err(bad_input)?;
        let mut km = KinematicModel::new(
            [
                axis_components(x, 'X')?,
                axis_components(y, 'Y')?,
                axis_components(z, 'Z')?,
            ],
            k,
        );
        km.clamp = clamp;
        Ok(Model {
            loaded: LoadedModel::Kinematic(Box::new(km)),
            path: None,
        })
    }

    /// The kind of model: `"axis-table"`, `"kinematic-21"` or `"straightness"`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.loaded.kind().name()
    }

    /// The file the model was loaded from, or None.
    #[getter]
    fn path(&self) -> Option<String> {
        self.path.as_ref().map(|p| p.display().to_string())
    }

    /// Whether the deviation depends on the tool offset (Abbe arms of the
    /// 21-component model).
    #[getter]
    fn uses_tool_offset(&self) -> bool {
        self.model().uses_tool_offset()
    }

    /// The axis ranges the model is defined on: array of shape (3, 2),
    /// `[min, max]` per axis X, Y, Z (mm).
    #[getter]
    fn range_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let r = self.model().range_mm();
        Array2::from_shape_vec((3, 2), r.iter().flatten().copied().collect())
            .unwrap_or_else(|_| Array2::zeros((3, 2)))
            .into_pyarray(py)
    }

    /// The deviation `e = actual − commanded` (µm) at every row of
    /// `positions_mm` (shape (N, 3), machine axes, mm), as an array of shape
    /// (N, 3).
    ///
    /// `directions`: the motion direction of each axis, +1 forward, −1
    /// reverse; shape (3,) for all points or (N, 3); default all forward.
    /// `tool_offset_mm`: the active tool's length offset vector (G43: (0, 0,
    /// L)); shape (3,) or (N, 3); used by the 21-component model's Abbe arms.
    /// `positioning_only`: only E_XX, E_YY, E_ZZ. `outside`: `"raise"` (a
    /// point outside the range raises `BadInputError` naming its row) or
    /// `"nan"` (its row is NaN). The loop runs without the GIL.
    #[pyo3(signature = (positions_mm, *, directions = None, tool_offset_mm = None, positioning_only = false, outside = "raise"))]
    fn deviation_um<'py>(
        &self,
        py: Python<'py>,
        positions_mm: &Bound<'py, PyAny>,
        directions: Option<&Bound<'py, PyAny>>,
        tool_offset_mm: Option<&Bound<'py, PyAny>>,
        positioning_only: bool,
        outside: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let outside = arrays::Outside::parse(outside).map_err(bad_input)?;
        let q = f64_rows(positions_mm, "positions_mm", 3)?;
        let n = q.shape()[0];
        // One row for every point, or a row each.
        let rows = |obj: Option<&Bound<'py, PyAny>>, what: &str, default: f64| match obj {
            None => Ok(vec![default; 3]),
            Some(obj) => {
                let a = f64_rows(obj, what, 3)?;
                let shape = a.shape();
                if shape[0] != 1 && shape[0] != n {
                    let e = format!("{what} must have shape (3,) or ({n}, 3); got {shape:?}");
                    return Err(bad_input(e));
                }
                Ok(a.as_slice()?.to_vec())
            }
        };
        let dirs = rows(directions, "directions", 1.0)?;
        if directions.is_some() {
            arrays::check_directions(&dirs).map_err(bad_input)?;
        }
        let tool = rows(tool_offset_mm, "tool_offset_mm", 0.0)?;
        let components = if positioning_only {
            Components::PositioningOnly
        } else {
            Components::All
        };
        let model = self.model();
        let mut out = vec![0.0; 3 * n];
        let (q, dirs, tool) = (q.as_slice()?, dirs.as_slice(), tool.as_slice());
        let result = py.detach(|| {
            arrays::deviations_um(model, (q, dirs, tool), components, outside, &mut out)
        });
        if let Err((row, e)) = result {
            return Err(bad_input(format!("positions_mm row {row}: {e}")));
        }
        Ok(Array2::from_shape_vec((n, 3), out)
            .map_err(|e| crate::errors::bad_input(e.to_string()))?
            .into_pyarray(py))
    }

    /// The model's components as arrays, per axis and direction.
    ///
    /// `{"X": {"forward": {"position_mm": (n,), "linear_um": (n, 3), ...},
    /// "reverse": {...}}, "Y": ..., "Z": ...}`. `linear_um` columns are the
    /// errors along X, Y, Z the axis causes (E_XA, E_YA, E_ZA: positioning
    /// and straightness); the 21-component model adds `angular_urad`
    /// (E_AA, E_BA, E_CA: rotations about X, Y, Z) and the key
    /// `"squareness_urad"` (`{"xy", "yz", "zx"}`); the straightness model
    /// gives, per measured axis, the part of `e_z` that depends on it
    /// (`e_z(x) + β_zx·x`, likewise Y) at 201 points over its measured range
    /// (`{"X": {"position_mm", "ez_um"}, ...}`).
    fn components<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        fields(py, &columns::components(&self.loaded).py_err()?)
    }

    /// One named ISO 230-1 component (`"EXX"`, `"EZX"`, `"EBY"`, …) as
    /// `(position_mm, forward, reverse)` arrays (µm for linear errors, µrad
    /// for angular ones); axis tables have the linear ones only.
    fn component<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Series<'py>> {
        let [p, f, r] = self.loaded.component_columns(name).map_err(bad_input)?;
        Ok((
            PyArray1::from_vec(py, p),
            PyArray1::from_vec(py, f),
            PyArray1::from_vec(py, r),
        ))
    }

    /// The axis-table map as CSV text (docs/design.md); other kinds raise.
    fn to_csv(&self) -> PyResult<String> {
        match &self.loaded {
            LoadedModel::AxisTables(m) => Ok(m.to_csv()),
            _ => Err(bad_input(format!(
                "a {} model is not an axis-table map; to_csv() writes axis tables only",
                self.loaded.kind().name()
            ))),
        }
    }

    fn __repr__(&self) -> String {
        let r = self.model().range_mm();
        // As Python writes the values: a str in quotes, or None.
        let path = match &self.path {
            Some(p) => format!("{:?}", p.display().to_string()),
            None => "None".into(),
        };
        format!(
            "Model(kind={:?}, path={path}, range_mm=X {}…{}, Y {}…{}, Z {}…{})",
            self.loaded.kind().name(),
            r[0][0],
            r[0][1],
            r[1][0],
            r[1][1],
            r[2][0],
            r[2][1]
        )
    }
}

/// A model's controller tables (`volcomp map export`, docs/controllers.md):
/// the files by name, the controller's notes, and how far the table lies
/// from the map as the controller applies it.
#[pyfunction]
#[pyo3(signature = (model, **options))]
pub fn export<'py>(
    py: Python<'py>,
    model: &Model,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    use volcomp_core::request::{MapExportRequest, MapView};
    let request: MapExportRequest = crate::request::from_kwargs(options)?;
    let view = match &model.loaded {
        LoadedModel::AxisTables(m) => MapView::Tables(m),
        LoadedModel::Kinematic(m) => MapView::Kinematic(m),
        other => {
            return Err(bad_input(format!(
                "export takes axis tables or a 21-component model, not a {} model",
                other.kind().name()
            )))
        }
    };
    let name = model
        .path
        .as_ref()
        .map_or_else(|| "<model>".to_string(), |p| p.display().to_string());
    let out = request
        .run(view, &name)
        .map_err(crate::request::library_error)?;
    let files = PyDict::new(py);
    for f in out.files() {
        files.set_item(&f.name, &f.text)?;
    }
    let d = PyDict::new(py);
    d.set_item("files", files)?;
    d.set_item("notes", out.export.notes.clone())?;
    d.set_item("table_error_um", out.error.max_um)?;
    Ok(d)
}
