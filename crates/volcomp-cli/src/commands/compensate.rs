//! `volcomp compensate`.

use super::MachineExt;
use crate::args::CompensateArgs;
use crate::options::Flags;
use crate::output::{check, CliError, OutputPlan, Staged};
use crate::progress::Bar;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use volcomp_core::compensate::{CompensateSummary, PointRecord};
use volcomp_core::io::provenance::now_utc;
use volcomp_core::io::stream::{LinePercent, Tee};
use volcomp_core::limits::LimitedWriter;
use volcomp_core::model::ErrorModel;
use volcomp_core::plan::TimeComparison;
use volcomp_core::progress::Counted;
use volcomp_core::report::compensation::{
    held_warning, point_csv_row, summary_lines, uncompensated_warning, LargestCorrections,
    POINT_CSV_HEADER,
};
use volcomp_core::request::{Compensation, ModelSource, RunNames};

/// A reader over a program; `-` is standard input.
fn open_program(program: &Path) -> Result<Box<dyn Read>, CliError> {
    if program.as_os_str() == "-" {
        volcomp_core::io::inputs::record_stdin("the program (standard input)");
        return Ok(Box::new(std::io::stdin().lock()));
    }
    let f = volcomp_core::io::inputs::open(program, "the program")
        .map_err(|e| CliError::Io(program.to_path_buf(), e))?;
    Ok(Box::new(f))
}

/// The program's name in messages.
fn program_name(program: &Path) -> String {
    if program.as_os_str() == "-" {
        "<standard input>".into()
    } else {
        program.display().to_string()
    }
}

/// Compensates `program` into `out` as `job` says.
pub fn compensate_into(
    program: &Path,
    out: &mut dyn Write,
    job: &Compensation,
    model: &dyn ErrorModel,
    on_point: impl FnMut(&PointRecord),
    program_copy: Option<&mut dyn Write>,
    on_line: Option<&mut dyn FnMut(&volcomp_gcode::LineEvent<'_>)>,
) -> Result<CompensateSummary, CliError> {
    let bar = Bar::reading(&format!("compensating {}", program.display()), program);
    let reader = Counted::new(open_program(program)?, bar.clone());
    let file = program_name(program);
    let mut compensator = job
        .compensator(model, &file)
        .on_point(on_point)
        .on_warning(|w| eprintln!("{file}:{w}"));
    if let Some(copy) = program_copy {
        compensator = compensator.copy_program_to(copy);
    }
    if let Some(f) = on_line {
        compensator = compensator.on_line(f);
    }
    let result = compensator
        .run(reader, out)
        .map_err(|e| job.machine.refused(e));
    bar.finish();
    result
}

/// Compensates `program` into the file `output` (completely or not at all).
pub fn compensate_file(
    program: &Path,
    output: &Path,
    job: &Compensation,
    model: &dyn ErrorModel,
    on_point: impl FnMut(&PointRecord),
) -> Result<CompensateSummary, CliError> {
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", program).output("-o", output);
    check(&plan)?;
    let mut summary = None;
    let mut staged = Staged::new();
    staged.write(output, |out| {
        summary = Some(compensate_into(
            program, out, job, model, on_point, None, None,
        )?);
        Ok(())
    })?;
    staged.commit()?;
    summary.ok_or_else(|| CliError::Internal("compensation produced no summary".into()))
}

/// Where the report names a program.
fn shown(path: &Path) -> String {
    if path.as_os_str() == "-" {
        "standard output".into()
    } else {
        path.display().to_string()
    }
}

/// The command line as typed, for a report.
pub fn command_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

/// What the run kept besides the program: the summary, the largest
/// corrections and the program written (for the HTML report), the
/// per-point CSV.
struct Kept {
    summary: CompensateSummary,
    corrections: LargestCorrections,
    written: Option<Vec<u8>>,
    points_csv: Option<String>,
}

/// The inputs and outputs of a run, checked before any work.
fn plan(a: &CompensateArgs, map: &Path, output: &Path) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", &a.program)
        .map_input("--map", map)
        .input_opt("--controller", a.map.controller.as_ref())
        .input_opt(
            "--setup",
            a.job.machine.setup.as_ref().and_then(|s| s.path()),
        )
        .output(if a.filter { "--filter output" } else { "-o" }, output)
        .output_opt("--report", a.report.as_ref())
        .output_opt("--report-html", a.report_html.as_ref())
        .input_opt("--report-title", a.title.report_title.as_ref());
    check(&plan)?;
    if a.report_html.is_some() && a.program.as_os_str() == "-" {
        return Err(CliError::Message(
            "--report-html simulates the original program again after compensating it, so it needs PROGRAM as a file: standard input can be read only once".into(),
        ));
    }
    Ok(())
}

