//! `volcomp.Model`: any error model volcomp reads (axis tables, the
//! 21-component kinematic model, the straightness model), its vectorised
//! evaluation and its components as arrays.

use crate::errors::{bad_input, bad_input_at, IntoPy, Located};
use crate::inputs::{f64_rows, f64_vec, is_path_like, path_of, text_or_file};
use numpy::ndarray::Array2;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::PathBuf;
use volcomp_core::io::{load_model, LoadOptions, LoadedModel};
use volcomp_core::model::axis_table::{AxisTables, Table};
use volcomp_core::model::{Components, Direction, Directions, ErrorModel};
use volcomp_core::AxisTableMap;
use volcomp_gcode::Vec3;

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

/// What a point that lies outside the model's range gives.
#[derive(Clone, Copy, PartialEq)]
enum Outside {
    Raise,
    Nan,
}

/// Evaluates `e` at every row of `q_mm` (N×3, mm) with the directions of
/// `dirs` (N×3 or 1×3, ±1) and tool offsets `tool_mm` (N×3 or 1×3, mm) into
/// `out_um` (N×3, µm). `Err((row, error))` at the first point outside the
/// model's range unless `outside` is `Nan`.
fn evaluate_rows(
    model: &dyn ErrorModel,
    q_mm: &[f64],
    dirs: &[f64],
    tool_mm: &[f64],
    components: Components,
    outside: Outside,
    out_um: &mut [f64],
) -> Result<(), (usize, volcomp_core::error::ModelError)> {
    let n = q_mm.len() / 3;
    let dir = |v: f64| {
        if v < 0.0 {
            Direction::Reverse
        } else {
            Direction::Forward
        }
    };
    let per_row_dirs = dirs.len() > 3;
    let per_row_tool = tool_mm.len() > 3;
    let uses_tool = model.uses_tool_offset();
    for i in 0..n {
        let q = Vec3::new(q_mm[3 * i], q_mm[3 * i + 1], q_mm[3 * i + 2]);
        let d = if per_row_dirs { 3 * i } else { 0 };
        let s: Directions = [dir(dirs[d]), dir(dirs[d + 1]), dir(dirs[d + 2])];
        let e = if uses_tool {
            let t = if per_row_tool { 3 * i } else { 0 };
            let tool = Vec3::new(tool_mm[t], tool_mm[t + 1], tool_mm[t + 2]);
            model.deviation_with_tool_um(q, s, components, tool)
        } else {
            model.deviation_um(q, s, components)
        };
        match e {
            Ok(e) => out_um[3 * i..3 * i + 3].copy_from_slice(&[e.x, e.y, e.z]),
            Err(_) if outside == Outside::Nan => out_um[3 * i..3 * i + 3].fill(f64::NAN),
            Err(err) => return Err((i, err)),
        }
    }
    Ok(())
}

/// Builds one axis' table from positions (mm) and errors (µm, n×3).
fn table(positions_mm: Vec<f64>, errors_um: &[f64], what: &str) -> PyResult<Table> {
    let n = positions_mm.len();
    if errors_um.len() != 3 * n {
        return Err(bad_input(format!(
            "{what}: {n} positions but {} error values; give errors of shape ({n}, 3) in µm (along X, Y, Z)",
            errors_um.len()
        )));
    }
    if n < 2 {
        return Err(bad_input(format!(
            "{what}: {n} point(s); give at least two points per table"
        )));
    }
    if let Some(i) = positions_mm.iter().position(|p| !p.is_finite()) {
        return Err(bad_input(format!(
            "{what}: position {i} is {}; give finite positions in mm",
            positions_mm[i]
        )));
    }
    if let Some(i) = errors_um.iter().position(|e| !e.is_finite()) {
        return Err(bad_input(format!(
            "{what}: error value at row {}, column {} is {}; give finite errors in µm",
            i / 3,
            i % 3,
            errors_um[i]
        )));
    }
    if let Some(i) = positions_mm.windows(2).position(|w| w[1] <= w[0]) {
        return Err(bad_input(format!(
            "{what}: position {} ({} mm) does not increase after {} mm; list positions in strictly increasing order",
            i + 1,
            positions_mm[i + 1],
            positions_mm[i]
        )));
    }
    Ok(Table {
        positions_mm,
        errors_um: errors_um
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect(),
    })
}

