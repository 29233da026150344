//! One function per subcommand: validate flags into library options, run,
//! print.

use crate::args::{Cli, Command, MovesArgs, MovesFormat};
use crate::options::flags;
use crate::output::CliError;
use std::io::{self, BufRead, Write};
use std::path::{Path, PathBuf};
use volcomp_core::io::stream::ReadAhead;
use volcomp_core::request::{Machine, MachineRequest};
use volcomp_gcode::number::{format_fixed_bytes, format_uint_bytes};
use volcomp_gcode::{Motion, MotionKind, MotionSource, Vec3, Walker};

pub mod ballbar;
mod compensate;
pub use compensate::command_line;
mod demo;
pub mod map;
pub mod probe;
mod simulate;
pub mod straightness;
pub mod surface;
pub mod thermal;
mod time;

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Moves(a) => moves(a),
        Command::Compensate(a) => compensate::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Time(a) => time::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Map(a) => map::run(a),
        Command::Surface(a) => surface::run(a),
        Command::Straightness(a) => straightness::run(a),
        Command::Thermal(a) => thermal::run(a),
        Command::Probe(a) => probe::run(a),
        Command::Ballbar(a) => ballbar::run(a),
        Command::Completions(a) => {
            let mut cmd = <Cli as clap::CommandFactory>::command();
            clap_complete::generate(a.shell, &mut cmd, "volcomp", &mut io::stdout());
            Ok(())
        }
        Command::Man => {
            let mut page = Vec::new();
            clap_mangen::Man::new(<Cli as clap::CommandFactory>::command())
                .render(&mut page)
                .map_err(CliError::Stdout)?;
            io::stdout().write_all(&page).map_err(CliError::Stdout)
        }
    }
}

/// The machine of a request, as the library builds it.
pub fn machine(request: &MachineRequest) -> Result<Machine, CliError> {
    Ok(request.machine()?)
}

/// The CLI's side of a machine: its warning, its errors with flags, its
/// programs read from files or standard input.
pub trait MachineExt {
    /// Warns on standard error when no work offset was given.
    fn warn_without_work_offset(&self);
    /// Renders a compensation or simulation error with the CLI's flags: an
    /// out-of-range position first names a missing work offset, then the
    /// flags that fix it.
    fn refused(&self, e: volcomp_core::Error) -> CliError;
    /// A walker over a program file ("-" is standard input).
    fn walk(&self, path: &Path) -> Result<Walker<Box<dyn BufRead>>, CliError>;
}

impl MachineExt for Machine {
    fn warn_without_work_offset(&self) {
        if let Some(w) = self.work_offset_warning() {
            eprintln!("volcomp: warning: {}", flags(&w));
        }
    }

    fn refused(&self, e: volcomp_core::Error) -> CliError {
        match Machine::explain(self, &e) {
            Some(text) => CliError::reworded(flags(&text), e),
            None => {
                // Options the library names as `{name}`, said as flags.
                let text = e.to_string();
                let said = flags(&text);
                if said == text {
                    CliError::from(e)
                } else {
                    CliError::reworded(said, e)
                }
            }
        }
    }

    fn walk(&self, path: &Path) -> Result<Walker<Box<dyn BufRead>>, CliError> {
        // For speed, the program is read ahead on a thread of its own.
        let reader: Box<dyn BufRead> = if path.as_os_str() == "-" {
            volcomp_core::io::inputs::record_stdin("the program (standard input)");
            Box::new(ReadAhead::new(io::stdin()))
        } else {
            let f = volcomp_core::io::inputs::open(path, "the program")
                .map_err(|e| CliError::Io(path.to_path_buf(), e))?;
            Box::new(ReadAhead::new(f))
        };
        Ok(self.setup.walker(reader, &path.display().to_string()))
    }
}

/// The CSV of a model file's tables, written beside the model `output`
/// (`model.toml` → `model.csv`): its name, as the model file names it, and
/// its path.
pub(crate) fn tables_beside(output: &Path) -> (String, PathBuf) {
    let stem = output
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("model");
    let csv_name = format!("{stem}.csv");
    let csv_path = output.with_file_name(&csv_name);
    (csv_name, csv_path)
}