/// What the machining-time estimate gets while the program is written:
/// the program as it is made, and each line of the original as the
/// compensation reads it (`plan::compare_while_writing_fed`).
type Feeds<'a, 'b> = (
    Option<&'a mut dyn Write>,
    Option<&'b mut dyn FnMut(&volcomp_gcode::LineEvent<'_>)>,
);

/// Writes the compensated program to `output`, keeping what the other
/// outputs need. As a LinuxCNC filter, prints `FILTER_PROGRESS=n`
/// (percent), which AXIS reads from a filter's standard error (axis.py,
/// filter_program).
fn write_program(
    a: &CompensateArgs,
    output: &Path,
    job: &Compensation,
    model: &dyn ErrorModel,
    staged: &mut Staged,
    (stream, on_line): Feeds<'_, '_>,
) -> Result<Kept, CliError> {
    let mut percent = a.filter.then(|| LinePercent::of(&a.program));
    let mut points_csv = a.report.as_ref().map(|_| POINT_CSV_HEADER.to_string());
    let mut corrections = LargestCorrections::default();
    // Kept for the HTML report.
    let mut written = a.report_html.is_some().then(Vec::new);
    let mut summary = None;
    let max = job.max_output_bytes;
    staged.write(output, |out| {
        // The machining-time estimate's stream gets the program from the
        // compensation as it is made, not the output (whose header, and so
        // all of it, waits for the end).
        let mut tee = Tee {
            inner: out,
            copy: written.as_mut(),
            stream: None,
        };
        let mut out = LimitedWriter::new(&mut tee, max);
        let on_point = |p: &PointRecord| {
            corrections.push(p);
            if let Some(pct) = percent.as_mut().and_then(|l| l.at(p.line)) {
                eprintln!("FILTER_PROGRESS={pct}");
            }
            // Past the size limit the report is refused below.
            if let Some(r) = points_csv
                .as_mut()
                .filter(|r| max.is_none_or(|m| r.len() as u64 <= m))
            {
                point_csv_row(p, r);
            }
        };
        summary = Some(compensate_into(
            &a.program, &mut out, job, model, on_point, stream, on_line,
        )?);
        Ok(())
    })?;
    if let Some(r) = &points_csv {
        if max.is_some_and(|m| r.len() as u64 > m) {
            return Err(CliError::Message(format!(
                "the --report file would exceed the limit of {} bytes (--max-output-size); nothing was written",
                max.unwrap_or(u64::MAX)
            )));
        }
    }
    let summary =
        summary.ok_or_else(|| CliError::Internal("compensation produced no summary".into()))?;
    Ok(Kept {
        summary,
        corrections,
        written,
        points_csv,
    })
}

