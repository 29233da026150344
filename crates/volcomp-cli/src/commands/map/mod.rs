//! `volcomp map`: evaluate, convert, plot and import error maps — the
//! axis tables (docs/design.md), the 21-component kinematic model (ISO 230-1),
//! LinuxCNC compensation files and ISO 230-2 positioning tests.
//!
//! The formats and the computations are the library's (`volcomp_core::io`,
//! `volcomp_core::model`); this module turns flags into options, calls it and
//! prints.

mod args;
mod eval;
mod export;
mod iso;

pub use args::*;

use crate::commands::parse_triple;
use crate::output::{check, write_atomically, CliError, OutputPlan};
use crate::plot::{write_charts, Chart, Series};
use std::io::Write;
use std::path::Path;
use volcomp_core::example::kinematic as kinematic_example;
use volcomp_core::identify::iso230_2;
use volcomp_core::io::grid::{self, GridError};
use volcomp_core::io::linuxcnc_comp::{self, Positioning};
use volcomp_core::io::model_file;
use volcomp_core::io::{load_model, LoadOptions, LoadedModel};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_core::model::kinematic::{Form, KinematicModel};
use volcomp_core::model::topology::Topology;
use volcomp_core::model::{parse_directions, Directions, ErrorModel};
use volcomp_core::report::map::component_charts;
use volcomp_core::request::{self, MapToolRequest, MapView};
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// Loads a map through the library's one model loader (axis-table CSV,
/// 21-component model TOML, straightness model TOML).
pub fn load(path: &Path, clamp: bool) -> Result<LoadedModel, CliError> {
    Ok(load_model(path, &LoadOptions { clamp })?)
}

/// The maps `volcomp map` works on.
enum Map {
    Tables(Box<AxisTableMap>),
    Kinematic(Box<KinematicModel>),
}

impl Map {
    fn view(&self) -> MapView<'_> {
        match self {
            Map::Tables(m) => MapView::Tables(m),
            Map::Kinematic(m) => MapView::Kinematic(m),
        }
    }

    fn model(&self) -> &dyn ErrorModel {
        self.view().model()
    }
}

/// Loads axis tables or a 21-component model; `volcomp map` takes no other kind.
fn load_map(path: &Path, clamp: bool) -> Result<Map, CliError> {
    match load(path, clamp)? {
        LoadedModel::AxisTables(m) => Ok(Map::Tables(m)),
        LoadedModel::Kinematic(m) => Ok(Map::Kinematic(m)),
        other => Err(CliError::Message(format!(
            "{}: `volcomp map` reads axis tables and 21-component models, not a {} model; use it with compensate or simulate",
            path.display(),
            other.kind().name()
        ))),
    }
}

pub fn run(cmd: MapCommand) -> Result<(), CliError> {
    match cmd.command {
        MapSub::Eval(a) => eval::eval(a),
        MapSub::Convert(a) => convert(a),
        MapSub::Export(a) => export::export(*a),
        MapSub::Plot(a) => plot(a),
        MapSub::ImportLinuxcnc(a) => import_linuxcnc(a),
        MapSub::Import(a) => import_params(a),
        MapSub::Build(a) => build_model(a),
        MapSub::Iso230_2(a) => iso230_2(a),
        MapSub::Example(a) => example(a),
    }
}

/// `--direction`, read by the library.
fn directions(text: &str) -> Result<Directions, CliError> {
    parse_directions(text).map_err(|e| {
        CliError::Message(format!(
            "--direction expects forward, reverse or one letter per axis (f/r or +/-) like frf; got `{}`",
            e.text
        ))
    })
}

/// `--chain`, read by the library; the seed chain when not given.
fn chain(text: Option<&str>) -> Result<Topology, CliError> {
    match text {
        Some(c) => c
            .parse::<Topology>()
            .map_err(|e| CliError::Message(format!("--chain: {e}"))),
        None => Ok(Topology::SEED),
    }
}

fn positive_step(step: Option<f64>) -> Result<Option<f64>, CliError> {
    match step {
        Some(s) if !(s.is_finite() && s > 0.0) => Err(CliError::Message(format!(
            "--step must be a positive length in mm; got {s}"
        ))),
        other => Ok(other),
    }
}

