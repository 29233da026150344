//! `volcomp surface mirror`: free-form surface compensation from on-machine
//! probing (the mirror method, `docs/mirror.md`). Flags, validation, files
//! and printing; the method is `volcomp_core::surface::mirror`.

use super::compensate::{date_utc, file_name, refuse_if_compensated};
use super::Machine;
use crate::args::surface::{flag_help, Cl, MirrorArgs, SurfaceArgs, SurfaceCommand};
use crate::output::{check, write_atomically, CliError, OutputPlan};
use crate::progress::Bar;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use volcomp_core::compensate::survey_style;
use volcomp_core::io::provenance::{sha256_hex, HeaderWriter, ProgramHeader};
use volcomp_core::progress::Counted;
use volcomp_core::surface::mirror::report::{
    compensated_surface_text, header_method, header_options, report_csv, summary_json,
    summary_text, FinishingJson, RunInputs, SurfaceFiles,
};
use volcomp_core::surface::mirror::{
    compensate_finishing, mirror, program_frame_offset, read_nominal, read_probe_points, BallTool,
    ClPoint, CompensatedSurface, DeviationField, FinishingOptions, FinishingSummary, MirrorOptions,
    MirrorResult, NominalFormat, NominalSurface, SurfaceModel,
};

pub fn run(a: SurfaceArgs) -> Result<(), CliError> {
    match a.command {
        SurfaceCommand::Mirror(m) => run_mirror(m),
    }
}

fn read_text(path: &Path) -> Result<String, CliError> {
    volcomp_core::io::inputs::read_to_string(path, "an input")
        .map_err(|e| CliError::Io(path.to_path_buf(), e))
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

fn positive(v: f64, flag: &str, what: &str) -> Result<(), CliError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(CliError::Message(format!("{flag} must be {what}; got {v}")))
    }
}

/// Loads the nominal surface (its format by its extension).
fn load_nominal(a: &MirrorArgs) -> Result<NominalSurface, CliError> {
    let file = a.nominal.display().to_string();
    let text = read_text(&a.nominal)?;
    let format = NominalFormat::of_path(&a.nominal)?;
    Ok(read_nominal(
        &text,
        &file,
        format,
        a.material_side(),
        &a.grid_parameterization(),
    )
    .map_err(flag_help)?)
}

/// The run as the reports name it.
fn run_inputs(a: &MirrorArgs) -> RunInputs {
    RunInputs {
        nominal: a.nominal.display().to_string(),
        measured: a.measured.display().to_string(),
        stock_mm: a.stock,
        probe_radius_mm: a.probe_radius,
    }
}

fn default_base(measured: &Path) -> PathBuf {
    let stem = measured
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "surface".into());
    measured.with_file_name(format!("{stem}.compensated"))
}

fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

