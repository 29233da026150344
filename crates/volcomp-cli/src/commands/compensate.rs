//! `volcomp compensate`.

use super::MachineExt;
use crate::args::CompensateArgs;
use crate::options::Flags;
use crate::output::{check, CliError, OutputPlan, Staged};
use crate::progress::Bar;
use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};
pub use volcomp_core::compensate::file_name;
use volcomp_core::compensate::{CompensateSummary, PointRecord};
use volcomp_core::io::provenance::{now_utc, ProgramHeader};
use volcomp_core::model::ErrorModel;
use volcomp_core::progress::Counted;
use volcomp_core::report::compensation::{
    compensation_sections, header_facts, lines_to_quote, quote_lines, trace_program,
    LargestCorrections,
};
use volcomp_core::report::{Document, InputFile};
use volcomp_core::request::{Compensation, ModelSource};

/// A reader over a program; `-` is standard input.
fn open_program(program: &Path) -> Result<Box<dyn Read>, CliError> {
    if program.as_os_str() == "-" {
        return Ok(Box::new(std::io::stdin().lock()));
    }
    let f = std::fs::File::open(program).map_err(|e| CliError::Io(program.to_path_buf(), e))?;
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
) -> Result<CompensateSummary, CliError> {
    let bar = Bar::reading(&format!("compensating {}", program.display()), program);
    let reader = Counted::new(open_program(program)?, bar.clone());
    let file = program_name(program);
    let result = job
        .compensator(model, &file)
        .on_point(on_point)
        .on_warning(|w| eprintln!("{file}:{w}"))
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
        summary = Some(compensate_into(program, out, job, model, on_point)?);
        Ok(())
    })?;
    staged.commit()?;
    summary.ok_or_else(|| CliError::Internal("compensation produced no summary".into()))
}

/// Lines of a program file, for progress in percent (`None` for standard
/// input, whose length is unknown).
fn count_lines(program: &Path) -> Option<u64> {
    if program.as_os_str() == "-" {
        return None;
    }
    let mut f = std::io::BufReader::new(std::fs::File::open(program).ok()?);
    let mut n = 0u64;
    loop {
        let buf = f.fill_buf().ok()?;
        if buf.is_empty() {
            break;
        }
        n += buf.iter().filter(|&&b| b == b'\n').count() as u64;
        let len = buf.len();
        f.consume(len);
    }
    Some(n.max(1))
}

/// A writer that also keeps a copy of what passes through it.
struct Tee<'a, 'b> {
    inner: &'a mut dyn Write,
    copy: Option<&'b mut Vec<u8>>,
}

impl Write for Tee<'_, '_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        if let Some(c) = self.copy.as_mut() {
            c.extend_from_slice(&buf[..n]);
        }
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
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

/// The files of a program header (map and its tables) as report inputs.
pub fn header_inputs(header: &ProgramHeader) -> Vec<InputFile> {
    header
        .files
        .iter()
        .map(|(label, name, sha)| InputFile {
            role: label.clone(),
            name: name.clone(),
            bytes: std::fs::metadata(name).ok().map(|m| m.len()),
            sha256: sha.clone(),
        })
        .collect()
}

/// The HTML report of a compensation: the original simulated alone
/// ("before") and the compensated program against it ("after").
#[allow(clippy::too_many_arguments)]
fn report_html(
    a: &CompensateArgs,
    output: &Path,
    job: &Compensation,
    model: &dyn ErrorModel,
    summary: &CompensateSummary,
    corrections: &LargestCorrections,
    written: &[u8],
) -> Result<String, CliError> {
    let (machine, header) = (&job.machine, &job.header);
    let name = program_name(&a.program);
    let before = trace_program(
        model,
        &machine.setup,
        a.job.chord_tolerance_mm,
        "before",
        &name,
        open_program(&a.program)?,
        None,
        |_| {},
    )
    .map_err(|e| machine.refused(e))?;
    let after = trace_program(
        model,
        &machine.setup,
        a.job.chord_tolerance_mm,
        "after",
        &shown(output),
        written,
        Some((name.clone(), open_program(&a.program)?)),
        |_| {},
    )
    .map_err(|e| machine.refused(e))?;
    let want = lines_to_quote(
        corrections,
        Some(summary),
        &before.warnings.iter().map(|w| w.0).collect::<Vec<_>>(),
    );
    let quoted = quote_lines(std::io::BufReader::new(open_program(&a.program)?), &want)
        .map_err(|e| CliError::Io(a.program.clone(), e))?;
    let mut inputs = vec![InputFile::read("program", &a.program)?];
    inputs.extend(header_inputs(header));
    if let Some(s) = &machine.setup_file {
        inputs.push(InputFile::read("set-up", s)?);
    }
    let mut facts = vec![
        ("command".to_string(), command_line()),
        ("program".to_string(), name.clone()),
        ("compensated program".to_string(), shown(output)),
    ];
    facts.extend(header_facts(header));
    let doc = Document {
        title: format!("volcomp compensation report: {name}"),
        facts,
        inputs,
        sections: compensation_sections("", &before, &after, summary, corrections, &quoted),
    };
    Ok(doc.to_html())
}