/// Writes `text` to `path` atomically, refusing to overwrite `inputs`.
fn write_text(path: &Path, inputs: &[&Path], text: &str) -> Result<(), CliError> {
    write_atomically(path, inputs, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| CliError::Io(path.to_path_buf(), e))
    })
}

/// The files a model written as `out` (.toml) consists of: it and its
/// tables beside it (same stem, .csv).
fn model_outputs(plan: &mut OutputPlan, flag: &str, out: &Path) {
    plan.output(flag, out);
    let is_toml = out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_toml {
        plan.output(
            format!("{flag} (its tables beside it)"),
            out.with_extension("csv"),
        );
    }
}

/// Writes `model` as `out` (TOML) and its tables beside it (same stem, .csv).
fn write_model(
    model: &KinematicModel,
    out: &Path,
    inputs: &[&Path],
    description: Option<&str>,
) -> Result<(), CliError> {
    let files = model_file::model_files(model, out, description)?;
    write_text(&files.csv_path, inputs, &files.csv)?;
    write_text(out, inputs, &files.toml)?;
    crate::note!(
        "volcomp: wrote {} and {}",
        out.display(),
        files.csv_path.display()
    );
    Ok(())
}

fn convert(a: ConvertArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map);
    match a.to {
        ConvertTarget::Linuxcnc => {
            for axis in AXES {
                let name = format!("{}.comp", axis.to_ascii_lowercase());
                plan.output(format!("-o (its {name})"), a.output.join(&name));
            }
        }
        ConvertTarget::Model => model_outputs(&mut plan, "-o", &a.output),
        _ => {
            plan.output("-o", &a.output);
        }
    }
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let form = a.tool.form()?;
    match a.to {
        ConvertTarget::AxisTable => {
            let Map::Kinematic(m) = &map else {
                return Err(CliError::Message(format!(
                    "{} already is an axis-table map",
                    a.map.display()
                )));
            };
            let mut m = (**m).clone();
            m.form = form;
            let Some(tool) = a.tool.offset()? else {
                return Err(CliError::Message("axis tables hold the deviation for one tool: pass --tool-length MM (or --tool-offset X,Y,Z), e.g. the length of the tool the program uses".into()));
            };
            let reference = match (&a.at, m.shared_measuring().0) {
                (Some(t), _) => parse_triple(t, "--at")?,
                (None, Some(p)) => p,
                (None, None) => return Err(CliError::Message("the model's axes were measured along different lines: pass --at X,Y,Z, the position whose three lines the axis tables should reproduce (e.g. the middle of the part)".into())),
            };
            let tables = m.to_axis_tables(reference, tool, form)?;
            let worst = m.largest_difference_um(tool, &tables)?;
            write_text(&a.output, &[&a.map], &tables.to_csv())?;
            crate::note!(
                "volcomp: wrote {} for tool length offset ({}, {}, {}) mm, exact on the lines through ({}, {}, {}) mm; elsewhere it differs from the model by up to {worst:.3} µm (the Abbe cross terms an axis-table map cannot hold)",
                a.output.display(), tool.x, tool.y, tool.z, reference.x, reference.y, reference.z
            );
            Ok(())
        }
        ConvertTarget::Grid => {
            let step = positive_step(a.step)?.unwrap_or(25.0);
            let s = directions(&a.direction)?;
            let tool = a.tool.offset()?.unwrap_or(Vec3::ZERO);
            let name = a.map.display().to_string();
            let (text, count) =
                grid::grid_csv(map.model(), &name, tool, s, step).map_err(|e| match e {
                    GridError::TooManyPoints { step_mm, points } => CliError::Message(format!(
                        "a {step_mm} mm grid over this range has {points} points; choose a larger --step"
                    )),
                    other => other.into(),
                })?;
            write_text(&a.output, &[&a.map], &text)?;
            crate::note!("volcomp: wrote {} ({count} points)", a.output.display());
            Ok(())
        }
        ConvertTarget::Linuxcnc => convert_linuxcnc(&a, &map, form),
        ConvertTarget::Model => {
            let model = match map {
                Map::Tables(t) => {
                    KinematicModel::from_axis_tables(t.as_ref(), chain(a.chain.as_deref())?)
                }
                Map::Kinematic(m) => *m,
            };
            write_model(&model, &a.output, &[&a.map], None)
        }
    }
}

