//! `volcomp thermal`: thermally varying volumetric error (docs/thermal.md).
//! `fit` identifies the 21-component model with Legendre-polynomial
//! components from ball-array measurements per cycle and regresses its
//! parameters on temperatures; `predict` writes the 21-component model for a
//! moment that `compensate --map` reads; `plot` draws parameter evolution,
//! model fit and residuals; `example` writes synthetic inputs.

use crate::options::Options;
use crate::output::{check, write_file, CliError, OutputPlan};
use crate::plot::{charts, write_charts, write_charts_or_report};
use crate::progress::Bar;
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};
use volcomp_core::example::thermal as example;
use volcomp_core::identify::thermal::files::ThermalModelFile;
use volcomp_core::identify::thermal::report;
use volcomp_core::identify::thermal::uncertainty::{LineBands, LINE_INTERVALS};
use volcomp_core::request::{
    Input, ThermalFitRequest, ThermalPredictRequest, DEFAULT_BAND_SAMPLES,
};

/// Thermally varying error: ball-array identification, temperature regression, prediction, plots.
#[derive(Args, Debug)]
pub struct ThermalArgs {
    #[command(subcommand)]
    pub command: ThermalCommand,
}

#[derive(Subcommand, Debug)]
pub enum ThermalCommand {
    /// Identify the model per measurement cycle from ball-array data and regress it on temperatures.
    Fit(Box<FitArgs>),
    /// Write the 21-component model (TOML + CSV) predicted for one row of a temperature file.
    Predict(PredictArgs),
    /// Plot parameter evolution, regression fit and residuals (.svg or .png).
    Plot(PlotArgs),
    /// Write synthetic example inputs (artifact, measurements, temperatures of two tests).
    Example(ExampleArgs),
}

