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

pub use args::*;

use crate::commands::compensate::command_line;
use crate::commands::parse_triple;
use crate::options::flags;
use crate::output::{check, write_file, CliError, OutputPlan};
use crate::plot::{charts, write_charts};
use std::io::Write;
use std::path::{Path, PathBuf};
use volcomp_core::example::kinematic as kinematic_example;
use volcomp_core::io::{load_model, LoadOptions, LoadedModel};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_core::model::kinematic::KinematicModel;
use volcomp_core::model::topology::Topology;
use volcomp_core::model::{parse_directions, Directions, ErrorModel};
use volcomp_core::request::{
    self, map_charts, map_file_name, map_plot_report, model_outputs, read_text, ConvertTo,
    Iso230_2Job, JobOutput, MapBuild, MapConvert, MapView,
};

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

/// Writes `text` to `path` atomically, refusing to overwrite `inputs`.
fn write_text(path: &Path, inputs: &[&Path], text: &str) -> Result<(), CliError> {
    write_file(path, inputs, text.as_bytes())
}

/// Declares the files of a job as the outputs of `flag`.
fn plan_outputs(plan: &mut OutputPlan, flag: &str, files: Vec<(String, PathBuf)>) {
    for (what, path) in files {
        match what.as_str() {
            "" => plan.output(flag, path),
            what => plan.output(format!("{flag} {what}"), path),
        };
    }
}

/// Says and writes what a job gives: its standard output and warnings,
/// its folders and files (never over `inputs`), then its notes.
fn deliver(job: JobOutput, inputs: &[&Path]) -> Result<(), CliError> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    for line in &job.stdout {
        writeln!(out, "{line}").map_err(CliError::Stdout)?;
    }
    drop(out);
    for w in &job.warnings {
        eprintln!("{w}");
    }
    for d in &job.dirs {
        std::fs::create_dir_all(d).map_err(|e| CliError::Io(d.clone(), e))?;
    }
    for f in &job.files {
        write_text(&f.path, inputs, &f.text)?;
    }
    for n in &job.notes {
        crate::note!("{}", flags(n));
    }
    Ok(())
}

fn convert(a: ConvertArgs) -> Result<(), CliError> {
    let at = a.at.as_deref().map(|t| parse_triple(t, "--at")).transpose();
    let job = MapConvert {
        to: match a.to {
            ConvertTarget::AxisTable => ConvertTo::AxisTable,
            ConvertTarget::Grid => ConvertTo::Grid,
            ConvertTarget::Linuxcnc => ConvertTo::Linuxcnc,
            ConvertTarget::Model => ConvertTo::Model,
        },
        output: &a.output,
        at: None,
        tool: &a.tool,
        step_mm: a.step,
        directions: volcomp_core::model::ALL_FORWARD,
        comp: &a.comp,
        max_table_error_um: a.max_table_error_um,
        chain: Topology::SEED,
    };
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map);
    plan_outputs(&mut plan, "-o", job.outputs());
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let job = MapConvert {
        at: match (job.to, &map) {
            (ConvertTo::AxisTable | ConvertTo::Linuxcnc, Map::Kinematic(_)) => at?,
            _ => None,
        },
        directions: match job.to {
            ConvertTo::Grid => directions(&a.direction)?,
            _ => job.directions,
        },
        chain: match (job.to, &map) {
            (ConvertTo::Model, Map::Tables(_)) => chain(a.chain.as_deref())?,
            _ => Topology::SEED,
        },
        ..job
    };
    let out = job.run(map.view(), &a.map.display().to_string())?;
    deliver(out, &[&a.map])
}

fn plot(a: PlotArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map).output("-o", &a.output);
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let is_html = a
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("html"));
    let count = if is_html {
        let (html, count) = map_plot_report(map.view(), &a.map, &command_line())?;
        write_text(&a.output, &[&a.map], &html)?;
        count
    } else {
        let charts = map_charts(map.view(), &map_file_name(&a.map));
        let drawn = charts::component_line_charts(&charts);
        write_charts(&drawn, &a.output)?;
        charts.len()
    };
    crate::note!("volcomp: wrote {} ({count} charts)", a.output.display());
    Ok(())
}

fn import_linuxcnc(a: ImportArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("--x", &a.x)
        .input("--y", &a.y)
        .input("--z", &a.z);
    plan_outputs(&mut plan, "-o", model_outputs(&a.output));
    check(&plan)?;
    let inputs: [&Path; 3] = [&a.x, &a.y, &a.z];
    let is_toml = a
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let chain = match is_toml {
        true => chain(a.chain.as_deref())?,
        false => Topology::SEED,
    };
    deliver(
        request::import_linuxcnc(inputs, &a.comp, &a.output, chain)?,
        &inputs,
    )
}

fn build_model(a: BuildArgs) -> Result<(), CliError> {
    let text = read_text(&a.plan, "an input")?;
    let job = MapBuild::new(&text, &a.plan)?;
    let mut plan = OutputPlan::new();
    plan.input("PLAN", &a.plan);
    for (c, p) in job.runs() {
        plan.input(format!("the run of {c}"), p);
    }
    plan_outputs(&mut plan, "-o", model_outputs(&a.output));
    check(&plan)?;
    let out = job.run(&a.output)?;
    let mut inputs: Vec<&Path> = vec![&a.plan];
    inputs.extend(job.runs().iter().map(|(_, p)| p.as_path()));
    deliver(out, &inputs)
}

fn import_params(a: ImportParamsArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("FILE", &a.file);
    plan_outputs(&mut plan, "-o", model_outputs(&a.output));
    check(&plan)?;
    let text = read_text(&a.file, "FILE")?;
    let from = match a.from {
        ParamsFormat::IsgCsv => request::ParamsFormat::IsgCsv,
        ParamsFormat::Etalon => request::ParamsFormat::Etalon,
    };
    let chain = chain(a.chain.as_deref())?;
    let job = request::import_params(&text, &a.file, from, &a.output, chain)?;
    deliver(job, &[&a.file])
}

fn iso230_2(a: IsoArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("RUNS", &a.runs)
        .output_opt("-o", a.output.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    let text = volcomp_core::io::inputs::read_to_string(&a.runs, "RUNS")
        .map_err(|e| CliError::Io(a.runs.clone(), e))?;
    let command = command_line();
    let job = Iso230_2Job {
        runs: &a.runs,
        axis: a.axis,
        output: a.output.as_deref(),
        comp: &a.comp,
        report_html: a.report_html.as_deref(),
        command: &command,
    };
    let (r, mut out) = job.run(&text)?;
    if a.json {
        out.stdout = vec![serde_json::to_string(&r)?];
    }
    deliver(out, &[&a.runs])
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
