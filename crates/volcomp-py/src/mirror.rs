//! Free-form surfaces: mirror compensation of a ball-end finishing program
//! from on-machine probing (docs/mirror.md, [Mirror study]).

use crate::errors::{bad_input, IntoPy};
use crate::inputs::{machine, source, MachineArgs};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use volcomp_core::compensate::{file_name, survey_style};
use volcomp_core::io::provenance::{iso8601_utc, sha256_hex, HeaderWriter, ProgramHeader};
use volcomp_core::surface::bspline::Parameterization;
use volcomp_core::surface::mirror::report::{
    compensated_surface_text, header_method, header_options, summary_json, FinishingJson,
    RunInputs, SurfaceFiles,
};
use volcomp_core::surface::mirror::{
    compensate_finishing, mirror as mirror_method, program_frame_offset, read_nominal,
    read_probe_points, BallTool, ClPoint, CompensatedSurface, FitMethod, MaterialSide,
    MirrorOptions, NominalFormat, SurfaceModel,
};

fn positive(v: f64, name: &str, what: &str) -> PyResult<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad_input(format!("{name} must be {what}; got {v}")))
    }
}

/// Mirror compensation (docs/mirror.md): the deviation field of the
/// semi-finished surface from `measured` probe points against the
/// `nominal` surface, and, with `finishing` and `tool_radius_mm`, the
/// finishing program compensated for it.
///
/// `nominal`: a B-spline surface (TOML) or a grid of points (CSV), as text
/// (then `nominal_format` "bspline" or "grid" says which) or a pathlib.Path
/// (its extension says). `measured`: the probe points CSV. `stock_mm`: the
/// allowance the semi-finishing pass left. Options as `volcomp surface
/// mirror`: `material` ("below", "above", "normal-out", "normal-in"),
/// `probe_radius_mm`, `max_error_mm`, `fit` ("least-squares" with
/// `tolerance_um`, or "interpolate"), `grid_params` ("chord-length",
/// "centripetal", "uniform"), `grid_size`; for the program: `cl_point`
/// ("tip", "center"), `contact_tolerance_mm`, `segment_length_mm` (None:
/// no split), `decimals`, `trace`, the machine (`setup`, `work_offset_mm`,
/// ...), `allow_recompensate`, `date_utc`.
///
/// Returns a dict: `summary` (the CLI's `--json` object: statistics
/// before and predicted after, the fit, the finishing run), `program` (the
/// compensated finishing program's text, or None), `surface_grid_csv` and
/// `surface_bspline_toml` (the compensated surface's files' text),
/// `predicted_worse` (the leave-one-out prediction says compensating is
/// worse than not).
#[pyfunction]
#[pyo3(signature = (nominal, measured, *, stock_mm, nominal_format = None, material = "below", probe_radius_mm = None, max_error_mm = 0.1, fit = "least-squares", tolerance_um = None, grid_params = "chord-length", grid_size = 41, finishing = None, tool_radius_mm = None, cl_point = "tip", contact_tolerance_mm = 0.02, segment_length_mm = Some(2.0), decimals = None, trace = true, setup = None, work_offset_mm = None, absolute_arc_centers = false, accept_k0 = false, allow_no_program_end = false, allow_recompensate = false, date_utc = None))]
#[allow(clippy::too_many_arguments)]
pub fn mirror<'py>(
    py: Python<'py>,
    nominal: &Bound<'py, PyAny>,
    measured: &Bound<'py, PyAny>,
    stock_mm: f64,
    nominal_format: Option<&str>,
    material: &str,
    probe_radius_mm: Option<f64>,
    max_error_mm: f64,
    fit: &str,
    tolerance_um: Option<f64>,
    grid_params: &str,
    grid_size: usize,
    finishing: Option<&Bound<'py, PyAny>>,
    tool_radius_mm: Option<f64>,
    cl_point: &str,
    contact_tolerance_mm: f64,
    segment_length_mm: Option<f64>,
    decimals: Option<u8>,
    trace: bool,
    setup: Option<&Bound<'py, PyAny>>,
    work_offset_mm: Option<Vec<f64>>,
    absolute_arc_centers: bool,
    accept_k0: bool,
    allow_no_program_end: bool,
    allow_recompensate: bool,
    date_utc: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    positive(stock_mm, "stock_mm", "a positive length in mm")?;
    positive(max_error_mm, "max_error_mm", "a positive length in mm")?;
    positive(
        contact_tolerance_mm,
        "contact_tolerance_mm",
        "a positive length in mm",
    )?;
    if let Some(t) = tolerance_um {
        positive(t, "tolerance_um", "a positive number of µm")?;
    }
    if let Some(l) = segment_length_mm {
        positive(l, "segment_length_mm", "a positive length in mm")?;
    }
    if let Some(r) = probe_radius_mm {
        if !(r.is_finite() && r >= 0.0) {
            return Err(bad_input(format!(
                "probe_radius_mm must be a length ≥ 0 in mm; got {r}"
            )));
        }
    }
    if !(2..=1001).contains(&grid_size) {
        return Err(bad_input(format!(
            "grid_size must be 2 … 1001; got {grid_size}"
        )));
    }
    if decimals.is_some_and(|d| !(1..=9).contains(&d)) {
        return Err(bad_input("decimals must be 1 … 9"));
    }
    let side = match material {
        "below" => MaterialSide::Below,
        "above" => MaterialSide::Above,
        "normal-out" => MaterialSide::NormalOut,
        "normal-in" => MaterialSide::NormalIn,
        m => {
            return Err(bad_input(format!(
                "material must be \"below\", \"above\", \"normal-out\" or \"normal-in\"; got {m:?}"
            )))
        }
    };
    let params = match grid_params {
        "chord-length" => Parameterization::ChordLength,
        "centripetal" => Parameterization::Centripetal,
        "uniform" => Parameterization::Uniform,
        p => {
            return Err(bad_input(format!(
                "grid_params must be \"chord-length\", \"centripetal\" or \"uniform\"; got {p:?}"
            )))
        }
    };
    let fit = match fit {
        "least-squares" => FitMethod::LeastSquares { tolerance_um },
        "interpolate" => FitMethod::Interpolate,
        f => {
            return Err(bad_input(format!(
                "fit must be \"least-squares\" or \"interpolate\"; got {f:?}"
            )))
        }
    };
    let nom = source(nominal, "nominal", None)?;
    let format = match (nominal_format, &nom.path) {
        (Some("bspline"), _) => NominalFormat::BSplineToml,
        (Some("grid"), _) => NominalFormat::GridCsv,
        (Some(f), _) => {
            return Err(bad_input(format!(
                "nominal_format must be \"bspline\" or \"grid\"; got {f:?}"
            )))
        }
        (None, Some(p)) => NominalFormat::of_path(p).py_err()?,
        (None, None) => {
            return Err(bad_input(
                "nominal given as a file object: say its format with nominal_format=\"bspline\" (TOML) or \"grid\" (CSV)",
            ))
        }
    };
    let nom_text = String::from_utf8(nom.bytes.clone())
        .map_err(|_| bad_input(format!("{}: not UTF-8 text", nom.name)))?;
    let nominal = read_nominal(&nom_text, &nom.name, format, side, &params).py_err()?;
    let meas = source(measured, "measured", None)?;
    let meas_text = String::from_utf8(meas.bytes.clone())
        .map_err(|_| bad_input(format!("{}: not UTF-8 text", meas.name)))?;
    let probes = read_probe_points(&meas_text, &meas.name).py_err()?;
    let options = MirrorOptions {
        stock_mm,
        probe_radius_mm,
        max_error_mm,
        fit,
    };
    let result = py
        .detach(|| mirror_method(&nominal, &probes, &options, &meas.name))
        .py_err()?;
    let inputs = RunInputs {
        nominal: nom.name.clone(),
        measured: meas.name.clone(),
        stock_mm,
        probe_radius_mm,
    };
    let comp = CompensatedSurface {
        nominal: &nominal,
        field: &result.field,
    };
    let text = compensated_surface_text(&inputs, &comp, grid_size).py_err()?;
    let surface = SurfaceFiles {
        grid: "<surface_grid_csv>".into(),
        grid_nodes: text.grid_nodes,
        bspline: "<surface_bspline_toml>".into(),
        bspline_net: text.bspline_net,
        bspline_error_um: text.bspline_error_um,
    };
    let mut program = None;
    let mut finishing_json = None;
    match (finishing, tool_radius_mm) {
        (Some(f), Some(r)) => {
            positive(r, "tool_radius_mm", "the ball's radius in mm")?;
            let tool = BallTool {
                radius_mm: r,
                cl: match cl_point {
                    "tip" => ClPoint::Tip,
                    "center" => ClPoint::Centre,
                    c => {
                        return Err(bad_input(format!(
                            "cl_point must be \"tip\" or \"center\"; got {c:?}"
                        )))
                    }
                },
            };
            let m = machine(MachineArgs {
                setup,
                work_offset_mm,
                absolute_arc_centers,
                accept_k0,
                allow_no_program_end,
                chord_tolerance_mm: 1e-4,
            })?;
            let prog = source(f, "finishing", None)?;
            let frame = program_frame_offset(
                &mut m.setup.walker(prog.bytes.as_slice(), &prog.name),
                &prog.name,
            )
            .py_err()?;
            let model =
                SurfaceModel::new(&nominal, &result.field, tool, frame, contact_tolerance_mm)
                    .py_err()?;
            let head = &prog.bytes[..prog.bytes.len().min(1 << 16)];
            if !allow_recompensate {
                volcomp_core::compensate::refuse_if_compensated(head, &prog.name).py_err()?;
            }
            let style = survey_style(head);
            let header = ProgramHeader {
                version: env!("CARGO_PKG_VERSION").to_string(),
                files: vec![
                    (
                        "surf".into(),
                        file_or(&nom.path, "nominal"),
                        sha256_hex(&nom.bytes),
                    ),
                    (
                        "probes".into(),
                        file_or(&meas.path, "probes"),
                        sha256_hex(&meas.bytes),
                    ),
                ],
                setup_file: m.setup_file.as_deref().map(file_name),
                work_offset_note: m
                    .work_offset_given
                    .then(|| "G54 from work_offset_mm".to_string()),
                setup: m.setup.setup.clone(),
                method: header_method(false).into(),
                options: header_options(
                    stock_mm,
                    &tool,
                    &options.fit,
                    segment_length_mm,
                    contact_tolerance_mm,
                ),
                date_utc: date_utc.unwrap_or_else(now_utc),
            };
            let opts = volcomp_core::surface::mirror::FinishingOptions {
                segment_length_mm,
                decimals,
                trace_comments: trace,
                ..Default::default()
            };
            let mut out = Vec::new();
            let summary = py
                .detach(|| {
                    let mut walker = m.setup.walker(prog.bytes.as_slice(), &prog.name);
                    let mut w = HeaderWriter::new(&mut out, header.lines());
                    let s = compensate_finishing(
                        &mut walker,
                        &prog.name,
                        &style,
                        &model,
                        &opts,
                        &mut w,
                    )?;
                    w.finish()
                        .map_err(volcomp_core::error::CompensationError::Io)
                        .map_err(volcomp_core::surface::mirror::MirrorError::Program)?;
                    Ok::<_, volcomp_core::surface::mirror::MirrorError>(s)
                })
                .py_err()?;
            finishing_json = Some(FinishingJson::new("<program>", &summary));
            program = Some(String::from_utf8_lossy(&out).into_owned());
        }
        (Some(_), None) => {
            return Err(bad_input(
                "finishing needs tool_radius_mm: the ball's radius in mm",
            ))
        }
        _ => {}
    }
    let summary = summary_json(
        &inputs,
        &result,
        Some(&surface),
        finishing_json,
        None,
        false,
    );
    let json = serde_json::to_string(&summary).map_err(|e| bad_input(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item(
        "summary",
        py.import("json")?.call_method1("loads", (json,))?,
    )?;
    d.set_item("program", program)?;
    d.set_item("surface_grid_csv", text.grid_csv)?;
    d.set_item("surface_bspline_toml", text.bspline_toml)?;
    d.set_item("predicted_worse", result.compensation_predicted_worse())?;
    Ok(d)
}

fn file_or(path: &Option<std::path::PathBuf>, default: &str) -> String {
    path.as_deref()
        .map(file_name)
        .unwrap_or_else(|| default.to_string())
}

/// Now as ISO 8601 UTC, or `SOURCE_DATE_EPOCH` when set.
fn now_utc() -> String {
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
