//! `volcomp thermal`: thermally varying volumetric error (docs/thermal.md).
//! `fit` identifies the 21-component model with Legendre-polynomial
//! components from ball-array measurements per cycle and regresses its
//! parameters on temperatures; `predict` writes the 21-component model for a
//! moment that `compensate --map` reads; `plot` draws parameter evolution,
//! model fit and residuals; `example` writes synthetic inputs.

use crate::output::{check, write_atomically, CliError, OutputPlan};
use crate::plot::{write_charts, write_charts_or_report, Chart, Series};
use crate::progress::Bar;
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};
use volcomp_core::example::thermal as example;
use volcomp_core::identify::thermal::files::{
    self, parse_artifact, parse_measurements, parse_temperatures, FitOptions, ThermalModelFile,
};
use volcomp_core::identify::thermal::identify::DEFAULT_RELATIVE_THRESHOLD;
use volcomp_core::identify::thermal::report;
use volcomp_core::identify::thermal::uncertainty::{
    axis_line_bands_with_progress, check_band_samples, LineBands, LINE_INTERVALS,
};
use volcomp_core::identify::thermal::ThermalError;

/// Thermally varying error: ball-array identification, temperature regression, prediction, plots.
#[derive(Args, Debug)]
pub struct ThermalArgs {
    #[command(subcommand)]
    pub command: ThermalCommand,
}

#[derive(Subcommand, Debug)]
pub enum ThermalCommand {
    /// Identify the model per measurement cycle from ball-array data and regress it on temperatures.
    Fit(FitArgs),
    /// Write the 21-component model (TOML + CSV) predicted for one row of a temperature file.
    Predict(PredictArgs),
    /// Plot parameter evolution, regression fit and residuals (.svg or .png).
    Plot(PlotArgs),
    /// Write synthetic example inputs (artifact, measurements, temperatures of two tests).
    Example(ExampleArgs),
}

#[derive(Args, Debug)]
pub struct FitArgs {
    /// Measured sphere centres: cycle,time_h,placement,sphere,x_mm,y_mm,z_mm.
    #[arg(long, value_name = "CSV")]
    pub measurements: PathBuf,
    /// Temperatures per cycle: cycle,time_h,<sensor>_C,…
    #[arg(long, value_name = "CSV")]
    pub temperatures: PathBuf,
    /// Artifact: sphere,distance_mm (calibrated distance from sphere 1).
    #[arg(long, value_name = "CSV")]
    pub artifact: PathBuf,
    /// Axis ranges the polynomials live on, mm: "X0:X1,Y0:Y1,Z0:Z1".
    #[arg(long, value_name = "RANGES", allow_hyphen_values = true)]
    pub ranges_mm: String,
    /// Kinematic chain, workpiece to tool (docs/kinematic.md).
    #[arg(long, default_value = "w X' Y' b Z t")]
    pub chain: String,
    /// Maximum Legendre order of the components.
    #[arg(long, default_value_t = 2, allow_negative_numbers = true)]
    pub order: usize,
    /// Tool length offset of the probe (mm).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub probe_length_mm: f64,
    /// Lagged cycles of every sensor in the regression (ARX-style inputs).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub lags: usize,
    /// Relative singular-value threshold for rank deficiency.
    #[arg(long, default_value_t = DEFAULT_RELATIVE_THRESHOLD, allow_negative_numbers = true)]
    pub threshold: f64,
    /// Points per component table in predicted models.
    #[arg(long, default_value_t = 61, allow_negative_numbers = true)]
    pub table_samples: usize,
    /// Also write the 95 % Monte Carlo confidence bands of the last cycle's
    /// identified TCP error along lines through the middle of the volume in
    /// X, Y and Z: a CSV, or a plot (.svg/.png).
    #[arg(long, value_name = "FILE")]
    pub bands: Option<PathBuf>,
    /// Monte Carlo draws for --bands.
    #[arg(
        long,
        default_value_t = 400,
        requires = "bands",
        allow_negative_numbers = true
    )]
    pub samples: usize,
    /// Output thermal model (TOML).
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct PredictArgs {
    /// Thermal model from `thermal fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// Temperatures (same sensor columns as for the fit).
    #[arg(long, value_name = "CSV")]
    pub temperatures: PathBuf,
    /// Cycle number of the moment (default: the last row).
    #[arg(long, allow_negative_numbers = true)]
    pub cycle: Option<usize>,
    /// Output 21-component model (TOML); the tables go beside it as <stem>.csv.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Predict even at temperatures outside the training range (with a
    /// warning) instead of refusing.
    #[arg(long)]
    pub extrapolate: bool,
}