fn run_mirror(a: MirrorArgs) -> Result<(), CliError> {
    {
        let base = a
            .surface_out
            .clone()
            .unwrap_or_else(|| default_base(&a.measured));
        let mut plan = OutputPlan::new();
        plan.input("--nominal", &a.nominal)
            .input("--measured", &a.measured)
            .input_opt("--finishing", a.finishing.as_ref())
            .input_opt("--setup", a.machine.setup.as_ref())
            .output_opt("-o", a.output.as_ref())
            .output_opt("--baseline", a.baseline.as_ref())
            .output("--surface-out (grid)", with_suffix(&base, ".csv"))
            .output("--surface-out (B-spline)", with_suffix(&base, ".toml"))
            .output_opt("--report", a.report.as_ref());
        check(&plan)?;
    }
    positive(a.stock, "--stock", "a positive length in mm")?;
    positive(a.max_error, "--max-error", "a positive length in mm")?;
    if let Some(t) = a.tolerance {
        positive(t, "--tolerance", "a positive number of µm")?;
    }
    positive(
        a.contact_tolerance,
        "--contact-tolerance",
        "a positive length in mm",
    )?;
    if let Some(r) = a.probe_radius {
        if !(r.is_finite() && r >= 0.0) {
            return Err(CliError::Message(format!(
                "--probe-radius must be a length ≥ 0 in mm; got {r}"
            )));
        }
    }
    if !a.no_split {
        positive(
            a.segment_length,
            "--segment-length",
            "a positive length in mm",
        )?;
    }
    if !(2..=1001).contains(&a.grid_size) {
        return Err(CliError::Message(format!(
            "--grid-size must be 2 … 1001; got {}",
            a.grid_size
        )));
    }
    if a.decimals.is_some_and(|d| !(1..=9).contains(&d)) {
        return Err(CliError::Message("--decimals must be 1 … 9".into()));
    }
    let tool = match (&a.finishing, a.tool_radius) {
        (Some(_), Some(r)) => {
            positive(r, "--tool-radius", "the ball's radius in mm")?;
            Some(BallTool {
                radius_mm: r,
                cl: match a.cl_point {
                    Cl::Tip => ClPoint::Tip,
                    Cl::Center => ClPoint::Centre,
                },
            })
        }
        _ => None,
    };

    let nominal = load_nominal(&a)?;
    let measured_file = a.measured.display().to_string();
    let probes = read_probe_points(&read_text(&a.measured)?, &measured_file)?;
    let options = MirrorOptions {
        stock_mm: a.stock,
        probe_radius_mm: a.probe_radius,
        max_error_mm: a.max_error,
        fit: a.fit_method(),
    };
    let result = mirror(&nominal, &probes, &options, &measured_file).map_err(flag_help)?;
    if result.compensation_predicted_worse() {
        let p = result
            .mirror_predicted
            .as_ref()
            .map_or(f64::NAN, |p| p.std_um);
        let message = format!(
            "the leave-one-out prediction of the finishing error after compensation (std {p:.3} µm) is worse than not compensating (std {:.3} µm): the fit ({} × {} control net) does not predict the error between the probe points",
            result.before.std_um, result.fit.net.0, result.fit.net.1
        );
        if a.refuse_worse {
            return Err(CliError::Message(format!(
                "{measured_file}: {message}\n  help: probe more densely or check the probe points (an outlier?); nothing was written"
            )));
        }
        eprintln!(
            "volcomp: warning: {measured_file}: {message}; check the probe points, or pass --refuse-worse to refuse"
        );
    }
    let inputs: Vec<&Path> = [
        Some(a.nominal.as_path()),
        Some(a.measured.as_path()),
        a.finishing.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();

    // The finishing program first: it is the step most likely to be refused,
    // and nothing should be written then.
    let (finishing, baseline_program) = match (&a.finishing, &a.output, tool) {
        (Some(program), Some(output), Some(tool)) => {
            if program.as_os_str() == "-" {
                return Err(CliError::Message(
                    "--finishing needs a file: the program is read twice (its frame first)".into(),
                ));
            }
            let machine = Machine::from_args(&a.machine)?;
            let file = program.display().to_string();
            let frame = program_frame_offset(&mut machine.walk(program)?, &file)?;
            let opts = FinishingOptions {
                segment_length_mm: (!a.no_split).then_some(a.segment_length),
                decimals: a.decimals,
                trace_comments: !a.no_trace,
                ..FinishingOptions::default()
            };
            let run_one = |field: &DeviationField,
                           out: &Path|
             -> Result<FinishingSummary, CliError> {
                let model = SurfaceModel::new(&nominal, field, tool, frame, a.contact_tolerance)
                    .map_err(flag_help)?;
                let mut head = Vec::with_capacity(1 << 16);
                volcomp_core::io::inputs::open(program, "the program")
                    .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
                    .map_err(|e| CliError::Io(program.clone(), e))?;
                if !a.allow_recompensate {
                    refuse_if_compensated(&head, &file)?;
                }
                let style = survey_style(&head);
                let bar = Bar::reading(&format!("mirroring {}", program.display()), program);
                let f = volcomp_core::io::inputs::open(program, "the program")
                    .map_err(|e| CliError::Io(program.clone(), e))?;
                let reader: Box<dyn std::io::BufRead> = Box::new(Counted::new(
                    std::io::BufReader::with_capacity(1 << 16, f),
                    bar.clone(),
                ));
                let mut walker = machine.walker(reader, &program.display().to_string());
                let mut summary = None;
                let header = mirror_header(
                    &a,
                    &machine,
                    &tool,
                    out == a.baseline.as_deref().unwrap_or(Path::new("")),
                )?;
                let written = write_atomically(out, &inputs, |w| {
                    let mut w = HeaderWriter::new(w, header.lines());
                    summary = Some(
                        compensate_finishing(&mut walker, &file, &style, &model, &opts, &mut w)
                            .map_err(flag_help)?,
                    );
                    w.finish().map_err(|e| CliError::Io(out.to_path_buf(), e))?;
                    Ok(())
                });
                bar.finish();
                written?;
                summary.ok_or_else(|| {
                    CliError::Message("the finishing run produced no summary".into())
                })
            };
            let json =
                |p: &Path, s: &FinishingSummary| FinishingJson::new(&p.display().to_string(), s);
            let summary = json(output, &run_one(&result.field, output)?);
            let baseline = match &a.baseline {
                Some(path) => {
                    let s = nominal.surface();
                    let constant = DeviationField::constant(
                        result.baseline_offset_um,
                        s.domain_u(),
                        s.domain_v(),
                    );
                    Some(json(path, &run_one(&constant, path)?))
                }
                None => None,
            };
            (Some(summary), baseline)
        }
        _ => (None, None),
    };

    let surface = write_surface(&a, &nominal, &result, &inputs)?;
    if let Some(path) = &a.report {
        write_report(path, &a, &result, &inputs)?;
    }
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if a.json {
        let text = serde_json::to_string(&summary_json(
            &run_inputs(&a),
            &result,
            Some(&surface),
            finishing,
            baseline_program,
            false,
        ))?;
        writeln!(out, "{text}").map_err(CliError::Stdout)?;
    } else {
        let text = summary_text(
            &run_inputs(&a),
            &result,
            &surface,
            finishing.as_ref(),
            baseline_program.as_ref(),
        );
        out.write_all(text.as_bytes()).map_err(CliError::Stdout)?;
    }
    Ok(())
}

/// The header of a mirror-compensated finishing program: the nominal
/// surface and the probe points it was made from, the set-up and options.
fn mirror_header(
    a: &MirrorArgs,
    machine: &Machine,
    tool: &BallTool,
    baseline: bool,
) -> Result<ProgramHeader, CliError> {
    let mut files = Vec::new();
    for (label, p) in [("surf", &a.nominal), ("probes", &a.measured)] {
        let bytes = volcomp_core::io::inputs::read(p, "an input")
            .map_err(|e| CliError::Io(p.clone(), e))?;
        files.push((label.to_string(), file_name(p), sha256_hex(&bytes)));
    }
    Ok(ProgramHeader {
        version: env!("CARGO_PKG_VERSION").to_string(),
        files,
        setup_file: a.machine.setup.as_deref().map(file_name),
        work_offset_note: a
            .machine
            .work_offset
            .as_ref()
            .map(|_| "G54 from --work-offset".to_string()),
        setup: machine.setup.clone(),
        method: header_method(baseline).into(),
        options: header_options(
            a.stock,
            tool,
            &a.fit_method(),
            (!a.no_split).then_some(a.segment_length),
            a.contact_tolerance,
        ),
        date_utc: date_utc(),
    })
}

fn write_surface(
    a: &MirrorArgs,
    nominal: &NominalSurface,
    result: &MirrorResult,
    inputs: &[&Path],
) -> Result<SurfaceFiles, CliError> {
    let base = a
        .surface_out
        .clone()
        .unwrap_or_else(|| default_base(&a.measured));
    let grid_path = with_suffix(&base, ".csv");
    let toml_path = with_suffix(&base, ".toml");
    let comp = CompensatedSurface {
        nominal,
        field: &result.field,
    };
    let text = compensated_surface_text(&run_inputs(a), &comp, a.grid_size)?;
    for (path, content) in [
        (&grid_path, &text.grid_csv),
        (&toml_path, &text.bspline_toml),
    ] {
        write_atomically(path, inputs, |w| {
            w.write_all(content.as_bytes())
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    Ok(SurfaceFiles {
        grid: grid_path.display().to_string(),
        grid_nodes: text.grid_nodes,
        bspline: toml_path.display().to_string(),
        bspline_net: text.bspline_net,
        bspline_error_um: text.bspline_error_um,
    })
}

fn write_report(
    path: &Path,
    a: &MirrorArgs,
    r: &MirrorResult,
    inputs: &[&Path],
) -> Result<(), CliError> {
    let bytes = if extension(path) == "html" {
        let mut files = Vec::new();
        for p in inputs {
            files.push(volcomp_core::report::InputFile::read("input", p)?);
        }
        let run = run_inputs(a);
        let doc = volcomp_core::report::Document {
            title: format!("volcomp mirror compensation report: {}", run.measured),
            facts: vec![
                ("command".into(), crate::commands::command_line()),
                ("volcomp".into(), env!("CARGO_PKG_VERSION").into()),
                ("date (UTC)".into(), crate::commands::date_utc()),
                ("nominal surface".into(), run.nominal.clone()),
                ("probe points".into(), run.measured.clone()),
                ("stock D".into(), format!("{} mm", run.stock_mm)),
                (
                    "probe ball radius".into(),
                    run.probe_radius_mm
                        .map_or("points are surface points".into(), |r| format!("{r} mm")),
                ),
            ],
            inputs: files,
            sections: volcomp_core::report::mirror::sections(r),
        };
        doc.to_html().into_bytes()
    } else if extension(path) == "json" {
        let j = summary_json(&run_inputs(a), r, None, None, None, true);
        let mut text = serde_json::to_string_pretty(&j)?;
        text.push('\n');
        text.into_bytes()
    } else {
        report_csv(&run_inputs(a), r).into_bytes()
    };
    write_atomically(path, inputs, |w| {
        w.write_all(&bytes)
            .map_err(|e| CliError::Io(path.to_path_buf(), e))
    })
}
