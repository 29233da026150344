//! `volcomp straightness`: identify a straightness model from measured
//! profiles, separating geometric error from vibration by comparing runs at
//! several feed rates (docs/straightness.md), then plot it, export a
//! Z-correction table or predict the deviation at points. The model file is
//! also a `--map` for `compensate` and `simulate`.

use crate::options::{flags, Options};
use crate::output::{check, write_file, CliError, OutputPlan};
use crate::plot::{charts, write_charts_or_report};
use clap::{Args, Subcommand};
use std::io::Write;
use std::path::{Path, PathBuf};
use volcomp_core::identify::straightness::files;
use volcomp_core::identify::straightness::identify::{Fit, FitOptions};
use volcomp_core::identify::straightness::StraightnessModel;
use volcomp_core::request::{fit_summary, StraightnessFitRequest};

#[derive(Args, Debug)]
pub struct StraightnessArgs {
    #[command(subcommand)]
    pub command: StraightnessCommand,
}

#[derive(Subcommand, Debug)]
pub enum StraightnessCommand {
    /// Identify a straightness model (Fourier series + alignment) from runs at several feed rates.
    Fit(FitArgs),
    /// Draw the spectra, P̄(λ), σ(λ), the cut-off and measured vs modelled profiles (.svg or .png).
    Plot(PlotArgs),
    /// Write a model's Z-correction table (CSV) for a controller's cross compensation.
    Table(TableArgs),
    /// Print a model's predicted Z deviation at points.
    Predict(PredictArgs),
}

/// The runs and the identification options (shared by `fit` and `plot`).
#[derive(Args, Debug, Clone)]
pub struct RunArgs {
    /// Run files: CSV `position_mm,displacement_um` (Z deviation, actual − commanded),
    /// evenly sampled, with `# feed_mm_per_min = F` (or a feed_mm_per_min column) and
    /// `# axis = X|Y`. Repeats at one feed rate are averaged.
    #[arg(required = true, value_name = "RUN")]
    pub runs: Vec<PathBuf>,
    #[command(flatten)]
    pub job: Options<StraightnessFitRequest>,
}

#[derive(Args, Debug)]
pub struct FitArgs {
    #[command(flatten)]
    pub runs: RunArgs,
    /// Write the model (TOML) here; standard output without it.
    #[arg(short, long, value_name = "MODEL")]
    pub output: Option<PathBuf>,
    /// Also draw the identification (.svg or .png).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct PlotArgs {
    #[command(flatten)]
    pub runs: RunArgs,
    /// The plot (.svg or .png), or a self-contained HTML report (.html).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct TableArgs {
    /// A model written by `volcomp straightness fit`.
    pub model: PathBuf,
    /// Distance between table rows (mm); keep it well under the cut-off wavelength.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub step: f64,
    /// Write the table here; standard output without it.
    #[arg(short, long, value_name = "CSV")]
    pub output: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct PredictArgs {
    /// A model written by `volcomp straightness fit`.
    pub model: PathBuf,
    /// Points `X,Y` in mm (machine coordinates), e.g. `120,35 250,-10 -5,20`.
    /// A point may begin with a minus sign; `--clamp` may come before or
    /// after the points.
    #[arg(required = true, value_name = "X,Y", allow_hyphen_values = true)]
    pub points: Vec<String>,
    /// Hold points outside the measured range at its end instead of refusing them.
    #[arg(long)]
    pub clamp: bool,
}

pub fn run(a: StraightnessArgs) -> Result<(), CliError> {
    match a.command {
        StraightnessCommand::Fit(a) => fit_cmd(a),
        StraightnessCommand::Plot(a) => plot_cmd(a),
        StraightnessCommand::Table(a) => table_cmd(a),
        StraightnessCommand::Predict(a) => predict_cmd(a),
    }
}

/// Reads the runs and identifies the model.
fn identify(a: &RunArgs) -> Result<(Fit, FitOptions), CliError> {
    let o = a.job.options()?;
    let mut runs = Vec::with_capacity(a.runs.len());
    for path in &a.runs {
        runs.push(files::load_run(path, false).map_err(CliError::from)?);
    }
    Ok((a.job.fit(runs)?, o))
}

fn summary(f: &Fit, o: &FitOptions) -> String {
    flags(&fit_summary(f, o))
}

/// Refuses a plot path that `write_charts_or_report` could not write,
/// before any work.
fn check_plot_path(path: &Path) -> Result<(), CliError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if ["svg", "png", "html"].iter().any(|x| e.eq_ignore_ascii_case(x)) => Ok(()),
        _ => Err(CliError::Message(format!(
            "{}: plots are written as .svg or .png, reports as .html; choose one of those extensions",
            path.display()
        ))),
    }
}