/// One axis from `(positions_mm, errors_um)` (both directions) or a dict
/// `{"forward": (p, e), "reverse": (p, e)}`.
fn axis_tables(obj: &Bound<'_, PyAny>, axis: char) -> PyResult<AxisTables> {
    let pair = |o: &Bound<'_, PyAny>, what: String| -> PyResult<Table> {
        let t = o.cast::<PyTuple>().map_err(|_| {
            bad_input(format!(
                "{what} must be a pair (positions_mm, errors_um); positions of shape (n,), errors of shape (n, 3)"
            ))
        })?;
        if t.len() != 2 {
            return Err(bad_input(format!(
                "{what} must be a pair (positions_mm, errors_um)"
            )));
        }
        let p = f64_vec(&t.get_item(0)?, &format!("{what} positions_mm"))?;
        let e = f64_rows(&t.get_item(1)?, &format!("{what} errors_um"), 3)?;
        table(p, e.as_slice()?, &what)
    };
    if let Ok(d) = obj.cast::<PyDict>() {
        let get = |k: &str| -> PyResult<Bound<'_, PyAny>> {
            d.get_item(k)?.ok_or_else(|| {
                bad_input(format!("axis {axis}: the dict needs both \"forward\" and \"reverse\" tables (a single direction is not enough: the other direction's error would be a guess)"))
            })
        };
        if let Some(k) = d
            .keys()
            .iter()
            .map(|k| k.to_string())
            .find(|k| k != "forward" && k != "reverse")
        {
            return Err(bad_input(format!(
                "axis {axis}: unknown key {k:?}; use \"forward\" and \"reverse\""
            )));
        }
        return Ok(AxisTables {
            forward: pair(&get("forward")?, format!("axis {axis} forward"))?,
            reverse: pair(&get("reverse")?, format!("axis {axis} reverse"))?,
        });
    }
    let t = pair(obj, format!("axis {axis}"))?;
    Ok(AxisTables {
        forward: t.clone(),
        reverse: t,
    })
}

fn vec3_rows<'py>(py: Python<'py>, v: &[Vec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = v.iter().flat_map(|e| [e.x, e.y, e.z]).collect();
    Array2::from_shape_vec((v.len(), 3), flat)
        .unwrap_or_else(|_| Array2::zeros((0, 3)))
        .into_pyarray(py)
}

fn direction_dict<'py>(
    py: Python<'py>,
    positions_mm: &[f64],
    columns: &[(&str, &[Vec3])],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("position_mm", PyArray1::from_slice(py, positions_mm))?;
    for (name, v) in columns {
        d.set_item(*name, vec3_rows(py, v))?;
    }
    Ok(d)
}

