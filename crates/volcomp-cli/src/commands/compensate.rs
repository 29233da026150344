//! `volcomp compensate`.

use super::Machine;
use crate::args::{CompensateArgs, ControllerCompensates, MapArgs, Method as MethodArg};
use crate::output::{check, CliError, OutputPlan, Staged};
use crate::progress::Bar;
use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};
pub use volcomp_core::compensate::file_name;
use volcomp_core::compensate::solve::Method;
use volcomp_core::compensate::{
    header_for_map, CompensateOptions, CompensateSummary, Compensator, DirectionPolicy,
    PointRecord, Segmentation,
};
use volcomp_core::io::controllers;
use volcomp_core::io::provenance::{iso8601_utc, ProgramHeader};
use volcomp_core::model::controller::{ControllerApplies, ControllerResidual};
use volcomp_core::model::ErrorModel;
use volcomp_core::plan::{compare_programs, TimeComparison};
use volcomp_core::progress::Counted;
use volcomp_core::report::compensation::{
    compensation_sections, header_facts, lines_to_quote, quote_lines, trace_program,
    LargestCorrections,
};
use volcomp_core::report::machining_time::machining_time_section;
use volcomp_core::report::{Document, InputFile};

/// Loads the error map named by `--map`; with `--controller` or
/// `--controller-compensates`, the residual the controller leaves
/// (`volcomp_core::model::controller`).
pub fn load_map(a: &MapArgs) -> Result<Box<dyn ErrorModel>, CliError> {
    // Axis tables (.csv), a 21-component kinematic model or a straightness
    // model (TOML, told apart by their `model` key): docs/kinematic.md.
    let map = super::map::load(&a.map, a.clamp)?.into_model();
    let controller = match (&a.controller, a.controller_compensates) {
        (Some(file), _) => controllers::read_applies(file)?,
        (None, Some(ControllerCompensates::Positioning)) => ControllerApplies::MapPositioning,
        (None, None) => return Ok(map),
    };
    Ok(Box::new(ControllerResidual { map, controller }))
}

/// Adds the controller file (`--controller`) to a program's header, so the
/// program says which controller table it was made for.
pub fn note_controller(header: &mut ProgramHeader, a: &MapArgs) -> Result<(), CliError> {
    if let Some(file) = &a.controller {
        let bytes = std::fs::read(file).map_err(|e| CliError::Io(file.clone(), e))?;
        let name = file
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| file.display().to_string());
        header.files.push((
            "ctrl".into(),
            name,
            volcomp_core::io::provenance::sha256_hex(&bytes),
        ));
    }
    if a.controller_compensates.is_some() {
        header
            .options
            .push_str("; the controller compensates the positioning errors");
    }
    Ok(())
}

/// Validated options from the raw flags.
pub fn options(a: &CompensateArgs) -> Result<CompensateOptions, CliError> {
    let method = match a.method {
        MethodArg::Exact => Method::Exact,
        MethodArg::Direct => Method::Direct,
        MethodArg::Pitch => Method::Pitch,
        MethodArg::Ilc => {
            if !(a.gain > 0.0 && a.gain <= 1.0) {
                return Err(CliError::Message(format!(
                    "--gain must satisfy 0 < γ ≤ 1; got {}",
                    a.gain
                )));
            }
            Method::Ilc {
                gain: a.gain,
                max_iterations: a.max_iterations,
            }
        }
    };
    let segmentation = match (
        a.no_split,
        a.segments,
        a.segment_length,
        a.contour_tolerance_um,
    ) {
        (true, ..) => Segmentation::Off,
        (_, Some(0), ..) => return Err(CliError::Message("--segments must be at least 1".into())),
        (_, Some(n), ..) => Segmentation::Count(n),
        (_, _, Some(l), _) if !(l.is_finite() && l > 0.0) => {
            return Err(CliError::Message(format!(
                "--segment-length must be a positive length in mm; got {l}"
            )))
        }
        (_, _, Some(l), _) => Segmentation::MaxLength(l),
        (_, _, _, t) => {
            let t = t.unwrap_or(volcomp_core::compensate::DEFAULT_CONTOUR_TOLERANCE_UM);
            let positive = |v: f64| v.is_finite() && v > 0.0;
            if !(positive(t) && positive(a.min_segment_length)) {
                return Err(CliError::Message(
                    "--contour-tolerance-um and --min-segment-length must be positive".into(),
                ));
            }
            Segmentation::Adaptive {
                tolerance_mm: t * 1e-3,
                min_length_mm: a.min_segment_length,
            }
        }
    };
    if !(a.chord_tolerance.is_finite() && a.chord_tolerance > 0.0) {
        return Err(CliError::Message(
            "--chord-tolerance must be a positive length in mm".into(),
        ));
    }
    if !(a.max_correction.is_finite() && a.max_correction > 0.0) {
        return Err(CliError::Message(format!(
            "--max-correction must be a positive length in mm; got {}",
            a.max_correction
        )));
    }
    if matches!(a.method, MethodArg::Ilc) && a.max_iterations == 0 {
        return Err(CliError::Message(
            "--max-iterations must be at least 1 (ILC needs one step to move any point)".into(),
        ));
    }
    if !(a.max_residual_um.is_finite() && a.max_residual_um > 0.0) {
        return Err(CliError::Message(format!(
            "--max-residual-um must be a positive number of µm; got {}",
            a.max_residual_um
        )));
    }
    if let Some(t) = a.take_up_tolerance_um {
        if !(t.is_finite() && t > 0.0) {
            return Err(CliError::Message(format!(
                "--take-up-tolerance-um must be a positive number of µm; got {t}"
            )));
        }
    }
    if a.decimals.is_some_and(|d| !(1..=9).contains(&d)) {
        return Err(CliError::Message("--decimals must be 1 … 9".into()));
    }
    Ok(CompensateOptions {
        method,
        segmentation,
        chord_tolerance_mm: a.chord_tolerance,
        arcs_as_arcs: !a.arcs_as_lines,
        decimals: a.decimals,
        max_correction_mm: a.max_correction,
        directions: if a.nominal_directions {
            DirectionPolicy::Nominal
        } else {
            DirectionPolicy::Commanded
        },
        take_up: !a.no_take_up,
        fold_take_ups: !a.separate_take_ups,
        take_up_tolerance_mm: a.take_up_tolerance_um.map(|t| t * 1e-3),
        trace_comments: !a.no_trace,
        // Direct and pitch do not aim at the full model's target: their
        // residual is the method's own error, checked for finiteness only.
        max_residual_um: matches!(a.method, MethodArg::Exact | MethodArg::Ilc)
            .then_some(a.max_residual_um),
    })
}

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