#[derive(Args, Debug)]
pub struct FitArgs {
    #[command(flatten)]
    pub job: Options<ThermalFitRequest>,
    /// Also write the 95 % Monte Carlo confidence bands of the last cycle's
    /// identified TCP error along lines through the middle of the volume in
    /// X, Y and Z: a CSV, or a plot (.svg/.png).
    #[arg(long, value_name = "FILE")]
    pub bands: Option<PathBuf>,
    /// Output thermal model (TOML).
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct PredictArgs {
    /// Thermal model from `thermal fit`.
    #[arg(long)]
    pub model: PathBuf,
    #[command(flatten)]
    pub job: Options<ThermalPredictRequest>,
    /// Output 21-component model (TOML); the tables go beside it as <stem>.csv.
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct PlotArgs {
    /// Thermal model from `thermal fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// How many parameters to draw (the largest drifts relative to their uncertainty first).
    #[arg(long, default_value_t = 6)]
    pub top: usize,
    /// Output picture (.svg or .png), or a self-contained HTML report (.html).
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct ExampleArgs {
    /// Directory to write into (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn run(a: ThermalArgs) -> Result<(), CliError> {
    match a.command {
        ThermalCommand::Fit(a) => fit_cmd(*a),
        ThermalCommand::Predict(a) => predict_cmd(a),
        ThermalCommand::Plot(a) => plot_cmd(a),
        ThermalCommand::Example(a) => example_cmd(a),
    }
}

fn input(i: &Option<Input>) -> Option<&Path> {
    i.as_ref().and_then(|i| i.path())
}

fn fit_cmd(a: FitArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input_opt("--measurements", input(&a.job.measurements))
        .input_opt("--temperatures", input(&a.job.temperatures))
        .input_opt("--artifact", input(&a.job.artifact))
        .output("-o", &a.output)
        .output_opt("--bands", a.bands.as_ref());
    check(&plan)?;
    if a.job.bands_samples.is_some() && a.bands.is_none() {
        return Err(CliError::Message(
            "--samples is the number of draws of --bands: give --bands FILE too".into(),
        ));
    }
    let fit = a.job.fit()?;
    let inputs: Vec<&Path> = [&a.job.measurements, &a.job.temperatures, &a.job.artifact]
        .into_iter()
        .filter_map(input)
        .collect();
    let text = fit.file.to_toml();
    write_file(&a.output, &inputs, text.as_bytes())?;
    if let Some(path) = &a.bands {
        // 123 points × the draws: a bar from 100 000 model evaluations.
        let points = 3 * (u64::from(LINE_INTERVALS) + 1);
        let draws = a.job.bands_samples.unwrap_or(DEFAULT_BAND_SAMPLES);
        let mut bar = Bar::items(
            "Monte Carlo bands (points)",
            points,
            points * draws >= 100_000,
        );
        let bands = a.job.bands(&fit, &mut bar);
        bar.finish();
        let (lines, samples) = bands?;
        write_bands(path, &lines, samples)?;
    }
    for w in &fit.warnings {
        eprintln!("volcomp: warning: {w}");
    }
    for line in fit.summary_lines() {
        println!("{line}");
    }
    crate::note!("volcomp: wrote {}", a.output.display());
    Ok(())
}

fn load_model(path: &Path) -> Result<ThermalModelFile, CliError> {
    report::load_model(path).map_err(CliError::from)
}

fn predict_cmd(a: PredictArgs) -> Result<(), CliError> {
    let (csv_name, csv_path) = super::tables_beside(&a.output);
    let mut plan = OutputPlan::new();
    plan.input("--model", &a.model)
        .input_opt("--temperatures", input(&a.job.temperatures))
        .output("-o", &a.output)
        .output("-o (its tables beside it)", &csv_path);
    check(&plan)?;
    let model = load_model(&a.model)?;
    let prediction = a.job.predict(&model)?;
    if let Some(w) = &prediction.warning {
        eprintln!("volcomp: warning: {}", crate::options::flags(w));
    }
    let (toml, csv) = prediction.model_files(&model, &csv_name)?;
    let mut inputs = vec![a.model.as_path()];
    inputs.extend(input(&a.job.temperatures));
    for (path, text) in [(&csv_path, &csv), (&a.output, &toml)] {
        write_file(path, &inputs, text.as_bytes())?;
    }
    let (t, row) = (&prediction.temperatures, prediction.row);
    crate::note!(
        "volcomp: wrote {} and {} (cycle {}, t = {} h); use it with `volcomp compensate --map {}`",
        a.output.display(),
        csv_path.display(),
        t.cycles[row],
        t.time_h[row],
        a.output.display()
    );
    Ok(())
}

fn plot_cmd(a: PlotArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("--model", &a.model).output("-o", &a.output);
    check(&plan)?;
    let m = load_model(&a.model)?;
    let charts = charts::thermal_charts(&m, a.top);
    write_charts_or_report(
        &charts,
        &a.output,
        "volcomp thermal model report",
        &[("model", a.model.as_path())],
    )?;
    crate::note!("volcomp: wrote {}", a.output.display());
    Ok(())
}

fn example_cmd(a: ExampleArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
    let files = example::example_files();
    for (name, text) in &files {
        let path = a.output.join(name);
        write_file(&path, &[], text.as_bytes())?;
    }
    let d = a.output.display();
    let r = example::RANGES_MM;
    crate::note!("volcomp: wrote the example into {d}; try:");
    crate::note!(
        "  volcomp thermal fit --measurements {d}/measurements_train.csv --temperatures {d}/temperatures_train.csv \\\n      --artifact {d}/artifact.csv --ranges-mm {}:{},{}:{},{}:{} -o {d}/thermal.toml",
        r[0][0], r[0][1], r[1][0], r[1][1], r[2][0], r[2][1]
    );
    crate::note!("  volcomp thermal predict --model {d}/thermal.toml --temperatures {d}/temperatures_check.csv -o {d}/predicted.toml");
    crate::note!("  volcomp thermal plot --model {d}/thermal.toml -o {d}/thermal.svg");
    Ok(())
}

/// The 95 % Monte Carlo bands of the identified TCP error along lines
/// through the middle of the volume (docs/thermal.md, "Confidence bands from the command line"), as CSV
/// or as a plot with one chart per axis line.
fn write_bands(path: &Path, lines: &[LineBands], samples: usize) -> Result<(), CliError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") | Some("png") => write_charts(&charts::band_charts(lines, samples), path),
        _ => {
            let csv = report::bands_csv(lines);
            write_file(path, &[], csv.as_bytes())
        }
    }
}
