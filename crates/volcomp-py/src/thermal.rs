//! Thermally varying error: a model fitted on artifact cycles and
//! temperatures, and the 21-component model it predicts for a moment
//! (docs/thermal.md, [Thermal study]).

use crate::errors::IntoPy;
use crate::inputs::{fields, warn};
use crate::model::Model;
use crate::request::{from_kwargs, input, keywords, library_error};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::identify::thermal::files::ThermalModelFile;
use volcomp_core::io::LoadedModel;
use volcomp_core::progress::Silent;
use volcomp_core::report::columns;
use volcomp_core::request::{ThermalFitRequest, ThermalPredictRequest};

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
        let path = crate::inputs::file_path(path)?;
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
    /// CSV: a path or a file object, docs/thermal.md) of cycle `cycle`, or
    /// the last row. Temperatures outside the training range are refused
    /// unless `extrapolate=True` (then with a `VolcompWarning`).
    #[pyo3(signature = (temperatures, **options))]
    fn predict(
        &self,
        py: Python<'_>,
        temperatures: &Bound<'_, PyAny>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Model> {
        let mut request: ThermalPredictRequest = from_kwargs(options)?;
        request.temperatures = Some(input(temperatures, "temperatures")?);
        let p = request.predict(&self.file).map_err(library_error)?;
        if let Some(w) = &p.warning {
            warn(py, &keywords(w))?;
        }
        let km = p.model(&self.file).map_err(library_error)?;
        Ok(Model {
            loaded: LoadedModel::Kinematic(Box::new(km)),
            path: None,
        })
    }
}

/// Fits a thermal model (docs/thermal.md): identifies the Legendre
/// 21-component model of every artifact cycle of `measurements`, then
/// regresses its parameters on `temperatures`. Inputs are CSV files (paths
/// or file objects): the measurements, the temperatures and the artifact
/// (ball array). The options are those of the CLI's `thermal fit`
/// (help(volcomp.thermal_fit) lists them; `ranges_mm`, the axis ranges
/// ((x0, x1), (y0, y1), (z0, z1)), is required). With `bands_samples`
/// (e.g. 400), the 95 % Monte Carlo bands of the last cycle's identified
/// error along lines through the middle of the volume are computed too.
///
/// Returns `(model, report)`: a `ThermalModel` and a dict with `rank`,
/// `parameters`, `sigma0_um` (min, max), `unidentifiable`, `warnings` and,
/// on request, `bands`: per axis "X", "Y", "Z" a dict of `points_mm` (K,
/// 3), `estimate_um`, `std_um`, `lo_um`, `hi_um` (K, 3).
#[pyfunction]
#[pyo3(signature = (measurements, temperatures, artifact, **options))]
pub fn thermal_fit<'py>(
    py: Python<'py>,
    measurements: &Bound<'py, PyAny>,
    temperatures: &Bound<'py, PyAny>,
    artifact: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(ThermalModel, Bound<'py, PyDict>)> {
    let mut request: ThermalFitRequest = from_kwargs(options)?;
    request.measurements = Some(input(measurements, "measurements")?);
    request.temperatures = Some(input(temperatures, "temperatures")?);
    request.artifact = Some(input(artifact, "artifact")?);
    let fit = py
        .detach(|| request.fit().map_err(Box::new))
        .map_err(|e| library_error(*e))?;
    let (file, idents) = (&fit.file, &fit.idents);
    let report = PyDict::new(py);
    if let Some(first) = idents.first() {
        report.set_item("rank", first.rank)?;
        report.set_item("parameters", first.theta.len())?;
        report.set_item("observations", first.observations)?;
    }
    report.set_item("sigma0_um", file.sigma0_range_um())?;
    report.set_item("unidentifiable", file.unidentifiable.clone())?;
    report.set_item("warnings", fit.warnings.clone())?;
    if request.bands_samples.is_some() {
        let (lines, _) = py
            .detach(|| request.bands(&fit, &mut Silent).map_err(Box::new))
            .map_err(|e| library_error(*e))?;
        report.set_item("bands", fields(py, &columns::bands(&lines))?)?;
    }
    Ok((ThermalModel { file: fit.file }, report))
}