#[derive(Args, Debug)]
pub struct PlotArgs {
    /// Thermal model from `thermal fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// How many parameters to draw (the largest drifts relative to their uncertainty first).
    #[arg(long, default_value_t = 6, allow_negative_numbers = true)]
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
        ThermalCommand::Fit(a) => fit_cmd(a),
        ThermalCommand::Predict(a) => predict_cmd(a),
        ThermalCommand::Plot(a) => plot_cmd(a),
        ThermalCommand::Example(a) => example_cmd(a),
    }
}

fn read(path: &Path) -> Result<String, CliError> {
    volcomp_core::io::inputs::read_to_string(path, "an input")
        .map_err(|e| CliError::Io(path.to_path_buf(), e))
}

fn parse_ranges(text: &str) -> Result<[[f64; 2]; 3], CliError> {
    let bad = || {
        CliError::Message(format!(
            "--ranges-mm `{text}`: write three ranges lo:hi separated by commas, e.g. 0:600,0:400,0:300"
        ))
    };
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut r = [[0.0; 2]; 3];
    for (a, p) in parts.iter().enumerate() {
        let (lo, hi) = p.split_once(':').ok_or_else(bad)?;
        r[a] = [
            lo.trim().parse().map_err(|_| bad())?,
            hi.trim().parse().map_err(|_| bad())?,
        ];
    }
    Ok(r)
}

/// A thermal option error said with the command line's flags (the library
/// names options by their names: `table_samples` is `--table-samples`).
fn flagged(e: ThermalError) -> CliError {
    let text = e.to_string();
    for (name, flag) in [
        ("table_samples", "--table-samples"),
        ("samples", "--samples"),
        ("order", "--order"),
        ("lags", "--lags"),
        ("threshold", "--threshold"),
        ("ranges_mm", "--ranges-mm"),
        ("probe_length_mm", "--probe-length-mm"),
    ] {
        if let Some(rest) = text.strip_prefix(name) {
            if rest.starts_with(' ') {
                return CliError::reworded(format!("{flag}{rest}"), e);
            }
        }
    }
    e.into()
}

fn fit_cmd(a: FitArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("--measurements", &a.measurements)
        .input("--temperatures", &a.temperatures)
        .input("--artifact", &a.artifact)
        .output("-o", &a.output)
        .output_opt("--bands", a.bands.as_ref());
    check(&plan)?;
    let ranges_mm = parse_ranges(&a.ranges_mm)?;
    let options = FitOptions {
        chain: a.chain.clone(),
        ranges_mm,
        order: a.order,
        probe_length_mm: a.probe_length_mm,
        lags: a.lags,
        relative_threshold: a.threshold,
        table_samples: a.table_samples,
    };
    // Every option is checked before any file is read.
    options.check().map_err(flagged)?;
    if a.bands.is_some() {
        check_band_samples(a.samples).map_err(flagged)?;
    }
    let art_name = a.artifact.display().to_string();
    let array = parse_artifact(&read(&a.artifact)?, &art_name)?;
    let m_name = a.measurements.display().to_string();
    let cycles = parse_measurements(&read(&a.measurements)?, &m_name, &array)?;
    let t_name = a.temperatures.display().to_string();
    let temps = parse_temperatures(&read(&a.temperatures)?, &t_name)?;
    let (file, idents) =
        files::fit(&array, &cycles, &temps, &t_name, &options).map_err(|e| match e {
            ThermalError::OutsideRange(r) => CliError::Message(r.describe("--ranges-mm")),
            e => e.into(),
        })?;
    let text = file.to_toml();
    write_atomically(
        &a.output,
        &[&a.measurements, &a.temperatures, &a.artifact],
        |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| CliError::Io(a.output.clone(), e))
        },
    )?;
    if let Some(path) = &a.bands {
        let last = idents
            .last()
            .ok_or_else(|| CliError::Message("no cycles to draw bands for".into()))?;
        let model = files::poly_model(&a.chain, ranges_mm, a.order, a.probe_length_mm)?;
        let samples = a.samples;
        // 123 points × `samples` draws: a bar from 100 000 model evaluations.
        let points = 3 * (u64::from(LINE_INTERVALS) + 1);
        let mut bar = Bar::items(
            "Monte Carlo bands (points)",
            points,
            points * samples as u64 >= 100_000,
        );
        let lines = axis_line_bands_with_progress(
            &model,
            last,
            ranges_mm,
            a.probe_length_mm,
            samples,
            &mut bar,
        );
        bar.finish();
        write_bands(path, &lines, samples)?;
    }
    for w in volcomp_core::identify::thermal::checks::noise_warnings(&cycles, &idents) {
        eprintln!(
            "{}",
            crate::output::clean(&format!("volcomp: warning: {m_name}: {w}"))
        );
    }
    let first = &idents[0];
    let (lo, hi) = file.sigma0_range_um();
    println!(
        "{} cycles, {} placements, {} observations per cycle; rank {} of {} parameters",
        cycles.len(),
        cycles[0].placements.len(),
        first.observations,
        first.rank,
        first.theta.len()
    );
    println!("probing noise estimated from the residuals: {lo:.3} … {hi:.3} µm");
    if file.unidentifiable.is_empty() {
        println!("every parameter is identifiable");
    } else {
        println!(
            "not identifiable from these placements (no values, zero in predicted models): {}",
            file.unidentifiable.join(", ")
        );
    }
    let worst = file.largest_residual();
    if let Some(p) = worst {
        println!(
            "regression on {} sensor(s), {} lag(s): largest residual RMS {:.3} {} ({})",
            file.sensors.len(),
            file.lags,
            p.residual_rms,
            p.unit,
            p.name
        );
    }
    println!("wrote {}", a.output.display());
    Ok(())
}

