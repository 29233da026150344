//! Raw command-line flags. They are turned into validated library options in
//! `commands`, never used by the library directly.

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
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
    /// on a terminal, for large inputs).
    #[arg(long, global = true)]
    pub quiet: bool,
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

/// How the program is set up on the machine.
#[derive(Args, Debug, Clone)]
pub struct MachineArgs {
    /// TOML setup file: work offsets, tool lengths, reference points.
    #[arg(long, value_name = "FILE")]
    pub setup: Option<PathBuf>,
    /// G54 work offset in mm (machine coordinates), overriding the setup's.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub work_offset: Option<String>,
    /// Read I/J/K as absolute arc centres (as if the program began with G90.1).
    #[arg(long)]
    pub absolute_arc_centers: bool,
    /// Accept `K0` on G17 arcs (FreeCAD writes it; LinuxCNC refuses it, and
    /// so does volcomp by default).
    #[arg(long)]
    pub accept_k0: bool,
    /// Refuse `K0` on G17 arcs: the default now, kept for old scripts.
    #[arg(long, hide = true, conflicts_with = "accept_k0")]
    pub strict_k0: bool,
    /// Accept a program that ends without M2, M30 or a closing `%`
    /// (LinuxCNC refuses it; grbl-family and other controllers run it).
    #[arg(long)]
    pub allow_no_program_end: bool,
}

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

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Solve q + e(q, s) = t to a tolerance (default).
    Exact,
    /// Iterative learning control, q ← q + γ·(t − actual(q)).
    Ilc,
    /// One step, q = t − e(t, s).
    Direct,
    /// Exact, but only with the positioning errors E_XX, E_YY, E_ZZ.
    Pitch,
}

#[derive(Args, Debug, Clone)]
pub struct MapArgs {
    /// Error map: axis-table CSV (docs/design.md, "The axis-table map") or a TOML model (the 21-component
    /// kinematic model of docs/kinematic.md, evaluated at each line's tool).
    #[arg(long, value_name = "MAP")]
    pub map: PathBuf,
    /// Clamp positions outside the map's range to its end instead of refusing.
    #[arg(long)]
    pub clamp: bool,
    /// A compensation table the controller applies itself (exported or read
    /// from it: Siemens EEC, Heidenhain .COM/.CMA, Klipper, Marlin;
    /// docs/controllers.md): only the rest of the map is compensated.
    #[arg(long, value_name = "FILE", conflicts_with = "controller_compensates")]
    pub controller: Option<PathBuf>,
    /// What the controller compensates from this very map: `positioning`
    /// (its pitch tables hold the map's E_XX, E_YY, E_ZZ).
    #[arg(long, value_enum, value_name = "WHAT")]
    pub controller_compensates: Option<ControllerCompensates>,
}

/// What a controller compensates itself (`--controller-compensates`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ControllerCompensates {
    /// The positioning errors E_XX, E_YY, E_ZZ (pitch/leadscrew compensation).
    Positioning,
}