/// Now as ISO 8601 UTC, or `SOURCE_DATE_EPOCH` when set (the
/// reproducible-builds convention), so a run can be repeated byte for byte.
pub fn date_utc() -> String {
    let secs = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs() as i64)
                .unwrap_or(0)
        });
    iso8601_utc(secs)
}

/// The header of a program compensated with `map` (and the tables it
/// names), the set-up file and the set-up used.
pub fn header_for(
    map: &Path,
    setup_file: Option<&Path>,
    machine: &Machine,
    options: &CompensateOptions,
) -> Result<ProgramHeader, CliError> {
    header_for_map(map, setup_file, &machine.setup, options, date_utc()).map_err(|e| match e {
        volcomp_core::Error::Io { path, source } => CliError::Io(path, source),
        e => CliError::from(e),
    })
}

/// Refuses a program whose first bytes show an earlier compensation.
pub fn refuse_if_compensated(head: &[u8], file: &str) -> Result<(), CliError> {
    Ok(volcomp_core::compensate::refuse_if_compensated(head, file)?)
}

/// Compensates `program` into `out` with `header` at its top; refuses a
/// program volcomp compensated already unless `allow_recompensate`.
#[allow(clippy::too_many_arguments)]
pub fn compensate_into(
    program: &Path,
    out: &mut dyn Write,
    machine: &Machine,
    model: &dyn ErrorModel,
    options: &CompensateOptions,
    header: &ProgramHeader,
    allow_recompensate: bool,
    on_point: impl FnMut(&PointRecord),
) -> Result<CompensateSummary, CliError> {
    let bar = Bar::reading(&format!("compensating {}", program.display()), program);
    let reader = Counted::new(open_program(program)?, bar.clone());
    let file = program_name(program);
    let result = Compensator::new(model)
        .setup(machine.0.clone())
        .options(*options)
        .header(header.clone())
        .file_name(file.as_str())
        .allow_recompensate(allow_recompensate)
        .on_point(on_point)
        .on_warning(|w| eprintln!("{file}:{w}"))
        .run(reader, out)
        .map_err(|e| machine.explain(e));
    bar.finish();
    result
}