/// Parses `X,Y,Z` (three finite numbers) given to `flag`.
pub fn parse_triple(text: &str, flag: &str) -> Result<Vec3, CliError> {
    match volcomp_core::request::option::parse_triple(text) {
        Some([x, y, z]) => Ok(Vec3::new(x, y, z)),
        None => Err(CliError::Message(format!(
            "{flag} expects three numbers in mm separated by commas, like 100,50,-200; got `{text}`"
        ))),
    }
}

/// Prints what the G-code interpreter assumed (no units, no reference
/// point, …) to stderr as `file:line:column: warning: …`.
pub fn print_warnings(file: &str, warnings: &[volcomp_gcode::Warning]) {
    for w in warnings {
        eprintln!("{}", crate::output::clean(&format!("{file}:{w}")));
    }
}

/// Motions handed from the reading thread to the writing thread at a time.
const MOVES_BATCH: usize = 4096;

/// What `volcomp moves` prints of a motion: the reading thread hands
/// these to the writing thread (for speed: about half a [`Motion`]; the
/// extra axes, zero in most programs, go in the batch's own list only
/// where they are printed).
#[derive(Clone, Copy)]
struct MoveRow {
    end: Vec3,
    /// The arc's centre (when `arc`).
    center: Vec3,
    line: u64,
    column: usize,
    kind: &'static str,
    source: MotionSource,
    arc: bool,
    /// Whether the next entry of [`MoveBatch::extra`] is this row's.
    extra: bool,
}

/// Rows handed over at a time, and the extra-axis ends of those that print them.
#[derive(Default)]
struct MoveBatch {
    rows: Vec<MoveRow>,
    extra: Vec<[f64; 6]>,
}

impl MoveBatch {
    fn with_capacity(n: usize) -> Self {
        Self {
            rows: Vec::with_capacity(n),
            extra: Vec::new(),
        }
    }

    fn push(&mut self, m: &Motion, extra_columns: bool) {
        let (arc, center) = match m.kind {
            MotionKind::Arc(arc) => (true, arc.center),
            _ => (false, Vec3::ZERO),
        };
        // Element by element, for speed: no slice comparison call.
        let extra = extra_columns || m.extra.end.iter().any(|&v| v != 0.0);
        if extra {
            self.extra.push(m.extra.end);
        }
        self.rows.push(MoveRow {
            end: m.end,
            center,
            line: m.line,
            column: m.column,
            kind: m.kind.name(),
            source: m.source,
            arc,
            extra,
        });
    }

    fn len(&self) -> usize {
        self.rows.len()
    }

    fn clear(&mut self) {
        self.rows.clear();
        self.extra.clear();
    }
}