pub fn run(a: CompensateArgs) -> Result<(), CliError> {
    let output = a.output.clone().unwrap_or_else(|| PathBuf::from("-"));
    let map_path = a.map.path()?;
    plan(&a, map_path, &output)?;
    let title_block = a.title.title_block(a.report_html.is_some())?;
    a.job.check_map(&a.map)?;
    let machine = super::machine(&a.job.machine)?;
    machine.warn_without_work_offset();
    let (model, notes) = a.map.load_noting()?;
    // What reading the controller's files assumed or found ignored.
    for n in notes {
        crate::note!("volcomp: note: {n}");
    }
    let mut job = a
        .job
        .prepare(machine, ModelSource::File(map_path), now_utc(), &Flags)?;
    a.map.note(&mut job.header)?;
    let mut staged = Staged::new();
    // The machining time is estimated while the program is
    // written, when it will be (not quiet, the output readable back).
    let readable = readable_output(&a, &output);
    let (kept, time) = if !crate::progress::quiet() && readable {
        let (kept, time) =
            job.machining_time_while(&a.program, &shown(&output), |sink, on_line| {
                let feeds = (Some(sink), Some(on_line));
                write_program(&a, &output, &job, model.as_ref(), &mut staged, feeds)
            })?;
        // The estimate read the program as made, without the header the
        // output has on top: its errors are located in the written file.
        let time = time.map_err(|e| kept.summary.header.locate_in_written(e));
        (kept, Some(time))
    } else {
        let kept = write_program(&a, &output, &job, model.as_ref(), &mut staged, (None, None))?;
        (kept, None)
    };
    if let (Some(path), Some(csv)) = (&a.report, &kept.points_csv) {
        staged.write_bytes(path, csv.as_bytes())?;
    }
    if let (Some(path), Some(written)) = (&a.report_html, &kept.written) {
        let names = RunNames {
            command: &command_line(),
            program: &program_name(&a.program),
            output: &shown(&output),
            title_block: &title_block,
        };
        let html = job
            .report_html(
                model.as_ref(),
                &a.program,
                written,
                &kept.summary,
                &kept.corrections,
                names,
            )
            .map_err(|e| job.machine.refused(e))?;
        staged.write_bytes(path, html.as_bytes())?;
    }
    staged.commit()?;
    if a.filter {
        eprintln!("FILTER_PROGRESS=100");
    }
    for line in summary_lines(&kept.summary, &shown(&output)) {
        crate::note!("volcomp: {line}");
    }
    machining_time(&job, time, readable, &output)?;
    if let Some(w) = held_warning(&kept.summary) {
        eprintln!("volcomp: warning: {w}");
    }
    if let Some(w) = uncompensated_warning(&kept.summary) {
        eprintln!("volcomp: warning: {}", crate::options::flags(&w));
    }
    Ok(())
}

/// Whether the compensated program's machining time is estimated (while
/// it is written): where it could also be read back, so that `volcomp
/// time` on the output gives the same figure (standard output, or a
/// regular file; not a pipe, a FIFO or /dev/stdout, read from its
/// reading end, nor /dev/null, which reads empty; a new output is made a
/// regular file).
fn readable_output(a: &CompensateArgs, output: &Path) -> bool {
    let streamed = a.report_html.is_some() || output.as_os_str() == "-";
    streamed
        || match std::fs::metadata(output) {
            Ok(m) => m.file_type().is_file(),
            Err(e) => e.kind() == std::io::ErrorKind::NotFound,
        }
}

/// The machining time of the compensated program beside the original's,
/// on standard error (unless quiet).
fn machining_time(
    job: &Compensation,
    time: Option<Result<TimeComparison, volcomp_core::Error>>,
    readable: bool,
    output: &Path,
) -> Result<(), CliError> {
    if !crate::progress::quiet() && !readable {
        eprintln!(
            "volcomp: machining time not estimated: {} is not a regular file (run `volcomp time` on a copy of the program)",
            shown(output)
        );
    }
    if let Some(time) = time {
        let time = time.map_err(|e| job.machine.refused(e))?;
        for line in time.summary_lines() {
            eprintln!("volcomp: {line}");
        }
    }
    Ok(())
}
