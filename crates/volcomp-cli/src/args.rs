//! Raw command-line flags. They are turned into validated library options in
//! `commands`, never used by the library directly.

use crate::options::Options;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use volcomp_core::request::{
    CompensateRequest, MachineRequest, MapRequest, ReportRequest, SimulateRequest, TimeRequest,
};
use volcomp_geom::Axis;

pub mod surface;

/// Volumetric error compensation of CNC part programs.
#[derive(Parser, Debug)]
#[command(name = "volcomp", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// No progress bar, summary line or report of what was written on
    /// standard error; warnings and errors still show (bars are drawn only
    /// on a terminal, for large inputs or work over a second).
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Largest file read whole (maps, models and their tables, set-ups,
    /// measurement files, controller files), in bytes (suffixes K, M, G:
    /// powers of 1024), or `none`; a larger file is refused before it is
    /// read (docs/errors.md, "Limits"). Programs are streamed: no limit.
    #[arg(long, global = true, value_name = "SIZE", default_value = "256M", value_parser = parse_input_size)]
    pub max_input_size: InputSize,
}

/// `--max-input-size`: bytes, or no limit.
#[derive(Debug, Clone, Copy)]
pub struct InputSize(pub Option<u64>);

fn parse_input_size(text: &str) -> Result<InputSize, String> {
    volcomp_core::request::option::parse_size(text)
        .map(InputSize)
        .ok_or_else(|| format!("must be a number of bytes with an optional K, M or G (powers of 1024), or none; got `{text}`"))
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Print every motion volcomp understood, in the axis frame (mm).
    Moves(MovesArgs),
    /// Write a compensated copy of a program for a measured error map.
    Compensate(CompensateArgs),
    /// Simulate a program on a machine with an error map and report its errors.
    Simulate(SimulateArgs),
    /// Estimate a program's machining time on a model of LinuxCNC 2.9's trajectory planner.
    Time(TimeArgs),
    /// Run the bundled example: the papers' circles and spiral on an example map.
    Demo(DemoArgs),
    /// Evaluate, convert, plot and import error maps (21-component model, LinuxCNC comp files, ISO 230-2).
    Map(crate::commands::map::MapCommand),
    /// Free-form surfaces: `surface mirror` compensates a finishing program from probing.
    Surface(surface::SurfaceArgs),
    /// Straightness models from measured profiles: fit (geometric error vs vibration), plot, table, predict.
    Straightness(crate::commands::straightness::StraightnessArgs),
    Thermal(crate::commands::thermal::ThermalArgs),
    /// Calibrate with a touch probe: probing programs, fit of the 21-component model, verification.
    Probe(crate::commands::probe::ProbeArgs),
    /// The circular test (ISO 230-4): predict a ballbar trace from a map, fit a trace's causes, a quick map from three planes.
    Ballbar(crate::commands::ballbar::BallbarArgs),
    /// Print a shell completion script to standard output, e.g.
    /// `volcomp completions bash > ~/.local/share/bash-completion/completions/volcomp`.
    Completions(CompletionsArgs),
    /// Print volcomp's man page (roff) to standard output, e.g.
    /// `volcomp man > volcomp.1 && man ./volcomp.1`.
    Man,
}

#[derive(Args, Debug)]
pub struct CompletionsArgs {
    /// The shell.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// The one value parser of every option that names an axis: `X`, `Y` or
/// `Z`, in either case (`--axis X` and `--axis x` are the same).
pub fn parse_axis(text: &str) -> Result<Axis, String> {
    match text.trim() {
        "X" | "x" => Ok(Axis::X),
        "Y" | "y" => Ok(Axis::Y),
        "Z" | "z" => Ok(Axis::Z),
        _ => Err(format!("`{text}` is not an axis: write X, Y or Z")),
    }
}

/// How the program is set up on the machine (the library's machine options).
pub type MachineArgs = Options<MachineRequest>;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum MovesFormat {
    Csv,
    Json,
}

#[derive(Args, Debug)]
pub struct MovesArgs {
    /// The part program ("-" for standard input).
    pub program: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Output format.
    #[arg(long, value_enum, default_value_t = MovesFormat::Csv)]
    pub format: MovesFormat,
    /// Add the extra axes' end values to every row (CSV columns a_deg,
    /// b_deg, c_deg, u_mm, v_mm, w_mm). JSON gives them without this flag
    /// on every motion where one is not zero.
    #[arg(long)]
    pub extra_axes: bool,
}

#[derive(Args, Debug)]
pub struct CompensateArgs {
    /// The part program to compensate ("-" for standard input).
    pub program: PathBuf,
    #[command(flatten)]
    pub map: Options<MapRequest>,
    #[command(flatten)]
    pub job: Options<CompensateRequest>,
    /// Print a per-point report (CSV: line, iterations, residual) to this file.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Write a self-contained HTML report of the run (inputs and their
    /// SHA-256, set-up, method; errors before and after; pictures).
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
    #[command(flatten)]
    pub title: Options<ReportRequest>,
    /// Output program ("-" for standard output); required unless --filter.
    #[arg(short, long, value_name = "OUT", required_unless_present = "filter")]
    pub output: Option<PathBuf>,
    /// Run as a LinuxCNC [FILTER] program (docs/linuxcnc.md): the program
    /// on standard output, `FILTER_PROGRESS=n` lines on standard error.
    #[arg(long, conflicts_with = "output")]
    pub filter: bool,
}

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// The program that runs on the machine.
    pub program: PathBuf,
    #[command(flatten)]
    pub map: Options<MapRequest>,
    #[command(flatten)]
    pub job: Options<SimulateRequest>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write per-segment error norms (CSV) for plotting.
    #[arg(long, value_name = "FILE")]
    pub errors_csv: Option<PathBuf>,
    /// Plot the errors along the path (.svg or .png).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Write a self-contained HTML report (with --reference: the reference
    /// on its own as "before", PROGRAM as "after").
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
    #[command(flatten)]
    pub title: Options<ReportRequest>,
}

#[derive(Args, Debug)]
pub struct TimeArgs {
    /// The program ("-" for standard input).
    pub program: PathBuf,
    #[command(flatten)]
    pub job: Options<TimeRequest>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Also give the time the planner spends on each line of the program
    /// (where the time goes): one row per line that moves, or `per_line`
    /// in the JSON object.
    #[arg(long)]
    pub per_line: bool,
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Where to write the example map and programs (`-o` as in every
    /// command that writes).
    #[arg(short, long, value_name = "DIR", default_value = "volcomp-demo")]
    pub out_dir: PathBuf,
    /// Also write the table as Markdown (BENCHMARKS.md's demo table).
    #[arg(long, value_name = "FILE.md")]
    pub markdown: Option<PathBuf>,
}
