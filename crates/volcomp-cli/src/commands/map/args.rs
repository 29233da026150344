//! The arguments of `volcomp map` and their turning into library values.

use crate::args::parse_axis;
use crate::options::Options;
use clap::{Args, Subcommand, ValueEnum};
use std::path::PathBuf;
use volcomp_core::request::{CompRequest, MapExportRequest, MapToolRequest};
use volcomp_geom::Axis;

/// Evaluate, convert, plot and import error maps.
#[derive(Args, Debug)]
pub struct MapCommand {
    #[command(subcommand)]
    pub command: MapSub,
}

#[derive(Subcommand, Debug)]
pub enum MapSub {
    /// The deviation e = actual − commanded (µm) at one axis position, with
    /// each component and Abbe arm of a 21-component model.
    Eval(EvalArgs),
    /// Convert a map: 21-component model → axis tables for a tool, a 3-D
    /// grid, LinuxCNC comp files, or axis tables → 21-component model.
    Convert(ConvertArgs),
    /// Export the map as a controller's own compensation tables (Siemens,
    /// Heidenhain, LinuxCNC, Klipper, Marlin: docs/controllers.md).
    Export(Box<ExportArgs>),
    /// Plot every component over its axis (.svg or .png).
    Plot(PlotArgs),
    /// Read LinuxCNC comp files (COMP_FILE_TYPE 0 or 1) into a map.
    ImportLinuxcnc(ImportArgs),
    /// Build a 21-component model from measurement runs (a plan TOML and one
    /// ISO 230-2 run file per component; docs/build.md).
    Build(BuildArgs),
    /// Read an ISO 230-1 parameter file (ISG CSV, Etalon exchange format) into a 21-component model.
    Import(ImportParamsArgs),
    /// Evaluate an ISO 230-2 bidirectional positioning test: B, R↑, R↓, R, E, M, A.
    #[command(name = "iso230-2")]
    Iso230_2(IsoArgs),
    /// Write the example 21-component model (TOML + CSV).
    Example(ExampleArgs),
}

#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Error map: axis-table CSV (docs/design.md) or 21-component model TOML.
    pub map: PathBuf,
    /// Axis position (machine coordinates, mm).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub at: String,
    #[command(flatten)]
    pub tool: Options<MapToolRequest>,
    /// Direction state: forward, reverse, or one letter per axis (f/r or +/-), e.g. frf.
    #[arg(long, default_value = "forward", allow_hyphen_values = true)]
    pub direction: String,
    /// Hold the error at a table end outside its range.
    #[arg(long)]
    pub clamp: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ConvertTarget {
    /// Axis-table CSV (docs/design.md) for one tool, exact on the lines through --at.
    AxisTable,
    /// A 3-D grid CSV: x_mm,y_mm,z_mm,ex_um,ey_um,ez_um every --step mm.
    Grid,
    /// LinuxCNC comp files x.comp, y.comp, z.comp in the directory -o.
    Linuxcnc,
    /// A 21-component model (TOML + CSV beside it).
    Model,
}

#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// Error map: axis-table CSV or 21-component model TOML.
    pub map: PathBuf,
    /// What to write.
    #[arg(long, value_enum)]
    pub to: ConvertTarget,
    /// Output file (a directory for --to linuxcnc).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Reference axis position (mm) whose three lines the axis tables
    /// reproduce exactly (default: the model's measuring point); for
    /// LinuxCNC files, where the positioning error is taken.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub at: Option<String>,
    #[command(flatten)]
    pub tool: Options<MapToolRequest>,
    /// Grid spacing (mm, default 25); for --to linuxcnc, resample the
    /// positioning tables at this spacing (LinuxCNC holds 256 points per joint).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub step: Option<f64>,
    /// Direction state of the grid (forward, reverse or one letter per axis).
    #[arg(long, default_value = "forward", allow_hyphen_values = true)]
    pub direction: String,
    #[command(flatten)]
    pub comp: Options<CompRequest>,
    /// For --to linuxcnc: the largest deviation (µm) of the written tables
    /// from the map, between and at their points (a finer --step when it is exceeded).
    #[arg(long, value_name = "UM", default_value_t = volcomp_core::io::controllers::table_error::DEFAULT_MAX_TABLE_ERROR_UM)]
    pub max_table_error_um: f64,
    /// Kinematic chain for --to model from axis tables (default w X' Y' b Z t).
    #[arg(long, value_name = "CHAIN")]
    pub chain: Option<String>,
}

#[derive(Args, Debug)]
pub struct PlotArgs {
    /// Error map: axis-table CSV or 21-component model TOML.
    pub map: PathBuf,
    /// Output plot (.svg or .png), or a self-contained HTML report (.html).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct ImportArgs {
    /// Comp file of the X joint.
    #[arg(long, value_name = "FILE")]
    pub x: PathBuf,
    /// Comp file of the Y joint.
    #[arg(long, value_name = "FILE")]
    pub y: PathBuf,
    /// Comp file of the Z joint.
    #[arg(long, value_name = "FILE")]
    pub z: PathBuf,
    #[command(flatten)]
    pub comp: Options<CompRequest>,
    /// Output: an axis-table .csv or a 21-component model .toml (CSV beside it).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Kinematic chain of the model (.toml output; default w X' Y' b Z t).
    #[arg(long, value_name = "CHAIN")]
    pub chain: Option<String>,
}

#[derive(Args, Debug)]
pub struct IsoArgs {
    /// The test: CSV with target_mm, cycle, direction, deviation_um (or actual_mm).
    pub runs: PathBuf,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Write the mean deviations x̄↑, x̄↓ as a positioning table: .csv (rows
    /// of the 21-component table for --axis) or .comp (LinuxCNC, with --type, --units).
    #[arg(short, long, value_name = "OUT", requires = "axis")]
    pub output: Option<PathBuf>,
    /// The axis that was tested (for -o): X, Y or Z.
    #[arg(long, value_parser = parse_axis)]
    pub axis: Option<Axis>,
    #[command(flatten)]
    pub comp: Options<CompRequest>,
    /// Write a self-contained HTML report: the standard's bidirectional
    /// plot (x̄ ± 2s per direction) and the figures B, R, E, M, A.
    #[arg(long, value_name = "FILE.html")]
    pub report_html: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct ExampleArgs {
    /// Directory to write example21.toml and example21.csv to.
    #[arg(short, long, value_name = "DIR", default_value = ".")]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// Error map: axis-table CSV or 21-component model TOML.
    pub map: PathBuf,
    #[command(flatten)]
    pub job: Options<MapExportRequest>,
    /// Directory to write the controller's files to.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ParamsFormat {
    /// ISG CSV (volumetric compensation of the ISG kernel / TwinCAT CNC).
    IsgCsv,
    /// Etalon exchange format, "Vendor" variant ([EXX] Gridpoints, [C0Y] VALUE).
    Etalon,
}

#[derive(Args, Debug)]
pub struct ImportParamsArgs {
    /// The parameter file (lengths in mm, angles in rad).
    pub file: PathBuf,
    /// Its format.
    #[arg(long, value_enum)]
    pub from: ParamsFormat,
    /// Output: a 21-component model .toml (its tables .csv beside it).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Kinematic chain of the model (default w X' Y' b Z t).
    #[arg(long, value_name = "CHAIN")]
    pub chain: Option<String>,
}

#[derive(Args, Debug)]
pub struct BuildArgs {
    /// The plan (TOML): which run file measures which component, where, the reference point.
    pub plan: PathBuf,
    /// Output: a 21-component model .toml (its tables .csv beside it).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
}