/// Compensates `program` into the file `output` (completely or not at all).
pub fn compensate_file(
    program: &Path,
    output: &Path,
    machine: &Machine,
    model: &dyn ErrorModel,
    options: &CompensateOptions,
    header: &ProgramHeader,
    on_point: impl FnMut(&PointRecord),
) -> Result<CompensateSummary, CliError> {
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", program).output("-o", output);
    check(&plan)?;
    let mut summary = None;
    let mut staged = Staged::new();
    staged.write(output, |out| {
        summary = Some(compensate_into(
            program, out, machine, model, options, header, false, on_point,
        )?);
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
    machine: &Machine,
    model: &dyn ErrorModel,
    header: &ProgramHeader,
    summary: &CompensateSummary,
    corrections: &LargestCorrections,
    written: &[u8],
    times: Option<&TimeComparison>,
) -> Result<String, CliError> {
    let name = program_name(&a.program);
    let before = trace_program(
        model,
        &machine.0,
        a.chord_tolerance,
        "before",
        &name,
        open_program(&a.program)?,
        None,
        |_| {},
    )
    .map_err(|e| machine.explain(e))?;
    let after = trace_program(
        model,
        &machine.0,
        a.chord_tolerance,
        "after",
        &shown(output),
        written,
        Some((name.clone(), open_program(&a.program)?)),
        |_| {},
    )
    .map_err(|e| machine.explain(e))?;
    let want = lines_to_quote(
        corrections,
        Some(summary),
        &before.warnings.iter().map(|w| w.0).collect::<Vec<_>>(),
    );
    let quoted = quote_lines(std::io::BufReader::new(open_program(&a.program)?), &want)
        .map_err(|e| CliError::Io(a.program.clone(), e))?;
    let mut inputs = vec![InputFile::read("program", &a.program)?];
    inputs.extend(header_inputs(header));
    if let Some(s) = &a.machine.setup {
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
    let mut doc = doc;
    if let Some(t) = times {
        doc.sections.push(machining_time_section(t));
    }
    Ok(doc.to_html())
}

/// The machining time of the original (when it can be read again) and of
/// the compensated program (`written`, or the output file).
fn machining_times(
    a: &CompensateArgs,
    output: &Path,
    machine: &Machine,
    written: Option<&[u8]>,
) -> Result<TimeComparison, CliError> {
    let name = program_name(&a.program);
    let original = if a.program.as_os_str() == "-" {
        None
    } else {
        Some((open_program(&a.program)?, name.as_str()))
    };
    let out_name = shown(output);
    let compensated: Box<dyn Read> = match written {
        Some(w) => Box::new(w),
        None => Box::new(
            std::fs::File::open(output).map_err(|e| CliError::Io(output.to_path_buf(), e))?,
        ),
    };
    compare_programs((compensated, out_name.as_str()), original, machine)
        .map_err(|e| machine.explain(e))
}

pub fn run(a: CompensateArgs) -> Result<(), CliError> {
    let output = match (&a.output, a.filter) {
        (Some(o), _) => o.clone(),
        (None, _) => PathBuf::from("-"),
    };
    let mut plan = OutputPlan::new();
    plan.input("PROGRAM", &a.program)
        .map_input("--map", &a.map.map)
        .input_opt("--controller", a.map.controller.as_ref())
        .input_opt("--setup", a.machine.setup.as_ref())
        .output(if a.filter { "--filter output" } else { "-o" }, &output)
        .output_opt("--report", a.report.as_ref())
        .output_opt("--report-html", a.report_html.as_ref());
    check(&plan)?;
    if a.report_html.is_some() && a.program.as_os_str() == "-" {
        return Err(CliError::Message(
            "--report-html simulates the original program again after compensating it, so it needs PROGRAM as a file: standard input can be read only once".into(),
        ));
    }
    let machine = Machine(
        Machine::from_args(&a.machine)?
            .0
            .with_spline_tolerance(a.chord_tolerance),
    );
    machine.warn_without_work_offset();
    let model = load_map(&a.map)?;
    let opts = options(&a)?;
    let mut header = header_for(&a.map.map, a.machine.setup.as_deref(), &machine, &opts)?;
    note_controller(&mut header, &a.map)?;
    if a.machine.work_offset.is_some() {
        header.work_offset_note = Some("G54 from --work-offset".into());
    }
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
    // (and for the machining time when the output goes to standard output)
    let to_stdout = output.as_os_str() == "-";
    let mut written: Option<Vec<u8>> =
        (a.report_html.is_some() || (to_stdout && !crate::progress::quiet())).then(Vec::new);
    let mut corrections = LargestCorrections::default();
    staged.write(&output, |out| {
        let mut tee = Tee {
            inner: out,
            copy: written.as_mut(),
        };
        let mut out = volcomp_core::limits::LimitedWriter::new(&mut tee, a.max_output_size.0);
        summary = Some(compensate_into(
            &a.program,
            &mut out,
            &machine,
            model.as_ref(),
            &opts,
            &header,
            a.allow_recompensate,
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
                    if a.max_output_size.0.is_some_and(|max| r.len() as u64 > max) {
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
            a.max_output_size.0.unwrap_or(u64::MAX)
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
    let mut times = None;
    if let (Some(path), Some(written)) = (&a.report_html, &written) {
        times = Some(machining_times(&a, &output, &machine, Some(written))?);
        let html = report_html(
            &a,
            &output,
            &machine,
            model.as_ref(),
            &header,
            &summary,
            &corrections,
            written,
            times.as_ref(),
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
    if !crate::progress::quiet() {
        let times = match times {
            Some(t) => t,
            None => machining_times(
                &a,
                &output,
                &machine,
                written.as_deref().filter(|_| to_stdout),
            )?,
        };
        for line in times.summary_lines() {
            eprintln!("volcomp: {line}");
        }
    }
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
