//! One function per subcommand: validate flags into library options, run,
//! print.

use crate::args::{Cli, Command, MachineArgs, MovesArgs, MovesFormat};
use crate::output::CliError;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Write};
use std::path::Path;
use volcomp_core::error::CompensationError;
use volcomp_core::MachineSetup;
use volcomp_gcode::number::{format_number_bytes, NumberStyle};
use volcomp_gcode::{InterpOptions, Motion, MotionKind, Vec3, Walker};

mod compensate;
pub use compensate::{command_line, date_utc};
mod demo;
pub mod map;
mod simulate;
pub mod straightness;
pub mod surface;
pub mod thermal;

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Moves(a) => moves(a),
        Command::Compensate(a) => compensate::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Map(a) => map::run(a),
        Command::Surface(a) => surface::run(a),
        Command::Straightness(a) => straightness::run(a),
        Command::Thermal(a) => thermal::run(a),
    }
}

/// The validated machine set-up of a program (the library's
/// [`MachineSetup`]), with the CLI's rendering of its errors.
pub struct Machine(pub MachineSetup);

impl std::ops::Deref for Machine {
    type Target = MachineSetup;
    fn deref(&self) -> &MachineSetup {
        &self.0
    }
}

/// The first words of every message about a missing work offset.
pub const NO_WORK_OFFSET: &str = "no work offset was given (G54 = 0)";

/// Parses `X,Y,Z` (three finite numbers).
pub fn parse_triple(text: &str, flag: &str) -> Result<Vec3, CliError> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let nums: Option<Vec<f64>> = parts.iter().map(|p| p.parse::<f64>().ok()).collect();
    match nums {
        Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => {
            Ok(Vec3::new(v[0], v[1], v[2]))
        }
        _ => Err(CliError::Message(format!(
            "{flag} expects three numbers in mm separated by commas, like 100,50,-200; got `{text}`"
        ))),
    }
}

impl Machine {
    pub fn from_args(a: &MachineArgs) -> Result<Machine, CliError> {
        let mut machine = match &a.setup {
            Some(path) => MachineSetup::from_setup_file(path).map_err(|e| match e {
                volcomp_core::Error::Io { path, source } => CliError::Io(path, source),
                e => CliError::from(e),
            })?,
            None => MachineSetup::unset(),
        };
        if let Some(w) = &a.work_offset {
            machine = machine.with_work_offset(parse_triple(w, "--work-offset")?);
        }
        Ok(Machine(machine.with_interp_options(InterpOptions {
            accept_k0_on_xy_arcs: a.accept_k0 && !a.strict_k0,
            absolute_arc_centers: a.absolute_arc_centers,
            require_program_end: !a.allow_no_program_end,
            ..InterpOptions::default()
        })))
    }

    /// Warns on standard error when no work offset was given.
    pub fn warn_without_work_offset(&self) {
        if self.no_work_offset {
            eprintln!("volcomp: warning: {NO_WORK_OFFSET}: program coordinates are taken as machine coordinates; give the offsets with --setup FILE or --work-offset X,Y,Z");
        }
    }

    /// Renders a compensation or simulation error with the CLI's flags: an
    /// out-of-range position first names a missing work offset, then the
    /// flags that fix it.
    pub fn explain(&self, e: volcomp_core::Error) -> CliError {
        match &e {
            volcomp_core::Error::Compensation(CompensationError::Model { .. })
                if self.no_work_offset =>
            {
                CliError::reworded(format!(
                    "{NO_WORK_OFFSET}: {e}\n  help: give the program's work offsets with --setup FILE or --work-offset X,Y,Z first; --clamp holds the error at the table ends"
                ), e)
            }
            volcomp_core::Error::Compensation(CompensationError::Model { .. }) => {
                CliError::reworded(format!(
                    "{e}\n  help: check --setup / --work-offset; --clamp holds the error at the table ends"
                ), e)
            }
            _ => CliError::from(e),
        }
    }

    /// A walker over a program file ("-" is standard input).
    pub fn walk(&self, path: &Path) -> Result<Walker<Box<dyn BufRead>>, CliError> {
        let reader: Box<dyn BufRead> = if path.as_os_str() == "-" {
            Box::new(BufReader::with_capacity(1 << 16, io::stdin()))
        } else {
            let f = File::open(path).map_err(|e| CliError::Io(path.to_path_buf(), e))?;
            Box::new(BufReader::with_capacity(1 << 16, f))
        };
        Ok(self.walker(reader, &path.display().to_string()))
    }
}

/// Prints what the G-code interpreter assumed (no units, no reference
/// point, …) to stderr as `file:line:column: warning: …`.
pub fn print_warnings(file: &str, warnings: &[volcomp_gcode::Warning]) {
    for w in warnings {
        eprintln!("{file}:{w}");
    }
}

/// Motions handed from the reading thread to the writing thread at a time.
const MOVES_BATCH: usize = 4096;

/// What `volcomp moves` prints of a motion: the reading thread hands
/// these (a third of a [`Motion`]) to the writing thread.
#[derive(Clone, Copy)]
struct MoveRow {
    line: u64,
    column: usize,
    kind: &'static str,
    source: &'static str,
    end: Vec3,
    center: Option<Vec3>,
    extra_end: [f64; 6],
}

impl MoveRow {
    fn of(m: &Motion) -> Self {
        Self {
            line: m.line,
            column: m.column,
            kind: m.kind.name(),
            source: m.source.name(),
            end: m.end,
            center: match m.kind {
                MotionKind::Arc(arc) => Some(arc.center),
                _ => None,
            },
            extra_end: m.extra.end,
        }
    }
}