fn load_model(path: &Path) -> Result<ThermalModelFile, CliError> {
    report::load_model(path).map_err(CliError::from)
}

fn predict_cmd(a: PredictArgs) -> Result<(), CliError> {
    {
        let stem = a
            .output
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("model");
        let mut plan = OutputPlan::new();
        plan.input("--model", &a.model)
            .input("--temperatures", &a.temperatures)
            .output("-o", &a.output)
            .output(
                "-o (its tables beside it)",
                a.output.with_file_name(format!("{stem}.csv")),
            );
        check(&plan)?;
    }
    let model = load_model(&a.model)?;
    let t_name = a.temperatures.display().to_string();
    let temps = parse_temperatures(&read(&a.temperatures)?, &t_name)?;
    let row = temps.row_of(a.cycle, &t_name)?;
    let theta = if a.extrapolate {
        if let Err(e) = volcomp_core::identify::thermal::checks::check_training_range(
            &model, &temps, &t_name, row,
        ) {
            eprintln!("volcomp: warning: {e} (--extrapolate)");
        }
        model.predict_extrapolating(&temps, &t_name, row)?
    } else {
        model.predict(&temps, &t_name, row).map_err(|e| {
            CliError::Message(format!("{e}\n  help: pass --extrapolate to predict anyway"))
        })?
    };
    let stem = a
        .output
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("model")
        .to_string();
    let csv_name = format!("{stem}.csv");
    let csv_path = a.output.with_file_name(&csv_name);
    let (toml, csv) = model.model_files(
        &theta,
        &csv_name,
        &format!(
            "volcomp thermal prediction for cycle {} (t = {} h) of {}",
            temps.cycles[row], temps.time_h[row], t_name
        ),
    )?;
    let inputs = [a.model.as_path(), a.temperatures.as_path()];
    write_atomically(&csv_path, &inputs, |w| {
        w.write_all(csv.as_bytes())
            .map_err(|e| CliError::Io(csv_path.clone(), e))
    })?;
    write_atomically(&a.output, &inputs, |w| {
        w.write_all(toml.as_bytes())
            .map_err(|e| CliError::Io(a.output.clone(), e))
    })?;
    println!(
        "wrote {} and {} (cycle {}, t = {} h); use it with `volcomp compensate --map {}`",
        a.output.display(),
        csv_path.display(),
        temps.cycles[row],
        temps.time_h[row],
        a.output.display()
    );
    Ok(())
}

