//! Thermally varying error: a model fitted on artifact cycles and
//! temperatures, and the 21-component model it predicts for a moment
//! (docs/thermal.md, [Thermal study]).

use crate::errors::{bad_input, IntoPy};
use crate::inputs::source;
use crate::model::Model;
use numpy::ndarray::Array2;
use numpy::prelude::*;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::identify::thermal::files::{
    self, parse_artifact, parse_measurements, parse_temperatures, ThermalModelFile,
};
use volcomp_core::identify::thermal::identify::DEFAULT_RELATIVE_THRESHOLD;
use volcomp_core::identify::thermal::uncertainty::axis_line_bands;
use volcomp_core::io::LoadedModel;
use volcomp_gcode::Vec3;

fn text_of(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(String, String)> {
    let src = source(obj, what, None)?;
    let text = String::from_utf8(src.bytes)
        .map_err(|_| bad_input(format!("{}: not UTF-8 text", src.name)))?;
    Ok((text, src.name))
}

/// A thermal model: the regression of the 21-component model's Legendre
/// coefficients on temperatures (the `volcomp thermal fit` file).
#[pyclass(module = "volcomp", frozen)]
pub struct ThermalModel {
    file: ThermalModelFile,
}

#[pymethods]
impl ThermalModel {
    /// Loads a thermal model file (TOML, `volcomp thermal fit -o`): a file
    /// name (str or pathlib.Path).
    #[staticmethod]
    fn load(path: &Bound<'_, PyAny>) -> PyResult<ThermalModel> {
        let path = if crate::inputs::is_path_like(path) {
            crate::inputs::path_of(path)?
        } else {
            std::path::PathBuf::from(
                path.extract::<String>()
                    .map_err(|_| bad_input("path must be a file name (str or pathlib.Path)"))?,
            )
        };
        let name = path.display().to_string();
        let text = volcomp_core::io::inputs::read_to_string(&path, "the thermal model")
            .map_err(|e| crate::errors::io_error(&name, &e))?;
        Ok(ThermalModel {
            file: ThermalModelFile::from_toml(&text, &name).py_err()?,
        })
    }

    /// The sensors the model was fitted on, in column order.
    #[getter]
    fn sensors(&self) -> Vec<String> {
        self.file.sensors.clone()
    }

    /// Parameters that the placements could not identify (zero in predictions).
    #[getter]
    fn unidentifiable(&self) -> Vec<String> {
        self.file.unidentifiable.clone()
    }

    /// Probing noise σ0 estimated per training cycle (µm).
    #[getter]
    fn sigma0_um<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.file.sigma0_um)
    }

    /// The model file's TOML text.
    fn to_toml(&self) -> String {
        self.file.to_toml()
    }

    /// The 21-component model at one moment: the row of `temperatures` (a
    /// CSV as text or pathlib.Path, docs/thermal.md) of cycle `cycle`, or
    /// the last row. Temperatures outside the training range are refused
    /// unless `extrapolate=True`.
    #[pyo3(signature = (temperatures, *, cycle = None, extrapolate = false))]
    fn predict(
        &self,
        temperatures: &Bound<'_, PyAny>,
        cycle: Option<usize>,
        extrapolate: bool,
    ) -> PyResult<Model> {
        let (text, name) = text_of(temperatures, "temperatures")?;
        let temps = parse_temperatures(&text, &name).py_err()?;
        let row = temps.row_of(cycle, &name).py_err()?;
        let theta = if extrapolate {
            self.file.predict_extrapolating(&temps, &name, row)
        } else {
            self.file.predict(&temps, &name, row)
        }
        .py_err()?;
        let poly = self.file.poly_model().py_err()?;
        let km = poly.to_kinematic_model(&theta, self.file.table_samples.max(2));
        Ok(Model {
            loaded: LoadedModel::Kinematic(Box::new(km)),
            path: None,
        })
    }
}