/// The positioning tables `E_aa` of a map: the axis tables' own, or a
/// 21-component model's as measured (or at `--at` for the tool).
fn positioning_tables(
    map: &Map,
    at: Option<&str>,
    tool: &MapToolRequest,
    form: Form,
) -> Result<[Positioning; 3], CliError> {
    let (at, tool) = match map {
        Map::Tables(_) => (None, None),
        Map::Kinematic(_) => {
            let tool = tool.offset()?;
            (at.map(|t| parse_triple(t, "--at")).transpose()?, tool)
        }
    };
    Ok(request::positioning_tables(map.view(), at, tool, form)?)
}

fn convert_linuxcnc(a: &ConvertArgs, map: &Map, form: Form) -> Result<(), CliError> {
    use volcomp_core::io::controllers::{table_error, ControllerCorrection, Format};
    let (ty, units) = a.comp.get()?;
    let original = positioning_tables(map, a.at.as_deref(), &a.tool, form)?;
    let step = positive_step(a.step)?;
    let tables = match step {
        Some(step) => original.clone().map(|p| p.resample(step)),
        None => original.clone(),
    };
    let mut texts = Vec::new();
    let mut applied = ControllerCorrection::empty(Format::Linuxcnc);
    for (k, p) in tables.iter().enumerate() {
        let text = linuxcnc_comp::write(p, ty, units).map_err(|m| {
            CliError::Message(format!(
                "axis {}: {m}; pass --step MM to resample the table (linear interpolation) at a spacing LinuxCNC can hold",
                AXES[k]
            ))
        })?;
        applied.axes[k] = Some(linuxcnc_comp::parse(&text, "comp", ty, units)?);
        texts.push(text);
    }
    // How far the written tables lie from the map, checked before writing.
    if !(a.max_table_error_um.is_finite() && a.max_table_error_um > 0.0) {
        return Err(CliError::Message(format!(
            "--max-table-error-um must be positive; got {}",
            a.max_table_error_um
        )));
    }
    let err = table_error::table_error(
        &original.map(Some),
        &applied,
        [table_error::Holds::BothDirections; 3],
        None,
    );
    table_error::check("linuxcnc", &err, 0.0, step, a.max_table_error_um)?;
    std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
    let mut names = Vec::new();
    for (k, text) in texts.iter().enumerate() {
        let path = a
            .output
            .join(format!("{}.comp", AXES[k].to_ascii_lowercase()));
        write_text(&path, &[&a.map], text)?;
        names.push(path);
    }
    crate::note!(
        "volcomp: the comp files lie at most {} µm from the map's positioning errors (checked at every point of both tables); --max-table-error-um allows {}",
        table_error::um(err.max_um),
        table_error::um(a.max_table_error_um)
    );
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    writeln!(out, "# LinuxCNC INI lines (joints 0, 1, 2 = X, Y, Z with trivkins); remove BACKLASH, the comp files hold the reversal").map_err(CliError::Stdout)?;
    for (k, p) in names.iter().enumerate() {
        writeln!(
            out,
            "[JOINT_{k}]\nCOMP_FILE = {}\nCOMP_FILE_TYPE = {}",
            p.display(),
            ty.number()
        )
        .map_err(CliError::Stdout)?;
    }
    Ok(())
}

fn plot(a: PlotArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map).output("-o", &a.output);
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let name = a
        .map
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| a.map.display().to_string());
    let charts = match &map {
        Map::Tables(m) => component_charts::tables(&name, m),
        Map::Kinematic(m) => component_charts::kinematic(&name, m),
    };
    let is_html = a
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("html"));
    if is_html {
        let mut inputs = vec![volcomp_core::report::InputFile::read("map", &a.map)?];
        if let Map::Tables(_) = &map {
            inputs[0].role = "map (axis tables)".into();
        }
        let doc = volcomp_core::report::Document {
            title: format!("volcomp error map report: {name}"),
            facts: vec![
                ("command".into(), super::compensate::command_line()),
                ("volcomp".into(), env!("CARGO_PKG_VERSION").into()),
                ("date (UTC)".into(), volcomp_core::io::provenance::now_utc()),
            ],
            inputs,
            sections: volcomp_core::report::map::sections(&charts),
            ..Default::default()
        };
        write_text(&a.output, &[&a.map], &doc.to_html())?;
    } else {
        let drawn: Vec<Chart> = charts
            .iter()
            .map(|c| Chart {
                title: c.title.clone(),
                x_label: c.x_label.clone(),
                y_label: c.y_label.clone(),
                series: c
                    .series
                    .iter()
                    .map(|s| Series::line(s.name.clone(), s.points.clone()))
                    .collect(),
                ..Chart::default()
            })
            .collect();
        write_charts(&drawn, &a.output)?;
    }
    crate::note!(
        "volcomp: wrote {} ({} charts)",
        a.output.display(),
        charts.len()
    );
    Ok(())
}