pub fn run(a: CompensateArgs) -> Result<(), CliError> {
    let output = match (&a.output, a.filter) {
        (Some(o), _) => o.clone(),
        (None, _) => PathBuf::from("-"),
    };
    let map_path = a.map.path()?;
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", &a.program)
        .map_input("--map", map_path)
        .input_opt("--controller", a.map.controller.as_ref())
        .input_opt(
            "--setup",
            a.job.machine.setup.as_ref().and_then(|s| s.path()),
        )
        .output(if a.filter { "--filter output" } else { "-o" }, &output)
        .output_opt("--report", a.report.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    if a.report_html.is_some() && a.program.as_os_str() == "-" {
        return Err(CliError::Message(
            "--report-html simulates the original program again after compensating it, so it needs PROGRAM as a file: standard input can be read only once".into(),
        ));
    }
    let machine = super::machine(&a.job.machine)?;
    machine.warn_without_work_offset();
    let model = a.map.load()?;
    let mut job = a
        .job
        .prepare(machine, ModelSource::File(map_path), now_utc(), &Flags)?;
    a.map.note(&mut job.header)?;
    // LinuxCNC's AXIS reads `FILTER_PROGRESS=n` (percent) from a filter's
    // standard error (axis.py, filter_program).
    let total_lines = if a.filter {
        count_lines(&a.program)
    } else {
        None
    };
    let mut percent_shown = 0u64;
    let mut report: Option<Vec<u8>> = a.report.as_ref().map(|_| {
        b"line,target_x_mm,target_y_mm,target_z_mm,command_x_mm,command_y_mm,command_z_mm,iterations,residual_um,reversed,held,take_up\n".to_vec()
    });
    let mut staged = Staged::new();
    let mut summary = None;
    let mut report_too_big = false;
    // The compensated program, kept for the HTML report's simulation.
    let mut written: Option<Vec<u8>> = a.report_html.as_ref().map(|_| Vec::new());
    let mut corrections = LargestCorrections::default();
    staged.write(&output, |out| {
        let mut tee = Tee {
            inner: out,
            copy: written.as_mut(),
        };
        let mut out = volcomp_core::limits::LimitedWriter::new(&mut tee, job.max_output_bytes);
        summary = Some(compensate_into(
            &a.program,
            &mut out,
            &job,
            model.as_ref(),
            |p| {
                if a.report_html.is_some() {
                    corrections.push(p);
                }
                if let Some(total) = total_lines {
                    let pct = (p.line.saturating_mul(100) / total).min(99);
                    if pct > percent_shown {
                        percent_shown = pct;
                        eprintln!("FILTER_PROGRESS={pct}");
                    }
                }
                if let Some(r) = report.as_mut() {
                    if job.max_output_bytes.is_some_and(|max| r.len() as u64 > max) {
                        report_too_big = true;
                        return;
                    }
                    let axes = |f: [bool; 3]| -> String {
                        ['X', 'Y', 'Z']
                            .iter()
                            .zip(f)
                            .filter(|(_, b)| *b)
                            .map(|(c, _)| *c)
                            .collect()
                    };
                    let _ = writeln!(
                        r,
                        "{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{:.6},{},{},{}",
                        p.line,
                        p.target_mm.x,
                        p.target_mm.y,
                        p.target_mm.z,
                        p.command_mm.x,
                        p.command_mm.y,
                        p.command_mm.z,
                        p.iterations,
                        p.residual_um,
                        axes(p.reversed),
                        axes(p.held),
                        p.take_up
                    );
                }
            },
        )?);
        Ok(())
    })?;
    if report_too_big {
        return Err(CliError::Message(format!(
            "the --report file would exceed the limit of {} bytes (--max-output-size); nothing was written",
            job.max_output_bytes.unwrap_or(u64::MAX)
        )));
    }
    if let (Some(path), Some(bytes)) = (&a.report, report) {
        staged.write(path, |w| {
            w.write_all(&bytes)
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    let summary =
        summary.ok_or_else(|| CliError::Internal("compensation produced no summary".into()))?;
    if let (Some(path), Some(written)) = (&a.report_html, written) {
        let html = report_html(
            &a,
            &output,
            &job,
            model.as_ref(),
            &summary,
            &corrections,
            &written,
        )?;
        staged.write(path, |w| {
            w.write_all(html.as_bytes())
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    staged.commit()?;
    if a.filter {
        eprintln!("FILTER_PROGRESS=100");
    }
    let shown = if output.as_os_str() == "-" {
        "standard output".to_string()
    } else {
        output.display().to_string()
    };
    crate::note!(
        "volcomp: wrote {} ({} lines from {}; {} points compensated, largest correction {:.2} µm, largest residual {:.4} µm, {} take-up moves, {} take-ups folded into their moves)",
        shown,
        summary.lines_out,
        summary.lines_in,
        summary.points,
        summary.max_correction_um,
        summary.max_residual_um,
        summary.take_ups,
        summary.take_ups_folded
    );
    let ratio = if summary.blocks_in > 0 {
        format!(
            " (x{:.2})",
            summary.blocks_out as f64 / summary.blocks_in as f64
        )
    } else {
        String::new()
    };
    crate::note!(
        "volcomp: size {} -> {} bytes, {} -> {} blocks{ratio}; largest contour deviation the segmentation leaves: {}",
        summary.bytes_in,
        summary.bytes_out,
        summary.blocks_in,
        summary.blocks_out,
        match summary.max_estimated_contour_um {
            Some(um) => format!("{um:.3} µm estimated (plus the rounding of the written numbers)"),
            None => "not estimated (fixed segmentation)".into(),
        }
    );
    if summary.held_count > 0 {
        let first: Vec<String> = summary
            .held
            .iter()
            .take(10)
            .map(|(l, a)| format!("line {l} ({a})"))
            .collect();
        eprintln!(
            "volcomp: warning: {} point(s) kept an axis still because the map's reversal value is negative there (forward error above reverse), so no command can reverse by less than it: {}",
            summary.held_count,
            first.join(", ")
        );
    }
    Ok(())
}
