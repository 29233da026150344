//! `volcomp simulate`.

use super::compensate::{command_line, date_utc, load_map};
use super::Machine;
use crate::args::SimulateArgs;
use crate::output::{check, write_atomically, CliError, OutputPlan};
use crate::plot::{write_charts, Chart, Series};
use crate::progress::Bar;
use std::io::Write;
use volcomp_core::plan::{compare_programs, TimeComparison};
use volcomp_core::progress::Counted;
use volcomp_core::report::compensation::{
    lines_to_quote, quote_lines, setup_facts, simulation_sections, trace_program, Traced,
};
use volcomp_core::report::machining_time::machining_time_section;
use volcomp_core::report::trace::PathTrace;
use volcomp_core::report::{Document, InputFile};
use volcomp_core::{SimReport, Simulation};

pub fn run(a: SimulateArgs) -> Result<(), CliError> {
    if !(a.chord_tolerance.is_finite() && a.chord_tolerance > 0.0) {
        return Err(CliError::Message(
            "--chord-tolerance must be a positive length in mm".into(),
        ));
    }
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", &a.program)
        .map_input("--map", &a.map.map)
        .input_opt("--controller", a.map.controller.as_ref())
        .input_opt("--setup", a.machine.setup.as_ref())
        .input_opt("--reference", a.reference.as_ref())
        .output_opt("--errors-csv", a.errors_csv.as_ref())
        .output_opt("--plot", a.plot.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    let machine = Machine(
        Machine::from_args(&a.machine)?
            .0
            .with_spline_tolerance(a.chord_tolerance),
    );
    machine.warn_without_work_offset();
    let model = load_map(&a.map)?;
    let name = a.program.display().to_string();
    let mut simulation = Simulation::new(model.as_ref())
        .setup(machine.0.clone())
        .file_name(name.as_str())
        .chord_tolerance_mm(a.chord_tolerance);
    if let Some(r) = &a.reference {
        simulation = simulation.reference_named(r.display().to_string(), open(r)?);
    }
    let mut rows: Option<Vec<u8>> = a
        .errors_csv
        .as_ref()
        .map(|_| b"line,nominal_line,x_mm,y_mm,z_mm,point_error_um,contour_max_um\n".to_vec());
    let mut along: Vec<(f64, Option<f64>, f64)> = Vec::new();
    let mut last: Option<volcomp_gcode::Vec3> = None;
    let mut travelled = 0.0;
    let mut trace = a.report_html.as_ref().map(|_| PathTrace::default());
    let bar = Bar::reading(&format!("simulating {}", a.program.display()), &a.program);
    let mut warnings: Vec<(u64, String)> = Vec::new();
    let report = simulation
        .on_warning(|w| {
            eprintln!("{name}:{w}");
            warnings.push((w.line, w.message.clone()));
        })
        .on_segment(|s| {
            if let Some(t) = trace.as_mut() {
                t.push(s);
            }
            if let Some(p) = last {
                travelled += (s.command_mm - p).norm();
            }
            last = Some(s.command_mm);
            if a.plot.is_some() {
                along.push((travelled, s.point_um, s.contour_max_um));
            }
            if let Some(r) = rows.as_mut() {
                // The point error exists only where the command ends a
                // nominal feed move; elsewhere the field is empty.
                let point = s.point_um.map(|p| format!("{p:.4}")).unwrap_or_default();
                let _ = writeln!(
                    r,
                    "{},{},{:.6},{:.6},{:.6},{},{:.4}",
                    s.line,
                    s.nominal_line,
                    s.command_mm.x,
                    s.command_mm.y,
                    s.command_mm.z,
                    point,
                    s.contour_max_um
                );
            }
        })
        .run(Counted::new(open(&a.program)?, bar.clone()));
    bar.finish();
    let report = report.map_err(|e| machine.explain(e))?;
    let times = machining_times(&a, &machine)?;
    if let (Some(path), Some(bytes)) = (&a.errors_csv, rows) {
        let mut inputs = vec![a.program.as_path()];
        if let Some(r) = &a.reference {
            inputs.push(r.as_path());
        }
        write_atomically(path, &inputs, |w| {
            w.write_all(&bytes)
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    if let Some(path) = &a.plot {
        let title = a.program.display().to_string();
        let chart = Chart {
            title: format!("{title}: error along the path"),
            x_label: "commanded path length (mm)".into(),
            y_label: "error (µm)".into(),
            series: vec![
                Series::markers(
                    "point error",
                    along
                        .iter()
                        .filter_map(|(s, p, _)| p.map(|p| (*s, p)))
                        .collect(),
                ),
                Series::line(
                    "largest contour error per segment",
                    along.iter().map(|(s, _, c)| (*s, *c)).collect(),
                ),
            ],
            ..Chart::default()
        };
        write_charts(&[chart], path)?;
    }
    if let (Some(path), Some(trace)) = (&a.report_html, trace) {
        let after = Traced {
            label: name.clone(),
            report,
            trace,
            warnings,
        };
        let html = report_html(&a, &machine, model.as_ref(), after, times.as_ref())?;
        let mut inputs = vec![a.program.as_path()];
        if let Some(r) = &a.reference {
            inputs.push(r.as_path());
        }
        write_atomically(path, &inputs, |w| {
            w.write_all(html.as_bytes())
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if a.json {
        /// The simulation's figures and the machining time in one object.
        #[derive(serde::Serialize)]
        struct Json<'a> {
            #[serde(flatten)]
            report: &'a SimReport,
            machining_time: Option<&'a TimeComparison>,
        }
        let text = serde_json::to_string(&Json {
            report: &report,
            machining_time: times.as_ref(),
        })?;
        writeln!(out, "{text}").map_err(CliError::Stdout)?;
    } else {
        print_table(&mut out, &report, a.reference.is_some(), times.as_ref())
            .map_err(CliError::Stdout)?;
    }
    Ok(())
}

/// The program's machining time (and its reference's), read again from
/// the files; `None` for a program on standard input, which is read once.
fn machining_times(
    a: &SimulateArgs,
    machine: &Machine,
) -> Result<Option<TimeComparison>, CliError> {
    if a.program.as_os_str() == "-" {
        return Ok(None);
    }
    let name = a.program.display().to_string();
    let ref_name = a.reference.as_ref().map(|r| r.display().to_string());
    let original = match (&a.reference, &ref_name) {
        (Some(r), Some(n)) => Some((open(r)?, n.as_str())),
        _ => None,
    };
    compare_programs((open(&a.program)?, name.as_str()), original, machine)
        .map(Some)
        .map_err(|e| machine.explain(e))
}

/// The HTML report of a simulation; with a reference, the reference on
/// its own is simulated too, as "before".
fn report_html(
    a: &SimulateArgs,
    machine: &Machine,
    model: &dyn volcomp_core::ErrorModel,
    after: Traced,
    times: Option<&TimeComparison>,
) -> Result<String, CliError> {
    let before = match &a.reference {
        Some(r) => Some(
            trace_program(
                model,
                &machine.0,
                a.chord_tolerance,
                &r.display().to_string(),
                &r.display().to_string(),
                open(r)?,
                None,
                |_| {},
            )
            .map_err(|e| machine.explain(e))?,
        ),
        None => None,
    };
    let want = lines_to_quote(
        &Default::default(),
        None,
        &after.warnings.iter().map(|w| w.0).collect::<Vec<_>>(),
    );
    let quoted = if a.program.as_os_str() == "-" {
        Default::default()
    } else {
        quote_lines(std::io::BufReader::new(open(&a.program)?), &want)
            .map_err(|e| CliError::Io(a.program.clone(), e))?
    };
    let mut inputs = Vec::new();
    if a.program.as_os_str() == "-" {
        inputs.push(InputFile {
            role: "program".into(),
            name: "<standard input>".into(),
            bytes: None,
            sha256: "(standard input: not kept)".into(),
        });
    } else {
        inputs.push(InputFile::read("program", &a.program)?);
    }
    if let Some(r) = &a.reference {
        inputs.push(InputFile::read("reference", r)?);
    }
    inputs.push(InputFile::read("map", &a.map.map)?);
    if let Some(s) = &a.machine.setup {
        inputs.push(InputFile::read("set-up", s)?);
    }
    let mut facts = vec![
        ("command".to_string(), command_line()),
        ("volcomp".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ("date (UTC)".to_string(), date_utc()),
        (
            "chord tolerance".to_string(),
            format!("{} mm", a.chord_tolerance),
        ),
    ];
    facts.extend(setup_facts(&machine.0.setup, None));
    let doc = Document {
        title: format!("volcomp simulation report: {}", a.program.display()),
        facts,
        inputs,
        sections: simulation_sections("", before.as_ref(), &after, &quoted),
    };
    let mut doc = doc;
    if let Some(t) = times {
        doc.sections.push(machining_time_section(t));
    }
    Ok(doc.to_html())
}

/// A reader over a program file ("-" is standard input).
pub fn open(path: &std::path::Path) -> Result<Box<dyn std::io::Read>, CliError> {
    if path.as_os_str() == "-" {
        return Ok(Box::new(std::io::stdin()));
    }
    let f = std::fs::File::open(path).map_err(|e| CliError::Io(path.to_path_buf(), e))?;
    Ok(Box::new(f))
}

fn print_table(
    out: &mut dyn Write,
    r: &SimReport,
    with_reference: bool,
    times: Option<&TimeComparison>,
) -> std::io::Result<()> {
    writeln!(out, "blocks              {}", r.blocks)?;
    writeln!(out, "feed length         {:.3} mm", r.feed_length_mm)?;
    writeln!(
        out,
        "point error         RMS {:8.3} µm   max {:8.3} µm   ({} points)",
        r.point_rms_um, r.point_max_um, r.points
    )?;
    writeln!(
        out,
        "contour error       RMS {:8.3} µm   max {:8.3} µm   ({} samples ≤ 0.05 mm apart)",
        r.contour_rms_um, r.contour_max_um, r.samples
    )?;
    let nominal = if with_reference {
        "the reference program (each line paired with the original block it was written for)"
    } else {
        "this program"
    };
    writeln!(out, "nominal path        {nominal}")?;
    for (label, text) in times.map(TimeComparison::rows).unwrap_or_default() {
        writeln!(out, "{label:<20}{text}")?;
    }
    writeln!(out, "point error:   {}", r.point_definition)?;
    writeln!(out, "contour error: {}", r.contour_definition)
}