/// `volcomp moves`: one thread reads and interprets, the other formats and
/// writes, with a bounded queue of batches between them, so memory stays
/// constant and both cores work.
fn moves(a: MovesArgs) -> Result<(), CliError> {
    let machine = machine(&a.machine)?;
    let mut walker = machine.walk(&a.program)?;
    let json = a.format == MovesFormat::Json;
    let (tx, rx) = std::sync::mpsc::sync_channel::<MoveBatch>(4);
    // Written batches come back to be filled again: no allocation (and no
    // fresh pages) per batch.
    let (tx_empty, rx_empty) = std::sync::mpsc::sync_channel::<MoveBatch>(8);
    let extra = a.extra_axes;
    let writer = std::thread::spawn(move || write_moves(rx, tx_empty, json, extra));
    let mut batch = MoveBatch::with_capacity(MOVES_BATCH);
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
            for m in ev.motions {
                batch.push(m, extra);
            }
            if batch.len() >= MOVES_BATCH {
                let empty = rx_empty
                    .try_recv()
                    .unwrap_or_else(|_| MoveBatch::with_capacity(MOVES_BATCH));
                let full = std::mem::replace(&mut batch, empty);
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

/// Bytes of output gathered before they are written (cache-sized).
const MOVES_OUTPUT_BYTES: usize = 1 << 18;

fn write_moves(
    rx: std::sync::mpsc::Receiver<MoveBatch>,
    empty: std::sync::mpsc::SyncSender<MoveBatch>,
    json: bool,
    extra_columns: bool,
) -> Result<(), CliError> {
    let stdout = io::stdout();
    let mut out = stdout.lock();
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
    // Six decimals, fixed when compiled (for speed).
    let num = |v: f64, text: &mut Vec<u8>| format_fixed_bytes::<6>(v, text);
    for mut batch in rx {
        let mut extras = batch.extra.iter();
        for m in &batch.rows {
            let extra = if m.extra { extras.next() } else { None };
            if json {
                push_json_row(m, extra, first, &mut text, num);
            } else {
                push_csv_row(m, extra.filter(|_| extra_columns), &mut text, num);
            }
            first = false;
            if text.len() >= MOVES_OUTPUT_BYTES {
                out.write_all(&text).map_err(CliError::Stdout)?;
                text.clear();
            }
        }
        batch.clear();
        let _ = empty.try_send(batch);
    }
    if json {
        text.extend_from_slice(b"\n]\n");
    }
    out.write_all(&text).map_err(CliError::Stdout)?;
    out.flush().map_err(CliError::Stdout)
}

/// One move as a JSON object (after a comma unless it is the `first`).
fn push_json_row(
    m: &MoveRow,
    extra: Option<&[f64; 6]>,
    first: bool,
    text: &mut Vec<u8>,
    num: impl Fn(f64, &mut Vec<u8>) + Copy,
) {
    text.extend_from_slice(if first { b"\n" } else { b",\n" });
    text.extend_from_slice(b"{\"line\":");
    push_uint(m.line, text);
    text.extend_from_slice(b",\"column\":");
    push_uint(m.column as u64, text);
    text.extend_from_slice(b",\"kind\":\"");
    text.extend_from_slice(m.kind.as_bytes());
    text.extend_from_slice(b"\",\"source\":\"");
    text.extend_from_slice(m.source.name().as_bytes());
    text.extend_from_slice(b"\",\"end_mm\":[");
    push_triple(m.end, text, num);
    text.push(b']');
    if m.arc {
        text.extend_from_slice(b",\"center_mm\":[");
        push_triple(m.center, text, num);
        text.push(b']');
    }
    if let Some(e) = extra {
        text.extend_from_slice(b",\"extra\":[");
        push_extra(e, text, num);
        text.push(b']');
    }
    text.push(b'}');
}

/// One move as a CSV row.
fn push_csv_row(
    m: &MoveRow,
    extra: Option<&[f64; 6]>,
    text: &mut Vec<u8>,
    num: impl Fn(f64, &mut Vec<u8>) + Copy,
) {
    push_uint(m.line, text);
    text.push(b',');
    push_uint(m.column as u64, text);
    text.push(b',');
    text.extend_from_slice(m.kind.as_bytes());
    text.push(b',');
    text.extend_from_slice(m.source.name().as_bytes());
    text.push(b',');
    push_triple(m.end, text, num);
    text.push(b',');
    if m.arc {
        push_triple(m.center, text, num);
    } else {
        text.extend_from_slice(b",,");
    }
    if let Some(e) = extra {
        text.push(b',');
        push_extra(e, text, num);
    }
    text.push(b'\n');
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

// Inlined into the row writer: a call per number cost more than the number.
#[inline]
fn push_uint(v: u64, text: &mut Vec<u8>) {
    // For speed, written where it goes: no `memcpy` call per number.
    format_uint_bytes(v, text);
}

fn push_triple(v: Vec3, text: &mut Vec<u8>, num: impl Fn(f64, &mut Vec<u8>)) {
    num(v.x, text);
    text.push(b',');
    num(v.y, text);
    text.push(b',');
    num(v.z, text);
}
