//! `volcomp ballbar`: the circular test of ISO 230-4 (docs/ballbar.md).
//! `predict` gives the trace of a map (and of a compensated test program),
//! `fit` the figures and causes of a trace file, `map` the quick model
//! from traces in three planes. Parse, call the library, render.

use crate::options::Options;
use crate::output::{check, CliError, OutputPlan, Staged};
use clap::{Args, Subcommand};
use std::io::Write;
use std::path::{Path, PathBuf};
use volcomp_core::ballbar::{report, Figures, Trace};
use volcomp_core::io::ballbar_trace;
use volcomp_core::request::{BallbarFitRequest, BallbarMapRequest, BallbarPredictRequest};

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
    /// Write an HTML report (polar plot, figures).
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
    /// A trace file drawn dashed beside the prediction (before compensation, say).
    #[arg(long, value_name = "TRACE.csv")]
    pub before: Option<PathBuf>,
    /// Print the figures as one JSON object.
    #[arg(long)]
    pub json: bool,
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
    /// Write an HTML report (polar plot, figures, causes).
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
    /// A trace file drawn dashed beside this one (before compensation, say).
    #[arg(long, value_name = "TRACE.csv")]
    pub before: Option<PathBuf>,
    /// Print the figures and causes as one JSON object.
    #[arg(long)]
    pub json: bool,
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

/// The "before" trace and its figures, for the report's overlay.
fn before(path: &Option<PathBuf>) -> Result<Option<(Trace, Figures)>, CliError> {
    let Some(p) = path else { return Ok(None) };
    let trace =
        BallbarFitRequest::default().trace(&read(p, "--before")?, &p.display().to_string())?;
    let f = volcomp_core::ballbar::figures(&trace).ok_or_else(|| {
        CliError::Message(format!(
            "{}: the trace's circle is undetermined",
            p.display()
        ))
    })?;
    Ok(Some((trace, f)))
}

fn print(lines: &[String]) -> Result<(), CliError> {
    let text = lines.join("\n") + "\n";
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(CliError::Stdout)
}

fn predict(a: PredictArgs) -> Result<(), CliError> {
    let program = a.job.program.as_ref().and_then(|p| p.path());
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map)
        .input_opt("--program", program)
        .input_opt("--before", a.before.as_ref());
    plan.output_opt("-o", a.output.as_ref())
        .output_opt("--write-program", a.write_program.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    let p = a.job.run(&a.map)?;
    let before = before(&a.before)?;
    let mut staged = Staged::new();
    if let Some(o) = &a.output {
        staged.write_bytes(o, ballbar_trace::write(&p.trace).as_bytes())?;
    }
    if let Some(o) = &a.write_program {
        staged.write_bytes(o, p.program.as_bytes())?;
    }
    if let Some(o) = &a.report_html {
        let mut traces = vec![("predicted", &p.trace, &p.figures)];
        traces.extend(before.as_ref().map(|(t, f)| ("before", t, f)));
        let doc = report::document(
            "volcomp ballbar predict",
            vec![("map".into(), a.map.display().to_string())],
            report::sections(&traces, None),
        );
        staged.write_bytes(o, doc.to_html().as_bytes())?;
    }
    staged.commit()?;
    if a.json {
        return print(&[serde_json::to_string(&p.figures)?]);
    }
    print(&report::figures_lines(&p.figures))
}

fn fit(a: FitArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("TRACE", &a.trace)
        .input_opt("--before", a.before.as_ref());
    plan.output_opt("--residual", a.residual.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    let name = a.trace.display().to_string();
    let text = read(&a.trace, "TRACE")?;
    let f = a.job.run(&text, &name)?;
    let before = before(&a.before)?;
    let mut staged = Staged::new();
    if let Some(o) = &a.residual {
        staged.write_bytes(o, ballbar_trace::write(&f.residual).as_bytes())?;
    }
    if let Some(o) = &a.report_html {
        let trace = a.job.trace(&text, &name)?;
        let mut traces = vec![(name.as_str(), &trace, &f.figures)];
        traces.extend(before.as_ref().map(|(t, fi)| ("before", t, fi)));
        let doc = report::document(
            "volcomp ballbar fit",
            vec![("trace".into(), name.clone())],
            report::sections(&traces, Some(&f)),
        );
        staged.write_bytes(o, doc.to_html().as_bytes())?;
    }
    staged.commit()?;
    if a.json {
        return print(&[serde_json::to_string(&f)?]);
    }
    print(&report::fit_lines(&f))
}

fn map(a: MapArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for t in &a.traces {
        plan.input("TRACE", t);
    }
    plan.output("-o", &a.output);
    check(&plan)?;
    let mut traces = Vec::new();
    for t in &a.traces {
        traces.push((read(t, "TRACE")?, t.display().to_string()));
    }
    let q = a.job.run(&traces)?;
    let mut staged = Staged::new();
    staged.write_bytes(&a.output, q.csv.as_bytes())?;
    staged.commit()?;
    let m = &q.model;
    print(&[
        format!(
            "scale (um/m)        X {:.3}  Y {:.3}  Z {:.3}",
            m.scale_um_per_m[0], m.scale_um_per_m[1], m.scale_um_per_m[2]
        ),
        format!(
            "squareness (urad)   XY {:.3}  YZ {:.3}  ZX {:.3}",
            m.squareness_urad[0], m.squareness_urad[1], m.squareness_urad[2]
        ),
        format!(
            "backlash (um)       X {:.3}  Y {:.3}  Z {:.3}",
            m.backlash_um[0], m.backlash_um[1], m.backlash_um[2]
        ),
    ])
}