fn fit_cmd(a: FitArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for r in &a.runs.runs {
        plan.input("RUNS", r);
    }
    plan.output_opt("-o", a.output.as_ref())
        .output_opt("--plot", a.plot.as_ref());
    check(&plan)?;
    if let Some(p) = &a.plot {
        check_plot_path(p)?;
    }
    let (f, o) = identify(&a.runs)?;
    let text = f.model.to_toml();
    let inputs: Vec<&Path> = a.runs.runs.iter().map(PathBuf::as_path).collect();
    if let Some(path) = &a.plot {
        let roles: Vec<(&str, &Path)> = inputs.iter().map(|p| ("profile", *p)).collect();
        write_charts_or_report(
            &charts::straightness_charts(&f, &o),
            path,
            "volcomp straightness report",
            &roles,
        )?;
    }
    match &a.output {
        Some(path) => {
            write_file(path, &inputs, text.as_bytes())?;
            eprint!("{}", summary(&f, &o));
            crate::note!("volcomp: wrote {}", path.display());
        }
        None => {
            eprint!("{}", summary(&f, &o));
            std::io::stdout()
                .write_all(text.as_bytes())
                .map_err(CliError::Stdout)?;
        }
    }
    if let Some(path) = &a.plot {
        crate::note!("volcomp: wrote {}", path.display());
    }
    Ok(())
}

fn plot_cmd(a: PlotArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for r in &a.runs.runs {
        plan.input("RUNS", r);
    }
    plan.output("-o", &a.output);
    check(&plan)?;
    check_plot_path(&a.output)?;
    let (f, o) = identify(&a.runs)?;
    for input in &a.runs.runs {
        if same_path(input, &a.output) {
            return Err(CliError::Message(format!(
                "refusing to overwrite the input {}: choose another output path with -o",
                input.display()
            )));
        }
    }
    let roles: Vec<(&str, &Path)> = a
        .runs
        .runs
        .iter()
        .map(|p| ("profile", p.as_path()))
        .collect();
    write_charts_or_report(
        &charts::straightness_charts(&f, &o),
        &a.output,
        "volcomp straightness report",
        &roles,
    )?;
    eprint!("{}", summary(&f, &o));
    crate::note!("volcomp: wrote {}", a.output.display());
    Ok(())
}

fn same_path(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

fn load_model(path: &Path) -> Result<StraightnessModel, CliError> {
    files::load_model(path).map_err(CliError::from)
}

fn table_cmd(a: TableArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("MODEL", &a.model)
        .output_opt("-o", a.output.as_ref());
    check(&plan)?;
    let model = load_model(&a.model)?;
    let csv = model.correction_table_csv(a.step)?;
    match &a.output {
        Some(path) => {
            write_file(path, &[&a.model], csv.as_bytes())?;
            crate::note!("volcomp: wrote {}", path.display());
        }
        None => std::io::stdout()
            .write_all(csv.as_bytes())
            .map_err(CliError::Stdout)?,
    }
    Ok(())
}

fn predict_cmd(a: PredictArgs) -> Result<(), CliError> {
    let mut model = load_model(&a.model)?;
    // The points take values beginning with `-` (negative X), so clap hands
    // a flag written after them over as a point: take it back here.
    let (given, points): (Vec<&String>, Vec<&String>) =
        a.points.iter().partition(|p| p.starts_with("--"));
    let mut clamp = a.clamp;
    for f in given {
        match f.as_str() {
            "--clamp" => clamp = true,
            other => {
                return Err(CliError::Message(format!(
                    "unexpected option `{other}` among the points: `volcomp straightness predict` takes only --clamp (see --help)"
                )))
            }
        }
    }
    if points.is_empty() {
        return Err(CliError::Message(
            "no points given: write them as X,Y in mm, like 120,35 250,-10".into(),
        ));
    }
    model.clamp = clamp;
    let mut out = String::from(files::PREDICTION_HEADER);
    for p in points {
        let v: Option<Vec<f64>> = p
            .split(',')
            .map(|t| t.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect();
        let (x, y) = match v.as_deref() {
            Some([x, y]) => (*x, *y),
            _ => {
                return Err(CliError::Message(format!(
                    "point `{p}` is not two numbers X,Y in mm, like 120,-35.5"
                )))
            }
        };
        let row = files::prediction_row(&model, x, y).map_err(|e| {
            CliError::Message(flags(&format!(
                "{}: {e}\n  help: {{clamp}} holds the error at the table ends",
                a.model.display()
            )))
        })?;
        out.push_str(&row);
    }
    std::io::stdout()
        .write_all(out.as_bytes())
        .map_err(CliError::Stdout)
}