/// Fits a thermal model (docs/thermal.md): identifies the Legendre
/// 21-component model of every artifact cycle of `measurements`, then
/// regresses its parameters on `temperatures`. Inputs are CSV (text or
/// pathlib.Path): the measurements, the temperatures and the artifact
/// (ball array). `ranges_mm`: the axis ranges ((x0, x1), (y0, y1), (z0,
/// z1)). Options as `volcomp thermal fit`. With `bands_samples` (e.g.
/// 400), the 95 % Monte Carlo bands of the last cycle's identified error
/// along lines through the middle of the volume are computed too.
///
/// Returns `(model, report)`: a `ThermalModel` and a dict with `rank`,
/// `parameters`, `sigma0_um` (min, max), `unidentifiable`, `warnings` and,
/// on request, `bands`: per axis "X", "Y", "Z" a dict of `points_mm` (K,
/// 3), `estimate_um`, `std_um`, `lo_um`, `hi_um` (K, 3).
#[pyfunction]
#[pyo3(signature = (measurements, temperatures, artifact, *, ranges_mm, chain = "w X' Y' b Z t", order = 2, probe_length_mm = 0.0, lags = 0, threshold = DEFAULT_RELATIVE_THRESHOLD, table_samples = 61, bands_samples = None))]
#[allow(clippy::too_many_arguments)]
pub fn thermal_fit<'py>(
    py: Python<'py>,
    measurements: &Bound<'py, PyAny>,
    temperatures: &Bound<'py, PyAny>,
    artifact: &Bound<'py, PyAny>,
    ranges_mm: [[f64; 2]; 3],
    chain: &str,
    order: usize,
    probe_length_mm: f64,
    lags: usize,
    threshold: f64,
    table_samples: usize,
    bands_samples: Option<usize>,
) -> PyResult<(ThermalModel, Bound<'py, PyDict>)> {
    if !(threshold > 0.0 && threshold < 1.0) {
        return Err(bad_input(format!(
            "threshold {threshold}: give a relative threshold between 0 and 1 (default {DEFAULT_RELATIVE_THRESHOLD})"
        )));
    }
    let (a_text, a_name) = text_of(artifact, "artifact")?;
    let array = parse_artifact(&a_text, &a_name).py_err()?;
    let (m_text, m_name) = text_of(measurements, "measurements")?;
    let cycles = parse_measurements(&m_text, &m_name, &array).py_err()?;
    let (t_text, t_name) = text_of(temperatures, "temperatures")?;
    let temps = parse_temperatures(&t_text, &t_name).py_err()?;
    let options = files::FitOptions {
        chain: chain.to_string(),
        ranges_mm,
        order,
        probe_length_mm,
        lags,
        relative_threshold: threshold,
        table_samples,
    };
    let (file, idents) = py
        .detach(|| files::fit(&array, &cycles, &temps, &t_name, &options))
        .py_err()?;
    let report = PyDict::new(py);
    if let Some(first) = idents.first() {
        report.set_item("rank", first.rank)?;
        report.set_item("parameters", first.theta.len())?;
        report.set_item("observations", first.observations)?;
    }
    report.set_item("sigma0_um", file.sigma0_range_um())?;
    report.set_item("unidentifiable", file.unidentifiable.clone())?;
    report.set_item(
        "warnings",
        volcomp_core::identify::thermal::checks::noise_warnings(&cycles, &idents),
    )?;
    if let Some(samples) = bands_samples {
        let last = idents
            .last()
            .ok_or_else(|| bad_input("no cycles to draw bands for"))?;
        let poly = files::poly_model(chain, ranges_mm, order, probe_length_mm).py_err()?;
        let lines =
            py.detach(|| axis_line_bands(&poly, last, ranges_mm, probe_length_mm, samples.max(10)));
        let bands = PyDict::new(py);
        for l in &lines {
            let d = PyDict::new(py);
            let rows = |f: &dyn Fn(usize) -> Vec3| {
                let v: Vec<f64> = (0..l.points_mm.len())
                    .flat_map(|k| {
                        let p = f(k);
                        [p.x, p.y, p.z]
                    })
                    .collect();
                Array2::from_shape_vec((l.points_mm.len(), 3), v)
                    .unwrap_or_else(|_| Array2::zeros((0, 3)))
                    .into_pyarray(py)
            };
            d.set_item("points_mm", rows(&|k| l.points_mm[k]))?;
            d.set_item("estimate_um", rows(&|k| l.bands[k].estimate_um))?;
            d.set_item("std_um", rows(&|k| l.bands[k].std_um))?;
            d.set_item("lo_um", rows(&|k| l.bands[k].lo_um))?;
            d.set_item("hi_um", rows(&|k| l.bands[k].hi_um))?;
            bands.set_item(['X', 'Y', 'Z'][l.axis].to_string(), d)?;
        }
        report.set_item("bands", bands)?;
    }
    Ok((ThermalModel { file }, report))
}
