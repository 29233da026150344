//! Python bindings of volcomp: the `volcomp` package (built with maturin,
//! `crates/volcomp-py/pyproject.toml`; walk-through in `docs/python.md`).
//!
//! A front end like the CLI (docs/architecture.md): it turns Python
//! arguments into the library's option types, calls the library and turns
//! the results into numpy arrays and plain Python values. Conventions
//! (units, frames, the deviation sign `e = actual − commanded`) are those of
//! `docs/design.md`.
// Files are read through `volcomp_geom::inputs` only (clippy.toml).
#![cfg_attr(not(test), warn(clippy::disallowed_methods))]

use pyo3::prelude::*;

mod ballbar;
mod errors;
mod identify;
mod inputs;
mod mirror;
mod model;
mod probe;
mod program;
mod request;
mod thermal;

/// The compiled part of the `volcomp` package.
#[pymodule]
fn _volcomp(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(py, m)?;
    m.add_class::<model::Model>()?;
    m.add_function(wrap_pyfunction!(model::export, m)?)?;
    m.add_class::<program::CompensateResult>()?;
    m.add_class::<program::SimulationResult>()?;
    m.add_function(wrap_pyfunction!(program::compensate, m)?)?;
    m.add_function(wrap_pyfunction!(program::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(program::moves, m)?)?;
    m.add_function(wrap_pyfunction!(program::machining_time, m)?)?;
    m.add_function(wrap_pyfunction!(identify::iso230_2, m)?)?;
    m.add_function(wrap_pyfunction!(identify::iso230_2_csv, m)?)?;
    m.add_function(wrap_pyfunction!(identify::straightness_fit, m)?)?;
    m.add_class::<thermal::ThermalModel>()?;
    m.add_function(wrap_pyfunction!(thermal::thermal_fit, m)?)?;
    m.add_function(wrap_pyfunction!(mirror::mirror, m)?)?;
    m.add_function(wrap_pyfunction!(ballbar::ballbar_predict, m)?)?;
    m.add_function(wrap_pyfunction!(ballbar::ballbar_fit, m)?)?;
    m.add_function(wrap_pyfunction!(probe::probe_fit, m)?)?;
    m.add_function(wrap_pyfunction!(probe::probe_plan, m)?)?;
    m.add_function(wrap_pyfunction!(request::options, m)?)?;
    Ok(())
}
