//! `volcomp simulate`.

use super::compensate::command_line;
use super::{Machine, MachineExt};
use crate::args::SimulateArgs;
use crate::output::{check, write_file, CliError, OutputPlan};
use crate::plot::{charts, write_charts};
use crate::progress::Bar;
use std::io::Write;
use std::path::Path;
use volcomp_core::model::ErrorModel;
use volcomp_core::progress::Counted;
use volcomp_core::report::compensation::{
    segment_csv_row, simulation_text, Traced, SEGMENT_CSV_HEADER,
};
use volcomp_core::report::trace::PathTrace;

/// What a run kept for its outputs: the simulation (metrics, trace,
/// warnings), the per-segment CSV, the errors along the path.
struct Kept {
    traced: Traced,
    errors_csv: Option<String>,
    along: Vec<(f64, Option<f64>, f64)>,
}

fn plan(a: &SimulateArgs) -> Result<(), CliError> {
    a.job.chord_tolerance_mm()?;
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", &a.program)
        .map_input("--map", a.map.path()?)
        .input_opt("--controller", a.map.controller.as_ref())
        .input_opt(
            "--setup",
            a.job.machine.setup.as_ref().and_then(|s| s.path()),
        )
        .input_opt(
            "--reference",
            a.job.reference.as_ref().and_then(|r| r.path()),
        )
        .output_opt("--errors-csv", a.errors_csv.as_ref())
        .output_opt("--plot", a.plot.as_ref())
        .output_opt("--report-html", a.report_html.as_ref())
        .input_opt("--report-title", a.title.report_title.as_ref());
    check(&plan)
}

/// Simulates the program, keeping what the outputs asked for need.
fn simulate(a: &SimulateArgs, machine: &Machine, model: &dyn ErrorModel) -> Result<Kept, CliError> {
    let name = a.program.display().to_string();
    let simulation = a.job.simulation(model, machine, &name)?;
    let mut errors_csv = a
        .errors_csv
        .as_ref()
        .map(|_| SEGMENT_CSV_HEADER.to_string());
    let mut along: Vec<(f64, Option<f64>, f64)> = Vec::new();
    let mut last: Option<volcomp_gcode::Vec3> = None;
    let mut travelled = 0.0;
    let mut trace = PathTrace::default();
    let bar = Bar::reading(&format!("simulating {}", a.program.display()), &a.program);
    let mut warnings: Vec<(u64, String)> = Vec::new();
    let report = simulation
        .on_warning(|w| {
            eprintln!("{}", crate::output::clean(&format!("{name}:{w}")));
            warnings.push((w.line, w.message.clone()));
        })
        .on_segment(|s| {
            if a.report_html.is_some() {
                trace.push(s);
            }
            if let Some(p) = last {
                travelled += (s.command_mm - p).norm();
            }
            last = Some(s.command_mm);
            if a.plot.is_some() {
                along.push((travelled, s.point_um, s.contour_max_um));
            }
            if let Some(r) = errors_csv.as_mut() {
                segment_csv_row(s, r);
            }
        })
        .run(Counted::new(open(&a.program)?, bar.clone()));
    bar.finish();
    let report = report.map_err(|e| machine.refused(e))?;
    let traced = Traced {
        label: name,
        report,
        trace,
        warnings,
    };
    Ok(Kept {
        traced,
        errors_csv,
        along,
    })
}

pub fn run(a: SimulateArgs) -> Result<(), CliError> {
    plan(&a)?;
    let title_block = a.title.title_block(a.report_html.is_some())?;
    let machine = a.job.prepare(super::machine(&a.job.machine)?)?;
    machine.warn_without_work_offset();
    let (model, notes) = a.map.load_noting()?;
    // What reading the controller's files assumed or found ignored.
    for n in notes {
        crate::note!("volcomp: note: {n}");
    }
    let kept = simulate(&a, &machine, model.as_ref())?;
    let mut inputs = vec![a.program.as_path()];
    inputs.extend(a.job.reference.as_ref().and_then(|r| r.path()));
    let write = |path: &Path, bytes: &[u8]| write_file(path, &inputs, bytes);
    if let (Some(path), Some(csv)) = (&a.errors_csv, &kept.errors_csv) {
        write(path, csv.as_bytes())?;
    }
    if let Some(path) = &a.plot {
        write_charts(&[charts::simulate_chart(&a.program, &kept.along)], path)?;
    }
    if let Some(path) = &a.report_html {
        let html = a
            .job
            .report_html(
                model.as_ref(),
                &machine,
                &a.program,
                a.map.path()?,
                &kept.traced,
                &command_line(),
                &title_block,
            )
            .map_err(|e| machine.refused(e))?;
        write(path, html.as_bytes())?;
    }
    let report = &kept.traced.report;
    let time = a
        .job
        .machining_time(&machine, &a.program)
        .map_err(|e| machine.refused(e))?;
    let text = if a.json {
        /// The simulation's figures and the machining time in one object.
        #[derive(serde::Serialize)]
        struct Json<'a> {
            #[serde(flatten)]
            report: &'a volcomp_core::SimReport,
            machining_time: Option<&'a volcomp_core::plan::TimeComparison>,
        }
        let json = Json {
            report,
            machining_time: time.as_ref(),
        };
        serde_json::to_string(&json)? + "\n"
    } else {
        let mut text = simulation_text(report, a.job.reference.is_some());
        for (label, line) in time.iter().flat_map(|t| t.rows()) {
            text.push_str(&format!("{label:<20}{line}\n"));
        }
        text
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(CliError::Stdout)
}

/// A reader over a program file ("-" is standard input).
pub fn open(path: &std::path::Path) -> Result<Box<dyn std::io::Read>, CliError> {
    if path.as_os_str() == "-" {
        volcomp_core::io::inputs::record_stdin("the program (standard input)");
        return Ok(Box::new(std::io::stdin()));
    }
    let f = volcomp_core::io::inputs::open(path, "a program")
        .map_err(|e| CliError::Io(path.to_path_buf(), e))?;
    Ok(Box::new(f))
}
