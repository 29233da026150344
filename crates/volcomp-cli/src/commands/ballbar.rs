//! `volcomp ballbar`: the circular test of ISO 230-4 (docs/ballbar.md).
//! `predict` gives the trace of a map (and of a compensated test program),
//! `fit` the figures and causes of a trace file, `map` the quick model
//! from traces in three planes. Parse, call the library, render.

use crate::options::Options;
use crate::output::{check, CliError, OutputPlan, Staged};
use clap::{Args, Subcommand};
use std::io::Write;
use std::path::{Path, PathBuf};
use volcomp_core::ballbar::report;
use volcomp_core::ballbar::trace as ballbar_trace;
use volcomp_core::request::ballbar::report_html;
use volcomp_core::request::{BallbarFitRequest, BallbarMapRequest, BallbarPredictRequest, Input};

/// The circular test (ISO 230-4): predict a trace from a map, fit a trace's causes, a quick map from three planes.
#[derive(Args, Debug)]
pub struct BallbarArgs {
    #[command(subcommand)]
    pub command: BallbarCommand,
}

#[derive(Subcommand, Debug)]
pub enum BallbarCommand {
    /// The trace a ballbar records on the machine of MAP, its ISO 230-4 figures, the test's program.
    Predict(PredictArgs),
    /// The ISO 230-4 figures of a trace file and the causes fitted to it.
    Fit(FitArgs),
    /// A quick map (scale, squareness, backlash) from one trace in each plane XY, YZ, ZX.
    Map(MapArgs),
}

/// What predict and fit show beside their text.
#[derive(Args, Debug)]
pub struct Shown {
    /// Write an HTML report (figures, polar plot; fit: the causes).
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
    /// A trace file drawn dashed beside this one in the report (before compensation, say).
    #[arg(long, value_name = "TRACE.csv")]
    pub before: Option<PathBuf>,
    /// Print the result as one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct PredictArgs {
    /// The error map (axis-table CSV or TOML model).
    pub map: PathBuf,
    #[command(flatten)]
    pub job: Options<BallbarPredictRequest>,
    /// Write the trace file (CSV, docs/ballbar.md, "Trace file").
    #[arg(short, long, value_name = "TRACE.csv")]
    pub output: Option<PathBuf>,
    /// Write the LinuxCNC program that runs the test.
    #[arg(long, value_name = "FILE.ngc")]
    pub write_program: Option<PathBuf>,
    #[command(flatten)]
    pub shown: Shown,
}

#[derive(Args, Debug)]
pub struct FitArgs {
    /// The trace file.
    pub trace: PathBuf,
    #[command(flatten)]
    pub job: Options<BallbarFitRequest>,
    /// Write what no cause explains as a trace file.
    #[arg(long, value_name = "TRACE.csv")]
    pub residual: Option<PathBuf>,
    #[command(flatten)]
    pub shown: Shown,
}

#[derive(Args, Debug)]
pub struct MapArgs {
    /// The trace files, one per plane.
    #[arg(required = true, num_args = 3)]
    pub traces: Vec<PathBuf>,
    #[command(flatten)]
    pub job: Options<BallbarMapRequest>,
    /// The quick map (axis-table CSV).
    #[arg(short, long, value_name = "MAP.csv")]
    pub output: PathBuf,
}

pub fn run(a: BallbarArgs) -> Result<(), CliError> {
    match a.command {
        BallbarCommand::Predict(a) => predict(a),
        BallbarCommand::Fit(a) => fit(a),
        BallbarCommand::Map(a) => map(a),
    }
}

fn read(path: &Path, role: &str) -> Result<String, CliError> {
    volcomp_core::io::inputs::read_to_string(path, role)
        .map_err(|e| CliError::Io(path.to_path_buf(), e))
}

fn print(lines: &[String]) -> Result<(), CliError> {
    let text = lines.join("\n") + "\n";
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(CliError::Stdout)
}

fn predict(a: PredictArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map)
        .input_opt("--program", a.job.program.as_ref().and_then(|p| p.path()));
    plan.input_opt("--before", a.shown.before.as_ref())
        .output_opt("-o", a.output.as_ref());
    plan.output_opt("--write-program", a.write_program.as_ref())
        .output_opt("--report-html", a.shown.report_html.as_ref());
    check(&plan)?;
    let p = a.job.run(&a.map)?;
    let mut staged = Staged::new();
    if let Some(o) = &a.output {
        staged.write_bytes(o, ballbar_trace::write(&p.trace).as_bytes())?;
    }
    if let Some(o) = &a.write_program {
        staged.write_bytes(o, p.program.as_bytes())?;
    }
    if let Some(o) = &a.shown.report_html {
        let text = report_html(
            "volcomp ballbar predict",
            "predicted",
            &p.trace,
            &p.figures,
            a.shown.before.clone().map(Input::File).as_ref(),
            None,
        )?;
        staged.write_bytes(o, text.as_bytes())?;
    }
    staged.commit()?;
    match a.shown.json {
        true => print(&[serde_json::to_string(&p.figures)?]),
        false => print(&report::figures_lines(&p.figures)),
    }
}

fn fit(a: FitArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("TRACE", &a.trace)
        .input_opt("--before", a.shown.before.as_ref());
    plan.output_opt("--residual", a.residual.as_ref())
        .output_opt("--report-html", a.shown.report_html.as_ref());
    check(&plan)?;
    let (name, text) = (a.trace.display().to_string(), read(&a.trace, "TRACE")?);
    let f = a.job.run(&text, &name)?;
    let mut staged = Staged::new();
    if let Some(o) = &a.residual {
        staged.write_bytes(o, ballbar_trace::write(&f.residual).as_bytes())?;
    }
    if let Some(o) = &a.shown.report_html {
        let trace = a.job.trace(&text, &name)?;
        let text = report_html(
            "volcomp ballbar fit",
            &name,
            &trace,
            &f.figures,
            a.shown.before.clone().map(Input::File).as_ref(),
            Some(&f),
        )?;
        staged.write_bytes(o, text.as_bytes())?;
    }
    staged.commit()?;
    match a.shown.json {
        true => print(&[serde_json::to_string(&f)?]),
        false => print(&report::fit_lines(&f)),
    }
}

fn map(a: MapArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for t in &a.traces {
        plan.input("TRACE", t);
    }
    plan.output("-o", &a.output);
    check(&plan)?;
    let traces: Vec<(String, String)> = a
        .traces
        .iter()
        .map(|t| Ok((read(t, "TRACE")?, t.display().to_string())))
        .collect::<Result<_, CliError>>()?;
    let q = a.job.run(&traces)?;
    let mut staged = Staged::new();
    staged.write_bytes(&a.output, q.csv.as_bytes())?;
    staged.commit()?;
    print(&report::quick_lines(&q.model))
}