/// `volcomp moves`: one thread reads and interprets, the other formats and
/// writes, with a bounded queue of batches between them, so memory stays
/// constant and both cores work.
fn moves(a: MovesArgs) -> Result<(), CliError> {
    let machine = Machine::from_args(&a.machine)?;
    let mut walker = machine.walk(&a.program)?;
    let json = a.format == MovesFormat::Json;
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<MoveRow>>(4);
    let extra = a.extra_axes;
    let writer = std::thread::spawn(move || write_moves(rx, json, extra));
    let mut batch = Vec::with_capacity(MOVES_BATCH);
    let mut read = || -> Result<(), CliError> {
        loop {
            let ev = match walker.next_line() {
                Ok(Some(ev)) => ev,
                Ok(None) => break,
                Err(e) => {
                    // Print what was understood up to the error, then report it.
                    let _ = tx.send(std::mem::take(&mut batch));
                    return Err(e.into());
                }
            };
            batch.extend(ev.motions.iter().map(MoveRow::of));
            if batch.len() >= MOVES_BATCH {
                let full = std::mem::replace(&mut batch, Vec::with_capacity(MOVES_BATCH));
                if tx.send(full).is_err() {
                    // The writer stopped (e.g. a closed pipe): its error is reported below.
                    return Ok(());
                }
            }
        }
        let _ = tx.send(std::mem::take(&mut batch));
        Ok(())
    };
    let read_result = read();
    print_warnings(&a.program.display().to_string(), walker.warnings());
    drop(tx);
    let write_result = writer
        .join()
        .unwrap_or_else(|_| Err(CliError::Internal("the output thread failed".into())));
    read_result?;
    write_result
}

/// Bytes of output gathered before they are written.
const MOVES_OUTPUT_BYTES: usize = 1 << 20;

fn write_moves(
    rx: std::sync::mpsc::Receiver<Vec<MoveRow>>,
    json: bool,
    extra_columns: bool,
) -> Result<(), CliError> {
    let stdout = io::stdout();
    let mut out = stdout.lock();
    let style = NumberStyle::fixed(6);
    let mut text: Vec<u8> = Vec::with_capacity(MOVES_OUTPUT_BYTES + 4096);
    let mut first = true;
    if json {
        text.extend_from_slice(b"[");
    } else {
        text.extend_from_slice(b"line,column,kind,source,x_mm,y_mm,z_mm,cx_mm,cy_mm,cz_mm");
        if extra_columns {
            text.extend_from_slice(b",a_deg,b_deg,c_deg,u_mm,v_mm,w_mm");
        }
        text.push(b'\n');
    }
    let num = |v: f64, text: &mut Vec<u8>| format_number_bytes(v, style, text);
    for batch in rx {
        for m in &batch {
            if json {
                text.extend_from_slice(if first { b"\n" } else { b",\n" });
                text.extend_from_slice(b"{\"line\":");
                push_uint(m.line, &mut text);
                text.extend_from_slice(b",\"column\":");
                push_uint(m.column as u64, &mut text);
                text.extend_from_slice(b",\"kind\":\"");
                text.extend_from_slice(m.kind.as_bytes());
                text.extend_from_slice(b"\",\"source\":\"");
                text.extend_from_slice(m.source.as_bytes());
                text.extend_from_slice(b"\",\"end_mm\":[");
                push_triple(m.end, &mut text, num);
                text.push(b']');
                if let Some(c) = m.center {
                    text.extend_from_slice(b",\"center_mm\":[");
                    push_triple(c, &mut text, num);
                    text.push(b']');
                }
                if extra_columns || m.extra_end != [0.0; 6] {
                    text.extend_from_slice(b",\"extra\":[");
                    push_extra(&m.extra_end, &mut text, num);
                    text.push(b']');
                }
                text.push(b'}');
            } else {
                push_uint(m.line, &mut text);
                text.push(b',');
                push_uint(m.column as u64, &mut text);
                text.push(b',');
                text.extend_from_slice(m.kind.as_bytes());
                text.push(b',');
                text.extend_from_slice(m.source.as_bytes());
                text.push(b',');
                push_triple(m.end, &mut text, num);
                text.push(b',');
                match m.center {
                    Some(c) => push_triple(c, &mut text, num),
                    None => text.extend_from_slice(b",,"),
                }
                if extra_columns {
                    text.push(b',');
                    push_extra(&m.extra_end, &mut text, num);
                }
                text.push(b'\n');
            }
            first = false;
            if text.len() >= MOVES_OUTPUT_BYTES {
                out.write_all(&text).map_err(CliError::Stdout)?;
                text.clear();
            }
        }
    }
    if json {
        text.extend_from_slice(b"\n]\n");
    }
    out.write_all(&text).map_err(CliError::Stdout)?;
    out.flush().map_err(CliError::Stdout)
}

/// A, B, C (degrees), U, V, W (mm), comma-separated.
fn push_extra(v: &[f64; 6], text: &mut Vec<u8>, num: impl Fn(f64, &mut Vec<u8>)) {
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            text.push(b',');
        }
        num(*x, text);
    }
}

fn push_uint(v: u64, text: &mut Vec<u8>) {
    text.extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
}

fn push_triple(v: Vec3, text: &mut Vec<u8>, num: impl Fn(f64, &mut Vec<u8>)) {
    num(v.x, text);
    text.push(b',');
    num(v.y, text);
    text.push(b',');
    num(v.z, text);
}