#[derive(Args, Debug)]
pub struct CompensateArgs {
    /// The part program to compensate ("-" for standard input).
    pub program: PathBuf,
    #[command(flatten)]
    pub map: MapArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Compensation method.
    #[arg(long, value_enum, default_value_t = Method::Exact)]
    pub method: Method,
    /// Split feed moves into segments of at most this length (mm) instead
    /// of adaptively.
    #[arg(
        long,
        value_name = "MM",
        conflicts_with = "segments",
        allow_negative_numbers = true
    )]
    pub segment_length: Option<f64>,
    /// Split every feed move into this many segments (as the papers do).
    #[arg(long, value_name = "N")]
    pub segments: Option<u32>,
    /// Do not split feed moves (only arcs are linearised).
    #[arg(long, conflicts_with_all = ["segments", "segment_length"])]
    pub no_split: bool,
    /// Contour tolerance (µm, default 0.1): feed moves are split adaptively,
    /// at the map's table points and where the map bends the path by more
    /// than this (the default segmentation).
    #[arg(long, value_name = "UM", conflicts_with_all = ["segments", "segment_length", "no_split"], allow_negative_numbers = true)]
    pub contour_tolerance_um: Option<f64>,
    /// Shortest segment of adaptive splitting (mm).
    #[arg(
        long,
        value_name = "MM",
        default_value_t = volcomp_core::compensate::DEFAULT_MIN_SEGMENT_LENGTH_MM,
        conflicts_with_all = ["segments", "segment_length", "no_split"]
    )]
    pub min_segment_length: f64,
    /// ILC gain γ, 0 < γ ≤ 1.
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub gain: f64,
    /// ILC iteration limit (at least 1).
    #[arg(long, default_value_t = 20)]
    pub max_iterations: u32,
    /// Largest model residual accepted at a point (µm) with the exact and
    /// ILC solvers; a point that is not reached is an error at its line.
    #[arg(long, value_name = "UM", default_value_t = volcomp_core::compensate::DEFAULT_MAX_RESIDUAL_UM, allow_negative_numbers = true)]
    pub max_residual_um: f64,
    /// Largest output accepted, in bytes (suffixes K, M, G: powers of 1024),
    /// or `none`; a bigger output is refused and nothing is written.
    #[arg(long, value_name = "BYTES", default_value = "256M", value_parser = parse_size)]
    pub max_output_size: SizeLimit,
    /// Chord tolerance for linearising arcs and splines (mm).
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 1e-4,
        allow_negative_numbers = true
    )]
    pub chord_tolerance: f64,
    /// Write arcs as G1 lines within --chord-tolerance instead of as
    /// compensated arcs (pieces of the original arc).
    #[arg(long)]
    pub arcs_as_lines: bool,
    /// Decimal places of written coordinates (default 5 in mm, 6 in inch).
    #[arg(long)]
    pub decimals: Option<u8>,
    /// Largest correction accepted (mm); larger ones mean a wrong map unit.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.1,
        allow_negative_numbers = true
    )]
    pub max_correction: f64,
    /// Choose error tables by the nominal move direction, as the papers do,
    /// instead of the direction of the compensated command (for comparison).
    #[arg(long)]
    pub nominal_directions: bool,
    /// Do not insert backlash take-up moves at reversals.
    #[arg(long)]
    pub no_take_up: bool,
    /// Write every take-up as a block of its own, even where the move that
    /// reverses can take it up within the contour tolerance (the default
    /// folds those, so the controller does not stop for them).
    #[arg(long, conflicts_with = "no_take_up")]
    pub separate_take_ups: bool,
    /// The contour error a take-up folded into its move may leave (µm;
    /// default: the contour tolerance). Larger folds more take-ups, so the
    /// controller stops less, at the price of up to that error at reversals
    /// (docs/compensation.md, "Take-ups folded into the move").
    #[arg(
        long,
        value_name = "UM",
        conflicts_with_all = ["no_take_up", "separate_take_ups"]
    )]
    pub take_up_tolerance_um: Option<f64>,
    /// Do not tag inserted lines with `(volcomp Ln)` comments.
    #[arg(long)]
    pub no_trace: bool,
    /// Print a per-point report (CSV: line, iterations, residual) to this file.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Write a self-contained HTML report of the run (inputs and their
    /// SHA-256, set-up, method; errors before and after; pictures).
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
    /// Output program ("-" for standard output).
    #[arg(short, long, value_name = "OUT", required_unless_present = "filter")]
    pub output: Option<PathBuf>,
    /// Run as a LinuxCNC [FILTER] program (docs/linuxcnc.md): the program
    /// on standard output, `FILTER_PROGRESS=n` lines on standard error.
    #[arg(long, conflicts_with = "output")]
    pub filter: bool,
    /// Compensate a program that volcomp compensated already (its header or
    /// trace comments say so); the corrections are then applied twice.
    #[arg(long)]
    pub allow_recompensate: bool,
}

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// The program that runs on the machine.
    pub program: PathBuf,
    #[command(flatten)]
    pub map: MapArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// The original program whose nominal path PROGRAM is judged against (PROGRAM
    /// written by `volcomp compensate` from it: its `(volcomp Ln)` comments pair them).
    #[arg(long, value_name = "ORIGINAL")]
    pub reference: Option<PathBuf>,
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
    /// Chord tolerance for linearising arcs and splines (mm).
    #[arg(
        long,
        value_name = "MM",
        default_value_t = volcomp_core::simulate::DEFAULT_CHORD_TOLERANCE_MM,
        allow_negative_numbers = true
    )]
    pub chord_tolerance: f64,
}

#[derive(Args, Debug)]
pub struct TimeArgs {
    /// The program ("-" for standard input).
    pub program: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// The program PROGRAM was made from (e.g. the original of a
    /// compensated program): both times and the change are printed.
    #[arg(long, value_name = "ORIGINAL")]
    pub reference: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Where to write the example map and programs.
    #[arg(long, value_name = "DIR", default_value = "volcomp-demo")]
    pub out_dir: PathBuf,
}

/// A limit in bytes; `None`: no limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SizeLimit(pub Option<u64>);

/// Parses a byte count such as `1048576`, `64K`, `256M`, `2G` (powers of
/// 1024), or `none` (no limit).
pub fn parse_size(text: &str) -> Result<SizeLimit, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("none") {
        return Ok(SizeLimit(None));
    }
    let (digits, factor) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 1u64 << 10),
        Some('M') => (&t[..t.len() - 1], 1 << 20),
        Some('G') => (&t[..t.len() - 1], 1 << 30),
        _ => (t, 1),
    };
    digits
        .parse::<u64>()
        .ok()
        .and_then(|n| n.checked_mul(factor))
        .filter(|n| *n > 0)
        .map(|n| SizeLimit(Some(n)))
        .ok_or_else(|| {
            format!("`{text}` is not a size: write a whole number of bytes, optionally with K, M or G (1024-based), or `none`")
        })
}