fn plot_cmd(a: PlotArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("--model", &a.model).output("-o", &a.output);
    check(&plan)?;
    let m = load_model(&a.model)?;
    let t = &m.time_h;
    let order = m.by_drift(a.top);
    // One chart per unit: linear parameters in µm and angular ones in µrad
    // never share an axis. Each parameter's markers (identified) and line
    // (regression) share one colour.
    let mut units: Vec<&str> = Vec::new();
    for p in &order {
        if !units.contains(&p.unit.as_str()) {
            units.push(p.unit.as_str());
        }
    }
    let mut charts = Vec::new();
    // The files spell units in ASCII ("um", "urad"); the charts in symbols.
    let symbol = |u: &str| match u {
        "um" => "µm".to_string(),
        "urad" => "µrad".to_string(),
        u => u.to_string(),
    };
    for unit_file in &units {
        let unit = symbol(unit_file);
        let mut evolution = Chart {
            title: format!(
                "Parameters in {unit} over time: identified (markers) and regression (lines)"
            ),
            x_label: "time (h)".into(),
            y_label: format!("value − first cycle ({unit})"),
            ..Chart::default()
        };
        let mut residuals = Chart {
            title: format!("Regression residuals of the parameters in {unit}"),
            x_label: "time (h)".into(),
            y_label: format!("identified − regression ({unit})"),
            ..Chart::default()
        };
        for (colour, p) in order.iter().filter(|p| p.unit == *unit_file).enumerate() {
            let base = p.identified[0];
            let label = format!("{} ({unit})", p.name);
            evolution.series.push(
                Series::markers(
                    format!("{label} identified"),
                    t.iter()
                        .zip(&p.identified)
                        .map(|(x, v)| (*x, v - base))
                        .collect(),
                )
                .colour(colour),
            );
            let f = m.fitted(p);
            evolution.series.push(
                Series::line(
                    format!("{label} regression"),
                    f.iter().map(|(x, v)| (*x, v - base)).collect(),
                )
                .colour(colour),
            );
            residuals.series.push(
                Series::line(
                    label,
                    f.iter()
                        .map(|(x, v)| {
                            let c = t.iter().position(|y| y == x).unwrap_or(0);
                            (*x, p.identified[c] - v)
                        })
                        .collect(),
                )
                .colour(colour),
            );
        }
        charts.push(evolution);
        charts.push(residuals);
    }
    let mut temps = Chart {
        title: "Temperatures".into(),
        x_label: "time (h)".into(),
        y_label: "temperature (°C)".into(),
        ..Chart::default()
    };
    for (s, name) in m.sensors.iter().enumerate() {
        temps.series.push(Series::line(
            name.clone(),
            t.iter()
                .zip(&m.temperatures_c)
                .map(|(x, v)| (*x, v[s]))
                .collect(),
        ));
    }
    let noise = Chart {
        title: "Probing noise estimated from the artifact residuals per cycle".into(),
        x_label: "time (h)".into(),
        y_label: "σ0 (µm)".into(),
        series: vec![Series::markers(
            "σ0",
            t.iter().zip(&m.sigma0_um).map(|(x, v)| (*x, *v)).collect(),
        )],
        ..Chart::default()
    };
    charts.push(temps);
    charts.push(noise);
    write_charts_or_report(
        &charts,
        &a.output,
        "volcomp thermal model report",
        &[("model", a.model.as_path())],
    )?;
    println!("wrote {}", a.output.display());
    Ok(())
}

fn example_cmd(a: ExampleArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
    let files = example::example_files();
    for (name, text) in &files {
        let path = a.output.join(name);
        write_atomically(&path, &[], |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    let d = a.output.display();
    let r = example::RANGES_MM;
    println!("wrote the example into {d}; try:");
    println!(
        "  volcomp thermal fit --measurements {d}/measurements_train.csv --temperatures {d}/temperatures_train.csv \\\n      --artifact {d}/artifact.csv --ranges-mm {}:{},{}:{},{}:{} -o {d}/thermal.toml",
        r[0][0], r[0][1], r[1][0], r[1][1], r[2][0], r[2][1]
    );
    println!("  volcomp thermal predict --model {d}/thermal.toml --temperatures {d}/temperatures_check.csv -o {d}/predicted.toml");
    println!("  volcomp thermal plot --model {d}/thermal.toml -o {d}/thermal.svg");
    Ok(())
}

/// The 95 % Monte Carlo bands of the identified TCP error along lines
/// through the middle of the volume (docs/thermal.md, "Confidence bands from the command line"), as CSV
/// or as a plot with one chart per axis line.
fn write_bands(path: &Path, lines: &[LineBands], samples: usize) -> Result<(), CliError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") | Some("png") => write_charts(&band_charts(lines, samples), path),
        _ => {
            let csv = report::bands_csv(lines);
            write_atomically(path, &[], |w| {
                w.write_all(csv.as_bytes())
                    .map_err(|e| CliError::Io(path.to_path_buf(), e))
            })
        }
    }
}

/// One chart per axis line: the component along the line's own axis (what a
/// part dimension sees), its estimate and 2.5 / 97.5 % quantiles.
fn band_charts(lines: &[LineBands], samples: usize) -> Vec<Chart> {
    lines
        .iter()
        .map(|l| {
            let a = l.axis;
            let name = ['X', 'Y', 'Z'][a];
            let mut series = [Vec::new(), Vec::new(), Vec::new()];
            for (p, b) in l.points_mm.iter().zip(&l.bands) {
                series[0].push((p[a], b.estimate_um[a]));
                series[1].push((p[a], b.lo_um[a]));
                series[2].push((p[a], b.hi_um[a]));
            }
            let [est, lo95, hi95] = series;
            Chart {
                title: format!("identified e_{} along {name} through the middle, 95 % Monte Carlo band ({samples} draws)", name.to_ascii_lowercase()),
                x_label: format!("{name} (mm)"),
                y_label: "deviation (µm)".into(),
                series: vec![Series::line("estimate", est), Series::line("2.5 %", lo95), Series::line("97.5 %", hi95)],
                ..Chart::default()
            }
        })
        .collect()
}