const AXES: [char; 3] = ['X', 'Y', 'Z'];

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
        let path = if is_path_like(path) {
            path_of(path)?
        } else {
            PathBuf::from(
                path.extract::<String>()
                    .map_err(|_| bad_input("path must be a file name (str or pathlib.Path)"))?,
            )
        };
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
        use volcomp_core::model::kinematic::{
            AngleConvention, AxisComponents, KinematicModel, Kinematics, MeasuringLine,
        };
        let topology: volcomp_core::model::topology::Topology = chain.parse().py_err()?;
        let angles = match angles {
            "relative" => AngleConvention::Relative,
            "moving-part" => AngleConvention::MovingPart,
            a => {
                return Err(bad_input(format!(
                    "angles must be \"relative\" or \"moving-part\"; got {a:?}"
                )))
            }
        };
        let (sq_xy, sq_yz, sq_zx) = squareness_urad;
        let (px, py_, pz) = measuring_point_mm;
        for (v, what) in [
            (sq_xy, "squareness_urad"),
            (sq_yz, "squareness_urad"),
            (sq_zx, "squareness_urad"),
            (px, "measuring_point_mm"),
            (py_, "measuring_point_mm"),
            (pz, "measuring_point_mm"),
            (measuring_tool_length_mm, "measuring_tool_length_mm"),
        ] {
            if !v.is_finite() {
                return Err(bad_input(format!("{what} must be finite; got {v}")));
            }
        }
        let mut k = Kinematics::new(topology);
        k.measuring = [MeasuringLine {
            point_mm: Vec3::new(px, py_, pz),
            tool_offset_mm: Vec3::new(0.0, 0.0, measuring_tool_length_mm),
        }; 3];
        k.squareness.xy_urad = sq_xy;
        k.squareness.yz_urad = sq_yz;
        k.squareness.zx_urad = sq_zx;
        k.angles = angles;
        let axis = |obj: &Bound<'_, PyAny>, name: char| -> PyResult<AxisComponents> {
            let triple = |o: &Bound<'_, PyAny>,
                          what: String|
             -> PyResult<volcomp_core::model::kinematic::ComponentTable> {
                let t = o.cast::<PyTuple>().map_err(|_| {
                    bad_input(format!(
                        "{what} must be a triple (positions_mm, linear_um, angular_urad)"
                    ))
                })?;
                if t.len() != 3 {
                    return Err(bad_input(format!(
                        "{what} must be a triple (positions_mm, linear_um, angular_urad)"
                    )));
                }
                let p = f64_vec(&t.get_item(0)?, &format!("{what} positions_mm"))?;
                let l = f64_rows(&t.get_item(1)?, &format!("{what} linear_um"), 3)?;
                let a = f64_rows(&t.get_item(2)?, &format!("{what} angular_urad"), 3)?;
                // The checks of an axis table (lengths, finite, increasing).
                let lin = table(p.clone(), l.as_slice()?, &what)?;
                let ang = table(p, a.as_slice()?, &what)?;
                volcomp_core::model::kinematic::ComponentTable::new(
                    lin.positions_mm,
                    lin.errors_um,
                    ang.errors_um,
                )
                .ok_or_else(|| bad_input(format!("{what}: the table is not valid")))
            };
            if let Ok(d) = obj.cast::<PyDict>() {
                let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
                    d.get_item(key)?.ok_or_else(|| {
                        bad_input(format!(
                            "axis {name}: the dict needs both \"forward\" and \"reverse\""
                        ))
                    })
                };
                return Ok(AxisComponents {
                    forward: triple(&get("forward")?, format!("axis {name} forward"))?,
                    reverse: triple(&get("reverse")?, format!("axis {name} reverse"))?,
                });
            }
            Ok(AxisComponents::both(triple(obj, format!("axis {name}"))?))
        };
        let mut km = KinematicModel::new([axis(x, 'X')?, axis(y, 'Y')?, axis(z, 'Z')?], k);
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
        let outside = match outside {
            "raise" => Outside::Raise,
            "nan" => Outside::Nan,
            o => {
                return Err(bad_input(format!(
                    "outside must be \"raise\" or \"nan\"; got {o:?}"
                )))
            }
        };
        let q = f64_rows(positions_mm, "positions_mm", 3)?;
        let n = q.shape()[0];
        let dirs = match directions {
            Some(d) => {
                let d = f64_rows(d, "directions", 3)?;
                let v = d.as_slice()?.to_vec();
                if d.shape()[0] != 1 && d.shape()[0] != n {
                    return Err(bad_input(format!(
                        "directions must have shape (3,) or ({n}, 3); got {:?}",
                        d.shape()
                    )));
                }
                if let Some(i) = v.iter().position(|x| *x != 1.0 && *x != -1.0) {
                    return Err(bad_input(format!(
                        "directions: row {}, column {} is {}; give +1 (forward) or -1 (reverse)",
                        i / 3,
                        i % 3,
                        v[i]
                    )));
                }
                v
            }
            None => vec![1.0; 3],
        };
        let tool = match tool_offset_mm {
            Some(t) => {
                let t = f64_rows(t, "tool_offset_mm", 3)?;
                if t.shape()[0] != 1 && t.shape()[0] != n {
                    return Err(bad_input(format!(
                        "tool_offset_mm must have shape (3,) or ({n}, 3); got {:?}",
                        t.shape()
                    )));
                }
                t.as_slice()?.to_vec()
            }
            None => vec![0.0; 3],
        };
        let components = if positioning_only {
            Components::PositioningOnly
        } else {
            Components::All
        };
        let q_slice = q.as_slice()?;
        let model = self.model();
        let mut out = vec![0.0; 3 * n];
        let result = py
            .detach(|| evaluate_rows(model, q_slice, &dirs, &tool, components, outside, &mut out));
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
        let out = PyDict::new(py);
        match &self.loaded {
            LoadedModel::AxisTables(m) => {
                for (a, t) in m.axes.iter().enumerate() {
                    let axis = PyDict::new(py);
                    for (name, tab) in [("forward", &t.forward), ("reverse", &t.reverse)] {
                        axis.set_item(
                            name,
                            direction_dict(
                                py,
                                &tab.positions_mm,
                                &[("linear_um", &tab.errors_um)],
                            )?,
                        )?;
                    }
                    out.set_item(AXES[a].to_string(), axis)?;
                }
            }
            LoadedModel::Kinematic(m) => {
                for (a, t) in m.axes.iter().enumerate() {
                    let axis = PyDict::new(py);
                    for (name, tab) in [("forward", &t.forward), ("reverse", &t.reverse)] {
                        axis.set_item(
                            name,
                            direction_dict(
                                py,
                                tab.positions_mm(),
                                &[
                                    ("linear_um", &tab.linear_um.errors_um),
                                    ("angular_urad", &tab.angular_urad.errors_um),
                                ],
                            )?,
                        )?;
                    }
                    out.set_item(AXES[a].to_string(), axis)?;
                }
                let sq = PyDict::new(py);
                let s = &m.kinematics.squareness;
                sq.set_item("xy", s.xy_urad)?;
                sq.set_item("yz", s.yz_urad)?;
                sq.set_item("zx", s.zx_urad)?;
                out.set_item("squareness_urad", sq)?;
            }
            LoadedModel::Straightness(m) => {
                for axis in [
                    volcomp_core::identify::straightness::Axis::X,
                    volcomp_core::identify::straightness::Axis::Y,
                ] {
                    let Some(am) = m.axis(axis) else { continue };
                    // Sampled every 1/200 of the measured range: the
                    // series is smooth (its shortest wavelength is the
                    // cut-off, many samples long).
                    let [lo, hi] = am.range_mm;
                    let n = 201usize;
                    let p: Vec<f64> = (0..n)
                        .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
                        .collect();
                    let e = p
                        .iter()
                        .map(|&x| m.axis_part_um(axis, x))
                        .collect::<Result<Vec<f64>, _>>()
                        .py_err()?;
                    let d = PyDict::new(py);
                    d.set_item("position_mm", PyArray1::from_vec(py, p))?;
                    d.set_item("ez_um", PyArray1::from_vec(py, e))?;
                    out.set_item(axis.letter().to_string(), d)?;
                }
            }
        }
        Ok(out)
    }

    /// One named ISO 230-1 component (`"EXX"`, `"EZX"`, `"EBY"`, …) as
    /// `(position_mm, forward, reverse)` arrays (µm for linear errors, µrad
    /// for angular ones); axis tables have the linear ones only.
    fn component<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Series<'py>> {
        let up = name.to_ascii_uppercase();
        let b = up.as_bytes();
        let parsed = (b.len() == 3 && b[0] == b'E')
            .then(|| {
                let axis = AXES.iter().position(|c| *c as u8 == b[2])?;
                let (dir, angular) = match b[1] {
                    b'X' => (0, false),
                    b'Y' => (1, false),
                    b'Z' => (2, false),
                    b'A' => (0, true),
                    b'B' => (1, true),
                    b'C' => (2, true),
                    _ => return None,
                };
                Some((axis, dir, angular))
            })
            .flatten();
        let Some((axis, dir, angular)) = parsed else {
            return Err(bad_input(format!(
                "unknown component {name:?}; use ISO 230-1 names: EXX, EYX, EZX, EAX, EBX, ECX (and the same for Y and Z)"
            )));
        };
        let col = |t: &Table| -> Vec<f64> { t.errors_um.iter().map(|e| e[dir]).collect() };
        let (p, f, r) = match (&self.loaded, angular) {
            (LoadedModel::AxisTables(m), false) => {
                let t = &m.axes[axis];
                if t.forward.positions_mm != t.reverse.positions_mm {
                    return Err(bad_input(format!("{up}: the forward and reverse tables of axis {} have different positions; read them from components()", AXES[axis])));
                }
                (
                    t.forward.positions_mm.clone(),
                    col(&t.forward),
                    col(&t.reverse),
                )
            }
            (LoadedModel::Kinematic(m), _) => {
                let t = &m.axes[axis];
                if t.forward.positions_mm() != t.reverse.positions_mm() {
                    return Err(bad_input(format!("{up}: the forward and reverse tables of axis {} have different positions; read them from components()", AXES[axis])));
                }
                let pick = |c: &volcomp_core::model::kinematic::ComponentTable| {
                    if angular {
                        col(&c.angular_urad)
                    } else {
                        col(&c.linear_um)
                    }
                };
                (
                    t.forward.positions_mm().to_vec(),
                    pick(&t.forward),
                    pick(&t.reverse),
                )
            }
            _ => {
                return Err(bad_input(format!(
                    "{up}: a {} model has no such component table; use components()",
                    self.loaded.kind().name()
                )))
            }
        };
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