fn import_linuxcnc(a: ImportArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("--x", &a.x)
        .input("--y", &a.y)
        .input("--z", &a.z);
    model_outputs(&mut plan, "-o", &a.output);
    check(&plan)?;
    let (ty, units) = a.comp.get()?;
    let p = [
        linuxcnc_comp::read(&a.x, ty, units)?,
        linuxcnc_comp::read(&a.y, ty, units)?,
        linuxcnc_comp::read(&a.z, ty, units)?,
    ];
    let tables = AxisTableMap::from_positioning(&p);
    let inputs: [&Path; 3] = [&a.x, &a.y, &a.z];
    let ext = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("csv") => {
            let text = linuxcnc_comp::imported_tables_csv(&tables, ty, units);
            write_text(&a.output, &inputs, &text)?;
            crate::note!("volcomp: wrote {}", a.output.display());
            Ok(())
        }
        Some("toml") => {
            let model = KinematicModel::from_axis_tables(&tables, chain(a.chain.as_deref())?);
            write_model(
                &model,
                &a.output,
                &inputs,
                Some("imported from LinuxCNC comp files: positioning errors only"),
            )
        }
        _ => Err(CliError::Message(format!(
            "{}: write an axis-table .csv or a 21-component .toml",
            a.output.display()
        ))),
    }
}

fn build_model(a: BuildArgs) -> Result<(), CliError> {
    use volcomp_core::identify::build;
    let read = |p: &Path| -> Result<String, CliError> {
        let bytes = volcomp_core::io::inputs::read(p, "an input")
            .map_err(|e| CliError::Io(p.to_path_buf(), e))?;
        Ok(volcomp_core::io::table::utf8(&bytes, &p.display().to_string())?.to_string())
    };
    let plan_text = read(&a.plan)?;
    let plan_name = a.plan.display().to_string();
    let (plan, runs) = build::parse_plan(&plan_text, &plan_name)?;
    let dir = a.plan.parent().unwrap_or(Path::new("")).to_path_buf();
    let paths: Vec<std::path::PathBuf> = runs.iter().map(|(_, f)| dir.join(f)).collect();
    let mut out_plan = OutputPlan::new();
    out_plan.input("PLAN", &a.plan);
    for (p, (c, _)) in paths.iter().zip(&runs) {
        out_plan.input(format!("the run of {c}"), p);
    }
    model_outputs(&mut out_plan, "-o", &a.output);
    check(&out_plan)?;
    let mut read_runs = Vec::new();
    for (p, (c, _)) in paths.iter().zip(&runs) {
        read_runs.push(build::read_run(c, &read(p)?, &p.display().to_string())?);
    }
    let (model, summary) = build::build(&plan, &read_runs, &plan_name)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    for l in summary.lines() {
        writeln!(out, "{l}").map_err(CliError::Stdout)?;
    }
    if let Some(d) = a.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|e| CliError::Io(d.to_path_buf(), e))?;
    }
    let mut inputs: Vec<&Path> = vec![&a.plan];
    inputs.extend(paths.iter().map(|p| p.as_path()));
    write_model(
        &model,
        &a.output,
        &inputs,
        Some(&format!("built from the runs of {plan_name}")),
    )
}

fn import_params(a: ImportParamsArgs) -> Result<(), CliError> {
    use volcomp_core::io::exchange;
    let mut plan = OutputPlan::new();
    plan.input("FILE", &a.file);
    model_outputs(&mut plan, "-o", &a.output);
    check(&plan)?;
    let bytes = volcomp_core::io::inputs::read(&a.file, "FILE")
        .map_err(|e| CliError::Io(a.file.clone(), e))?;
    let name = a.file.display().to_string();
    let text = volcomp_core::io::table::utf8(&bytes, &name)?;
    let params = match a.from {
        ParamsFormat::IsgCsv => exchange::parse_isg_csv(text, &name)?,
        ParamsFormat::Etalon => exchange::parse_etalon(text, &name)?,
    };
    let imported = exchange::to_model(&params, &name, text, chain(a.chain.as_deref())?)?;
    if let Some(dir) = a.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Io(dir.to_path_buf(), e))?;
    }
    if !imported.assumed_zero.is_empty() {
        eprintln!(
            "volcomp: not in the file, taken as zero: {}",
            imported.assumed_zero.join(", ")
        );
    }
    if !imported.not_used.is_empty() {
        eprintln!(
            "volcomp: not used (rotary axes or zero): {}",
            imported.not_used.join(", ")
        );
    }
    write_model(
        &imported.model,
        &a.output,
        &[&a.file],
        Some(&format!(
            "imported from {} ({})",
            name,
            match a.from {
                ParamsFormat::IsgCsv => "ISG CSV",
                ParamsFormat::Etalon => "Etalon exchange format",
            }
        )),
    )
}

fn iso230_2(a: IsoArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("RUNS", &a.runs)
        .output_opt("-o", a.output.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    let text = volcomp_core::io::inputs::read_to_string(&a.runs, "RUNS")
        .map_err(|e| CliError::Io(a.runs.clone(), e))?;
    let r = iso230_2::from_csv(&text, &a.runs.display().to_string())?;
    if let Some(path) = &a.report_html {
        let axis = a.axis.map_or("not given (--axis)".to_string(), |x| {
            AXES[x.index()].to_string()
        });
        let doc = volcomp_core::report::Document {
            title: format!("volcomp positioning test report: {}", a.runs.display()),
            facts: vec![
                ("command".into(), super::compensate::command_line()),
                ("volcomp".into(), env!("CARGO_PKG_VERSION").into()),
                ("date (UTC)".into(), volcomp_core::io::provenance::now_utc()),
                ("axis".into(), axis),
                (
                    "evaluation".into(),
                    "ISO 230-2:2014, clause 3 (bidirectional)".into(),
                ),
            ],
            inputs: vec![volcomp_core::report::InputFile::from_bytes(
                "runs",
                a.runs.display().to_string(),
                text.as_bytes(),
            )],
            sections: volcomp_core::report::iso230_2::sections(&r),
            ..Default::default()
        };
        write_text(path, &[&a.runs], &doc.to_html())?;
        crate::note!("volcomp: wrote {}", path.display());
    }
    if a.json {
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        writeln!(out, "{}", serde_json::to_string(&r)?).map_err(CliError::Stdout)?;
    } else {
        iso::print_iso230_2(&a.runs, &r)?;
    }
    if let (Some(path), Some(axis)) = (&a.output, a.axis) {
        let k = axis.index();
        let p = r.positioning();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let text = match ext.as_deref() {
            Some("comp") => {
                let (ty, units) = a.comp.get()?;
                linuxcnc_comp::write(&p, ty, units)?
            }
            Some("csv") => model_file::positioning_rows_csv(
                &p,
                Axis::ALL[k],
                &format!(
                    "ISO 230-2 mean unidirectional deviations of {} from {}: positioning only",
                    AXES[k],
                    a.runs.display()
                ),
            ),
            _ => return Err(CliError::Message(format!("{}: write the positioning table as .csv (21-component table rows) or .comp (LinuxCNC)", path.display()))),
        };
        write_text(path, &[&a.runs], &text)?;
        crate::note!("volcomp: wrote {}", path.display());
    }
    Ok(())
}

fn example(a: ExampleArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
    let (toml, csv) = kinematic_example::example_files("example21.csv");
    let csv_path = a.output.join("example21.csv");
    let toml_path = a.output.join("example21.toml");
    write_text(&csv_path, &[], &csv)?;
    write_text(&toml_path, &[], &toml)?;
    crate::note!(
        "volcomp: wrote {} and {}",
        toml_path.display(),
        csv_path.display()
    );
    Ok(())
}
