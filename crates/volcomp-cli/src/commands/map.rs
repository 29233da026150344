//! `volcomp map`: evaluate, convert, plot and import error maps — the
//! axis tables (docs/design.md), the 21-component kinematic model (ISO 230-1),
//! LinuxCNC compensation files and ISO 230-2 positioning tests.

use super::parse_triple;
use crate::args::{parse_axis, AxisArg};
use crate::output::{check, write_atomically, CliError, OutputPlan};
use crate::plot::{write_charts, Chart, Series};
use clap::{Args, Subcommand, ValueEnum};
use std::io::Write;
use std::path::{Path, PathBuf};
use volcomp_core::example::kinematic as kinematic_example;
use volcomp_core::identify::iso230_2;
use volcomp_core::io::linuxcnc_comp::{self, CompFileType, MachineUnits, Positioning};
use volcomp_core::io::model_file;
use volcomp_core::io::numfmt;
use volcomp_core::io::{load_model, LoadOptions, LoadedModel};
use volcomp_core::model::axis_table::{AxisTableMap, AxisTables, Table};
use volcomp_core::model::kinematic::{angular_name, linear_name, Form, KinematicModel};
use volcomp_core::model::topology::Topology;
use volcomp_core::model::{Components, Direction, Directions, ErrorModel};
use volcomp_gcode::Vec3;

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
    /// Plot every component over its axis (.svg or .png).
    Plot(PlotArgs),
    /// Read LinuxCNC comp files (COMP_FILE_TYPE 0 or 1) into a map.
    ImportLinuxcnc(ImportArgs),
    /// Evaluate an ISO 230-2 bidirectional positioning test: B, R↑, R↓, R, E, M, A.
    #[command(name = "iso230-2")]
    Iso230_2(IsoArgs),
    /// Write the example 21-component model (TOML + CSV).
    Example(ExampleArgs),
}

/// The tool whose tip the map is evaluated at.
#[derive(Args, Debug, Clone)]
pub struct ToolArgs {
    /// Tool length (mm) as G43 applies it: the tip lies this far below the
    /// spindle's gauge point. Default 0 (the gauge point).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub tool_length: Option<f64>,
    /// Tool length offset vector (mm) as G43.1 applies it, for angle heads.
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        conflicts_with = "tool_length"
    )]
    pub tool_offset: Option<String>,
}

impl ToolArgs {
    fn offset(&self) -> Result<Option<Vec3>, CliError> {
        match (&self.tool_length, &self.tool_offset) {
            (Some(l), _) if !l.is_finite() => Err(CliError::Message(format!(
                "--tool-length must be a length in mm; got {l}"
            ))),
            (Some(l), _) => Ok(Some(Vec3::new(0.0, 0.0, *l))),
            (None, Some(t)) => parse_triple(t, "--tool-offset").map(Some),
            (None, None) => Ok(None),
        }
    }
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum FormArg {
    /// Exact products of homogeneous transformation matrices.
    Htm,
    /// The small-angle (first-order) form.
    FirstOrder,
}

impl From<FormArg> for Form {
    fn from(f: FormArg) -> Form {
        match f {
            FormArg::Htm => Form::Htm,
            FormArg::FirstOrder => Form::FirstOrder,
        }
    }
}

#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Error map: axis-table CSV (docs/design.md) or 21-component model TOML.
    pub map: PathBuf,
    /// Axis position (machine coordinates, mm).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub at: String,
    #[command(flatten)]
    pub tool: ToolArgs,
    /// Direction state: forward, reverse, or one letter per axis (f/r or +/-), e.g. frf.
    #[arg(long, default_value = "forward", allow_hyphen_values = true)]
    pub direction: String,
    /// Evaluation of the 21-component model.
    #[arg(long, value_enum, default_value_t = FormArg::Htm)]
    pub form: FormArg,
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

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum UnitsArg {
    Mm,
    Inch,
}

impl From<UnitsArg> for MachineUnits {
    fn from(u: UnitsArg) -> MachineUnits {
        match u {
            UnitsArg::Mm => MachineUnits::Mm,
            UnitsArg::Inch => MachineUnits::Inch,
        }
    }
}

/// The LinuxCNC side of a comp file.
#[derive(Args, Debug, Clone)]
pub struct CompArgs {
    /// COMP_FILE_TYPE: 0 (nominal, actual forward, actual reverse) or
    /// 1 (nominal, trim forward, trim reverse; trim = nominal − actual).
    #[arg(long = "type", value_name = "0|1")]
    pub comp_type: Option<u8>,
    /// The machine's [TRAJ] LINEAR_UNITS, the unit of every number in the file.
    #[arg(long, value_enum)]
    pub units: Option<UnitsArg>,
}

impl CompArgs {
    fn get(&self) -> Result<(CompFileType, MachineUnits), CliError> {
        let ty = match self.comp_type {
            Some(n) => CompFileType::from_number(n).ok_or_else(|| {
                CliError::Message(format!("--type must be 0 or 1 (COMP_FILE_TYPE); got {n}"))
            })?,
            None => return Err(CliError::Message("LinuxCNC comp files need --type 0 or --type 1: type 0 holds actual positions, type 1 the trims nominal − actual; check COMP_FILE_TYPE in the machine's INI file".into())),
        };
        let units = self.units.ok_or_else(|| {
            CliError::Message("LinuxCNC comp files are in machine units: pass --units mm or --units inch as [TRAJ] LINEAR_UNITS says".into())
        })?;
        Ok((ty, units.into()))
    }
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
    pub tool: ToolArgs,
    /// Grid spacing (mm, default 25); for --to linuxcnc, resample the
    /// positioning tables at this spacing (LinuxCNC holds 256 points per joint).
    #[arg(long, value_name = "MM")]
    pub step: Option<f64>,
    /// Direction state of the grid (forward, reverse or one letter per axis).
    #[arg(long, default_value = "forward", allow_hyphen_values = true)]
    pub direction: String,
    #[command(flatten)]
    pub comp: CompArgs,
    /// Kinematic chain for --to model from axis tables (default w X' Y' b Z t).
    #[arg(long, value_name = "CHAIN")]
    pub chain: Option<String>,
    /// Evaluation of the 21-component model.
    #[arg(long, value_enum, default_value_t = FormArg::Htm)]
    pub form: FormArg,
}

#[derive(Args, Debug)]
pub struct PlotArgs {
    /// Error map: axis-table CSV or 21-component model TOML.
    pub map: PathBuf,
    /// Output plot (.svg or .png).
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
    pub comp: CompArgs,
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
    pub axis: Option<AxisArg>,
    #[command(flatten)]
    pub comp: CompArgs,
}

#[derive(Args, Debug)]
pub struct ExampleArgs {
    /// Directory to write example21.toml and example21.csv to.
    #[arg(short, long, value_name = "DIR", default_value = ".")]
    pub output: PathBuf,
}

/// Loads a map through the library's one model loader (axis-table CSV,
/// 21-component model TOML, straightness model TOML).
pub fn load(path: &Path, clamp: bool) -> Result<LoadedModel, CliError> {
    Ok(load_model(path, &LoadOptions { clamp })?)
}

/// The maps `volcomp map` works on.
enum Map {
    Tables(Box<AxisTableMap>),
    Kinematic(Box<KinematicModel>),
}

impl Map {
    fn model(&self) -> &dyn ErrorModel {
        match self {
            Map::Tables(m) => m.as_ref(),
            Map::Kinematic(m) => m.as_ref(),
        }
    }
}

/// Loads axis tables or a 21-component model; `volcomp map` takes no other kind.
fn load_map(path: &Path, clamp: bool) -> Result<Map, CliError> {
    match load(path, clamp)? {
        LoadedModel::AxisTables(m) => Ok(Map::Tables(m)),
        LoadedModel::Kinematic(m) => Ok(Map::Kinematic(m)),
        other => Err(CliError::Message(format!(
            "{}: `volcomp map` reads axis tables and 21-component models, not a {} model; use it with compensate or simulate",
            path.display(),
            other.kind().name()
        ))),
    }
}

pub fn run(cmd: MapCommand) -> Result<(), CliError> {
    match cmd.command {
        MapSub::Eval(a) => eval(a),
        MapSub::Convert(a) => convert(a),
        MapSub::Plot(a) => plot(a),
        MapSub::ImportLinuxcnc(a) => import_linuxcnc(a),
        MapSub::Iso230_2(a) => iso230_2(a),
        MapSub::Example(a) => example(a),
    }
}

const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// Parses a direction state: `forward`, `reverse`, or one letter per axis.
fn parse_directions(text: &str) -> Result<Directions, CliError> {
    let lower = text.trim().to_ascii_lowercase();
    let one = |c: char| match c {
        'f' | '+' => Some(Direction::Forward),
        'r' | '-' => Some(Direction::Reverse),
        _ => None,
    };
    match lower.as_str() {
        "forward" | "fwd" | "+" => Ok([Direction::Forward; 3]),
        "reverse" | "rev" | "-" => Ok([Direction::Reverse; 3]),
        _ => {
            let v: Vec<Option<Direction>> = lower.chars().map(one).collect();
            match v.as_slice() {
                [Some(x), Some(y), Some(z)] => Ok([*x, *y, *z]),
                _ => Err(CliError::Message(format!(
                    "--direction expects forward, reverse or one letter per axis (f/r or +/-) like frf; got `{text}`"
                ))),
            }
        }
    }
}

fn dir_letters(s: Directions) -> String {
    s.iter()
        .map(|d| match d {
            Direction::Forward => '+',
            Direction::Reverse => '-',
        })
        .collect()
}

fn fmt3(v: Vec3, decimals: usize) -> String {
    format!("{:+.d$}  {:+.d$}  {:+.d$}", v.x, v.y, v.z, d = decimals)
}

fn json3(v: Vec3) -> serde_json::Value {
    serde_json::json!([v.x, v.y, v.z])
}

fn eval(a: EvalArgs) -> Result<(), CliError> {
    let map = load_map(&a.map, a.clamp)?;
    let q = parse_triple(&a.at, "--at")?;
    let s = parse_directions(&a.direction)?;
    let tool = a.tool.offset()?.unwrap_or(Vec3::ZERO);
    let model = map.model();
    let e = model.deviation_with_tool_um(q, s, Components::All, tool)?;
    let pitch = model.deviation_with_tool_um(q, s, Components::PositioningOnly, tool)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match &map {
        Map::Tables(m) => {
            let per_axis: Vec<Vec3> = (0..3)
                .map(|k| {
                    let t = match s[k] {
                        Direction::Forward => &m.axes[k].forward,
                        Direction::Reverse => &m.axes[k].reverse,
                    };
                    let [lo, hi] = t.range();
                    let x = if a.clamp { q[k].clamp(lo, hi) } else { q[k] };
                    t.eval(x).unwrap_or(Vec3::ZERO)
                })
                .collect();
            if a.json {
                let v = serde_json::json!({
                    "map": a.map.display().to_string(),
                    "kind": "axis-table",
                    "at_mm": json3(q),
                    "directions": dir_letters(s),
                    "deviation_um": json3(e),
                    "positioning_um": json3(pitch),
                    "axes_um": {"X": json3(per_axis[0]), "Y": json3(per_axis[1]), "Z": json3(per_axis[2])},
                });
                writeln!(out, "{v}").map_err(CliError::Stdout)?;
            } else {
                writeln!(
                    out,
                    "map          {} (axis tables; the tool does not enter)",
                    a.map.display()
                )
                .map_err(CliError::Stdout)?;
                writeln!(
                    out,
                    "at           X {:.4}  Y {:.4}  Z {:.4} mm, directions {}",
                    q.x,
                    q.y,
                    q.z,
                    dir_letters(s)
                )
                .map_err(CliError::Stdout)?;
                writeln!(
                    out,
                    "deviation    {} µm   |e| {:.4} µm",
                    fmt3(e, 4),
                    e.norm()
                )
                .map_err(CliError::Stdout)?;
                writeln!(
                    out,
                    "positioning  {} µm   (E_XX, E_YY, E_ZZ only)",
                    fmt3(pitch, 4)
                )
                .map_err(CliError::Stdout)?;
                for (name, v) in AXES.iter().zip(&per_axis) {
                    writeln!(out, "  {name} table  {} µm", fmt3(*v, 4))
                        .map_err(CliError::Stdout)?;
                }
            }
        }
        Map::Kinematic(m) => {
            let mut m = (**m).clone();
            m.form = a.form.into();
            let e = m.deviation_with_tool_um(q, s, Components::All, tool)?;
            let htm = m.deviation_form_um(q, s, tool, Form::Htm)?;
            let first = m.deviation_form_um(q, s, tool, Form::FirstOrder)?;
            let v = m.values(q, s)?;
            let k = &m.kinematics;
            let sq = k.squareness.deviation_um(q);
            let mut comps = serde_json::Map::new();
            let mut arms = serde_json::Map::new();
            let mut contrib = serde_json::Map::new();
            for ax in 0..3 {
                for d in 0..3 {
                    comps.insert(linear_name(d, ax), serde_json::json!(v.linear_um[ax][d]));
                }
                for d in 0..3 {
                    comps.insert(
                        angular_name(d, ax),
                        serde_json::json!(v.angular_urad[ax][d]),
                    );
                }
                arms.insert(AXES[ax].to_string(), json3(k.arm_mm(ax, q, tool)));
                contrib.insert(
                    AXES[ax].to_string(),
                    json3(m.axis_contribution_um(ax, q, s[ax], tool, Form::FirstOrder)?),
                );
            }
            if a.json {
                let j = serde_json::json!({
                    "map": a.map.display().to_string(),
                    "kind": "kinematic-21",
                    "chain": k.topology.to_string(),
                    "form": match m.form { Form::Htm => "htm", Form::FirstOrder => "first-order" },
                    "at_mm": json3(q),
                    "directions": dir_letters(s),
                    "tool_length_offset_mm": json3(tool),
                    "deviation_um": json3(e),
                    "deviation_htm_um": json3(htm),
                    "deviation_first_order_um": json3(first),
                    "positioning_um": json3(pitch),
                    "squareness_um": json3(sq),
                    "components": comps,
                    "abbe_arms_mm": arms,
                    "axis_contributions_um": contrib,
                });
                writeln!(out, "{j}").map_err(CliError::Stdout)?;
            } else {
                let w = |out: &mut std::io::StdoutLock, text: String| -> Result<(), CliError> {
                    writeln!(out, "{text}").map_err(CliError::Stdout)
                };
                w(
                    &mut out,
                    format!(
                        "map          {} (21-component, chain {}, {})",
                        a.map.display(),
                        k.topology,
                        match m.form {
                            Form::Htm => "HTM",
                            Form::FirstOrder => "first order",
                        }
                    ),
                )?;
                w(
                    &mut out,
                    format!(
                        "at           X {:.4}  Y {:.4}  Z {:.4} mm, directions {}",
                        q.x,
                        q.y,
                        q.z,
                        dir_letters(s)
                    ),
                )?;
                w(&mut out, format!("tool offset  {:.4}, {:.4}, {:.4} mm (G43 length offset; the tip is below the gauge point by it)", tool.x, tool.y, tool.z))?;
                w(
                    &mut out,
                    format!("deviation    {} µm   |e| {:.4} µm", fmt3(e, 4), e.norm()),
                )?;
                w(&mut out, format!("  HTM        {} µm", fmt3(htm, 6)))?;
                w(
                    &mut out,
                    format!(
                        "  1st order  {} µm   (difference {:.2e} µm)",
                        fmt3(first, 6),
                        (htm - first).norm()
                    ),
                )?;
                w(
                    &mut out,
                    format!(
                        "positioning  {} µm   (E_XX, E_YY, E_ZZ only)",
                        fmt3(pitch, 4)
                    ),
                )?;
                w(
                    &mut out,
                    format!(
                        "squareness   {} µm   (S_xy·y + S_zx·z, S_yz·z, 0)",
                        fmt3(sq, 4)
                    ),
                )?;
                for ax in 0..3 {
                    let names_l: Vec<String> = (0..3)
                        .map(|d| format!("{} {:+.3}", linear_name(d, ax), v.linear_um[ax][d]))
                        .collect();
                    let names_a: Vec<String> = (0..3)
                        .map(|d| format!("{} {:+.2}", angular_name(d, ax), v.angular_urad[ax][d]))
                        .collect();
                    let arm = k.arm_mm(ax, q, tool);
                    let c = m.axis_contribution_um(ax, q, s[ax], tool, Form::FirstOrder)?;
                    w(
                        &mut out,
                        format!(
                            "{} ({}{}) {} µm   {} µrad",
                            AXES[ax],
                            if k.topology.carries_workpiece(ax) {
                                "workpiece side"
                            } else {
                                "tool side"
                            },
                            if s[ax] == Direction::Reverse {
                                ", reverse"
                            } else {
                                ""
                            },
                            names_l.join("  "),
                            names_a.join("  ")
                        ),
                    )?;
                    w(
                        &mut out,
                        format!(
                            "    Abbe arm {:.3}, {:.3}, {:.3} mm   contribution {} µm",
                            arm.x,
                            arm.y,
                            arm.z,
                            fmt3(c, 4)
                        ),
                    )?;
                }
            }
        }
    }
    Ok(())
}

/// The measuring point and tool shared by every axis, if they are shared.
fn shared_measuring(m: &KinematicModel) -> (Option<Vec3>, Option<Vec3>) {
    let l = m.kinematics.measuring;
    let p =
        (l[0].point_mm == l[1].point_mm && l[1].point_mm == l[2].point_mm).then_some(l[0].point_mm);
    let t = (l[0].tool_offset_mm == l[1].tool_offset_mm
        && l[1].tool_offset_mm == l[2].tool_offset_mm)
        .then_some(l[0].tool_offset_mm);
    (p, t)
}

/// Evenly spaced points from `lo` to `hi` inclusive, at most `step` apart.
fn grid_axis(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = (((hi - lo) / step).ceil() as usize).max(1);
    (0..=n)
        .map(|k| {
            if k == n {
                hi
            } else {
                lo + (hi - lo) * k as f64 / n as f64
            }
        })
        .collect()
}

/// Largest |e_model − e_tables| over a 5×5×5 grid of the range, all forward.
fn largest_difference(
    model: &KinematicModel,
    tool: Vec3,
    map: &AxisTableMap,
) -> Result<f64, CliError> {
    let r = model.range_mm();
    let axes: Vec<Vec<f64>> = (0..3)
        .map(|a| grid_axis(r[a][0], r[a][1], (r[a][1] - r[a][0]) / 4.0))
        .collect();
    let mut worst: f64 = 0.0;
    for &x in &axes[0] {
        for &y in &axes[1] {
            for &z in &axes[2] {
                let q = Vec3::new(x, y, z);
                let s = [Direction::Forward; 3];
                let e = model.deviation_with_tool_um(q, s, Components::All, tool)?;
                let t = map.deviation_um(q, s, Components::All)?;
                worst = worst.max((e - t).norm());
            }
        }
    }
    Ok(worst)
}

/// The files a model written as `out` (.toml) consists of: it and its
/// tables beside it (same stem, .csv).
fn model_outputs(plan: &mut OutputPlan, flag: &str, out: &Path) {
    plan.output(flag, out);
    let is_toml = out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_toml {
        plan.output(
            format!("{flag} (its tables beside it)"),
            out.with_extension("csv"),
        );
    }
}

fn convert(a: ConvertArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map);
    match a.to {
        ConvertTarget::Linuxcnc => {
            for axis in AXES {
                let name = format!("{}.comp", axis.to_ascii_lowercase());
                plan.output(format!("-o (its {name})"), a.output.join(&name));
            }
        }
        ConvertTarget::Model => model_outputs(&mut plan, "-o", &a.output),
        _ => {
            plan.output("-o", &a.output);
        }
    }
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let form: Form = a.form.into();
    match a.to {
        ConvertTarget::AxisTable => {
            let Map::Kinematic(m) = &map else {
                return Err(CliError::Message(format!(
                    "{} already is an axis-table map",
                    a.map.display()
                )));
            };
            let mut m = (**m).clone();
            m.form = form;
            let Some(tool) = a.tool.offset()? else {
                return Err(CliError::Message("axis tables hold the deviation for one tool: pass --tool-length MM (or --tool-offset X,Y,Z), e.g. the length of the tool the program uses".into()));
            };
            let reference = match (&a.at, shared_measuring(&m).0) {
                (Some(t), _) => parse_triple(t, "--at")?,
                (None, Some(p)) => p,
                (None, None) => return Err(CliError::Message("the model's axes were measured along different lines: pass --at X,Y,Z, the position whose three lines the axis tables should reproduce (e.g. the middle of the part)".into())),
            };
            let tables = m.to_axis_tables(reference, tool, form)?;
            let worst = largest_difference(&m, tool, &tables)?;
            let text = tables.to_csv();
            write_atomically(&a.output, &[&a.map], |w| {
                w.write_all(text.as_bytes())
                    .map_err(|e| CliError::Io(a.output.clone(), e))
            })?;
            eprintln!(
                "volcomp: wrote {} for tool length offset ({}, {}, {}) mm, exact on the lines through ({}, {}, {}) mm; elsewhere it differs from the model by up to {worst:.3} µm (the Abbe cross terms an axis-table map cannot hold)",
                a.output.display(), tool.x, tool.y, tool.z, reference.x, reference.y, reference.z
            );
            Ok(())
        }
        ConvertTarget::Grid => {
            let step = positive_step(a.step)?.unwrap_or(25.0);
            let s = parse_directions(&a.direction)?;
            let tool = a.tool.offset()?.unwrap_or(Vec3::ZERO);
            let model = map.model();
            let r = model.range_mm();
            let estimate: f64 = (0..3)
                .map(|k| ((r[k][1] - r[k][0]) / step).ceil().max(1.0) + 1.0)
                .product();
            if estimate > 5e6 {
                return Err(CliError::Message(format!(
                    "a {step} mm grid over this range has {estimate} points; choose a larger --step"
                )));
            }
            let axes: Vec<Vec<f64>> = (0..3).map(|k| grid_axis(r[k][0], r[k][1], step)).collect();
            let count = axes.iter().map(Vec::len).product::<usize>();
            let mut text = format!(
                "# volcomp 3-D grid of {}: e = actual - commanded (µm) at axis positions (mm)\n# tool length offset {}, {}, {} mm; directions {} (X, Y, Z; + forward, - reverse)\nx_mm,y_mm,z_mm,ex_um,ey_um,ez_um\n",
                a.map.display(), tool.x, tool.y, tool.z, dir_letters(s)
            );
            for &x in &axes[0] {
                for &y in &axes[1] {
                    for &z in &axes[2] {
                        let q = Vec3::new(x, y, z);
                        let e = model.deviation_with_tool_um(q, s, Components::All, tool)?;
                        text.push_str(&format!(
                            "{},{},{},{},{},{}\n",
                            numfmt::mm(x),
                            numfmt::mm(y),
                            numfmt::mm(z),
                            numfmt::um(e.x),
                            numfmt::um(e.y),
                            numfmt::um(e.z)
                        ));
                    }
                }
            }
            write_atomically(&a.output, &[&a.map], |w| {
                w.write_all(text.as_bytes())
                    .map_err(|e| CliError::Io(a.output.clone(), e))
            })?;
            eprintln!("volcomp: wrote {} ({count} points)", a.output.display());
            Ok(())
        }
        ConvertTarget::Linuxcnc => {
            let (ty, units) = a.comp.get()?;
            let tables: [Positioning; 3] = match &map {
                Map::Tables(t) => [0, 1, 2].map(|k| positioning_of_tables(t, k)),
                Map::Kinematic(m) => {
                    let tool = a.tool.offset()?;
                    if a.at.is_none() && tool.is_none() {
                        // The positioning errors as measured, at the measuring line.
                        [0, 1, 2].map(|k| {
                            let (p, f, r) = m.positioning(k);
                            Positioning {
                                positions_mm: p,
                                forward_um: f,
                                reverse_um: r,
                            }
                        })
                    } else {
                        let (shared_p, shared_t) = shared_measuring(m);
                        let reference = match (&a.at, shared_p) {
                            (Some(t), _) => parse_triple(t, "--at")?,
                            (None, Some(p)) => p,
                            (None, None) => return Err(CliError::Message("pass --at X,Y,Z: the model's axes were measured along different lines".into())),
                        };
                        let tool = match (tool, shared_t) {
                            (Some(t), _) | (None, Some(t)) => t,
                            (None, None) => {
                                return Err(CliError::Message("pass --tool-length MM".into()))
                            }
                        };
                        let t = m.to_axis_tables(reference, tool, form)?;
                        [0, 1, 2].map(|k| positioning_of_tables(&t, k))
                    }
                }
            };
            let tables = match positive_step(a.step)? {
                Some(step) => tables.map(|p| resample(&p, step)),
                None => tables,
            };
            std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
            let mut names = Vec::new();
            for (k, p) in tables.iter().enumerate() {
                let text = linuxcnc_comp::write(p, ty, units).map_err(|m| {
                    CliError::Message(format!(
                        "axis {}: {m}; pass --step MM to resample the table (linear interpolation) at a spacing LinuxCNC can hold",
                        AXES[k]
                    ))
                })?;
                let path = a
                    .output
                    .join(format!("{}.comp", AXES[k].to_ascii_lowercase()));
                write_atomically(&path, &[&a.map], |w| {
                    w.write_all(text.as_bytes())
                        .map_err(|e| CliError::Io(path.clone(), e))
                })?;
                names.push(path);
            }
            let stdout = std::io::stdout();
            let mut out = stdout.lock();
            writeln!(out, "# LinuxCNC INI lines (joints 0, 1, 2 = X, Y, Z with trivkins); remove BACKLASH, the comp files hold the reversal").map_err(CliError::Stdout)?;
            for (k, p) in names.iter().enumerate() {
                writeln!(
                    out,
                    "[JOINT_{k}]\nCOMP_FILE = {}\nCOMP_FILE_TYPE = {}",
                    p.display(),
                    ty.number()
                )
                .map_err(CliError::Stdout)?;
            }
            Ok(())
        }
        ConvertTarget::Model => {
            let model = match map {
                Map::Tables(t) => {
                    let topology = parse_chain(a.chain.as_deref())?;
                    KinematicModel::from_axis_tables(t.as_ref(), topology)
                }
                Map::Kinematic(m) => *m,
            };
            write_model(&model, &a.output, &[&a.map], None)
        }
    }
}

fn positive_step(step: Option<f64>) -> Result<Option<f64>, CliError> {
    match step {
        Some(s) if !(s.is_finite() && s > 0.0) => Err(CliError::Message(format!(
            "--step must be a positive length in mm; got {s}"
        ))),
        other => Ok(other),
    }
}

/// A positioning table resampled every `step` mm over its range (linear
/// interpolation, both ends kept).
fn resample(p: &Positioning, step: f64) -> Positioning {
    let n = p.positions_mm.len();
    let (lo, hi) = (p.positions_mm[0], p.positions_mm[n - 1]);
    let positions = grid_axis(lo, hi, step);
    let at = |v: &[f64], x: f64| -> f64 {
        let i = p.positions_mm.partition_point(|&q| q <= x).clamp(1, n - 1) - 1;
        let (x0, x1) = (p.positions_mm[i], p.positions_mm[i + 1]);
        v[i] + (v[i + 1] - v[i]) * (x - x0) / (x1 - x0)
    };
    Positioning {
        forward_um: positions.iter().map(|&x| at(&p.forward_um, x)).collect(),
        reverse_um: positions.iter().map(|&x| at(&p.reverse_um, x)).collect(),
        positions_mm: positions,
    }
}

fn parse_chain(chain: Option<&str>) -> Result<Topology, CliError> {
    match chain {
        Some(c) => Topology::parse(c).map_err(|e| CliError::Message(format!("--chain: {e}"))),
        None => Ok(Topology::SEED),
    }
}

/// `E_aa` of an axis-table map at the union of its forward and reverse positions.
fn positioning_of_tables(t: &AxisTableMap, a: usize) -> Positioning {
    let mut positions: Vec<f64> = t.axes[a]
        .forward
        .positions_mm
        .iter()
        .chain(&t.axes[a].reverse.positions_mm)
        .copied()
        .collect();
    positions.sort_by(f64::total_cmp);
    positions.dedup();
    let along = |table: &Table| -> Vec<f64> {
        let [lo, hi] = table.range();
        positions
            .iter()
            .map(|&x| table.eval(x.clamp(lo, hi)).map(|v| v[a]).unwrap_or(0.0))
            .collect()
    };
    Positioning {
        forward_um: along(&t.axes[a].forward),
        reverse_um: along(&t.axes[a].reverse),
        positions_mm: positions,
    }
}

/// Axis tables holding only positioning errors.
fn tables_of_positioning(p: &[Positioning; 3]) -> AxisTableMap {
    let axes = [0, 1, 2].map(|a| {
        let table = |v: &[f64]| Table {
            positions_mm: p[a].positions_mm.clone(),
            errors_um: v
                .iter()
                .map(|e| {
                    let mut w = Vec3::ZERO;
                    w[a] = *e;
                    w
                })
                .collect(),
        };
        AxisTables {
            forward: table(&p[a].forward_um),
            reverse: table(&p[a].reverse_um),
        }
    });
    AxisTableMap { axes, clamp: false }
}

/// Writes `model` as `out` (TOML) and its tables beside it (same stem, .csv).
fn write_model(
    model: &KinematicModel,
    out: &Path,
    inputs: &[&Path],
    description: Option<&str>,
) -> Result<(), CliError> {
    if out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
        != Some("toml")
    {
        return Err(CliError::Message(format!("{}: a 21-component model is written as a .toml file (its tables go to a .csv beside it)", out.display())));
    }
    let csv_path = out.with_extension("csv");
    let csv_name = csv_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let toml = model_file::model_to_toml(model, &csv_name, description);
    let csv = model_file::components_to_csv(&model.axes);
    write_atomically(&csv_path, inputs, |w| {
        w.write_all(csv.as_bytes())
            .map_err(|e| CliError::Io(csv_path.clone(), e))
    })?;
    write_atomically(out, inputs, |w| {
        w.write_all(toml.as_bytes())
            .map_err(|e| CliError::Io(out.to_path_buf(), e))
    })?;
    eprintln!(
        "volcomp: wrote {} and {}",
        out.display(),
        csv_path.display()
    );
    Ok(())
}

/// One series per direction of a component, or one when both directions agree.
fn component_series(
    name: String,
    forward: (&[f64], Vec<f64>),
    reverse: (&[f64], Vec<f64>),
) -> Vec<Series> {
    if forward.0 == reverse.0 && forward.1 == reverse.1 {
        vec![Series::line(
            name,
            forward.0.iter().copied().zip(forward.1).collect(),
        )]
    } else {
        vec![
            Series::line(
                format!("{name} forward"),
                forward.0.iter().copied().zip(forward.1).collect(),
            ),
            Series::line(
                format!("{name} reverse"),
                reverse.0.iter().copied().zip(reverse.1).collect(),
            ),
        ]
    }
}

fn plot(a: PlotArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map).output("-o", &a.output);
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let name = a
        .map
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| a.map.display().to_string());
    let mut charts = Vec::new();
    let column = |t: &Table, d: usize| -> Vec<f64> { t.errors_um.iter().map(|e| e[d]).collect() };
    match &map {
        Map::Tables(m) => {
            for (k, t) in m.axes.iter().enumerate() {
                let mut series = Vec::new();
                for d in 0..3 {
                    series.extend(component_series(
                        linear_name(d, k),
                        (&t.forward.positions_mm, column(&t.forward, d)),
                        (&t.reverse.positions_mm, column(&t.reverse, d)),
                    ));
                }
                charts.push(Chart {
                    title: format!("{name}: errors caused by {} (axis tables)", AXES[k]),
                    x_label: format!("{} position (mm)", AXES[k]),
                    y_label: "error (µm)".into(),
                    series,
                    ..Chart::default()
                });
            }
        }
        Map::Kinematic(m) => {
            let k = &m.kinematics;
            for (ax, t) in m.axes.iter().enumerate() {
                let mut linear = Vec::new();
                let mut angular = Vec::new();
                for d in 0..3 {
                    linear.extend(component_series(
                        linear_name(d, ax),
                        (t.forward.positions_mm(), column(&t.forward.linear_um, d)),
                        (t.reverse.positions_mm(), column(&t.reverse.linear_um, d)),
                    ));
                    angular.extend(component_series(
                        angular_name(d, ax),
                        (t.forward.positions_mm(), column(&t.forward.angular_urad, d)),
                        (t.reverse.positions_mm(), column(&t.reverse.angular_urad, d)),
                    ));
                }
                let extra = match ax {
                    0 => format!(" (chain {})", k.topology),
                    1 => format!(" (squareness S_xy {} µrad)", k.squareness.xy_urad),
                    _ => format!(
                        " (squareness S_yz {}, S_zx {} µrad)",
                        k.squareness.yz_urad, k.squareness.zx_urad
                    ),
                };
                charts.push(Chart {
                    title: format!(
                        "{name}: positioning and straightness of {}{extra}",
                        AXES[ax]
                    ),
                    x_label: format!("{} position (mm)", AXES[ax]),
                    y_label: "error (µm)".into(),
                    series: linear,
                    ..Chart::default()
                });
                charts.push(Chart {
                    title: format!("{name}: angular errors of {}", AXES[ax]),
                    x_label: format!("{} position (mm)", AXES[ax]),
                    y_label: "rotation (µrad)".into(),
                    series: angular,
                    ..Chart::default()
                });
            }
        }
    }
    write_charts(&charts, &a.output)?;
    eprintln!(
        "volcomp: wrote {} ({} charts)",
        a.output.display(),
        charts.len()
    );
    Ok(())
}

fn read_comp(path: &Path, ty: CompFileType, units: MachineUnits) -> Result<Positioning, CliError> {
    let text = super::read_utf8(path)?;
    Ok(linuxcnc_comp::parse(
        &text,
        &path.display().to_string(),
        ty,
        units,
    )?)
}

fn import_linuxcnc(a: ImportArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("--x", &a.x)
        .input("--y", &a.y)
        .input("--z", &a.z);
    model_outputs(&mut plan, "-o", &a.output);
    check(&plan)?;
    let (ty, units) = a.comp.get()?;
    let p = [
        read_comp(&a.x, ty, units)?,
        read_comp(&a.y, ty, units)?,
        read_comp(&a.z, ty, units)?,
    ];
    let tables = tables_of_positioning(&p);
    let inputs: [&Path; 3] = [&a.x, &a.y, &a.z];
    let ext = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("csv") => {
            let text =
                format!(
                "# imported from LinuxCNC comp files (type {}, {}): positioning errors only\n{}",
                ty.number(),
                match units { MachineUnits::Mm => "mm", MachineUnits::Inch => "inch" },
                tables.to_csv()
            );
            write_atomically(&a.output, &inputs, |w| {
                w.write_all(text.as_bytes())
                    .map_err(|e| CliError::Io(a.output.clone(), e))
            })?;
            eprintln!("volcomp: wrote {}", a.output.display());
            Ok(())
        }
        Some("toml") => {
            let topology = parse_chain(a.chain.as_deref())?;
            let model = KinematicModel::from_axis_tables(&tables, topology);
            write_model(
                &model,
                &a.output,
                &inputs,
                Some("imported from LinuxCNC comp files: positioning errors only"),
            )
        }
        _ => Err(CliError::Message(format!(
            "{}: write an axis-table .csv or a 21-component .toml",
            a.output.display()
        ))),
    }
}

fn iso230_2(a: IsoArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("RUNS", &a.runs)
        .output_opt("-o", a.output.as_ref());
    check(&plan)?;
    let text = std::fs::read_to_string(&a.runs).map_err(|e| CliError::Io(a.runs.clone(), e))?;
    let r = iso230_2::from_csv(&text, &a.runs.display().to_string())?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if a.json {
        writeln!(out, "{}", serde_json::to_string(&r)?).map_err(CliError::Stdout)?;
    } else {
        let w = |out: &mut std::io::StdoutLock, t: String| {
            writeln!(out, "{t}").map_err(CliError::Stdout)
        };
        w(
            &mut out,
            format!(
                "{}: ISO 230-2 evaluation, {} target positions (µm)",
                a.runs.display(),
                r.targets.len()
            ),
        )?;
        w(&mut out, "  target_mm     n↑  n↓     x̄↑       x̄↓       s↑      s↓      B_i      x̄_i     R↑_i    R↓_i    R_i".into())?;
        for t in &r.targets {
            w(&mut out, format!(
                "  {:>10.3}  {:>3} {:>3}  {:>+8.3} {:>+8.3} {:>7.3} {:>7.3} {:>+8.3} {:>+8.3} {:>7.3} {:>7.3} {:>7.3}",
                t.target_mm, t.n_up, t.n_down, t.mean_up_um, t.mean_down_um, t.s_up_um, t.s_down_um,
                t.reversal_um, t.mean_um, t.repeatability_up_um, t.repeatability_down_um, t.repeatability_um
            ))?;
        }
        let f = r.axis;
        w(
            &mut out,
            format!(
                "reversal value               B  = {:.3} µm   (mean reversal value B̄ = {:+.3} µm)",
                f.reversal_b_um, f.mean_reversal_um
            ),
        )?;
        w(
            &mut out,
            format!(
                "repeatability                R↑ = {:.3} µm   R↓ = {:.3} µm   R = {:.3} µm",
                f.repeatability_up_um, f.repeatability_down_um, f.repeatability_um
            ),
        )?;
        w(
            &mut out,
            format!(
                "systematic deviation         E↑ = {:.3} µm   E↓ = {:.3} µm   E = {:.3} µm",
                f.systematic_up_um, f.systematic_down_um, f.systematic_um
            ),
        )?;
        w(
            &mut out,
            format!(
                "mean bidirectional range     M  = {:.3} µm",
                f.mean_range_um
            ),
        )?;
        w(
            &mut out,
            format!(
                "accuracy                     A↑ = {:.3} µm   A↓ = {:.3} µm   A = {:.3} µm",
                f.accuracy_up_um, f.accuracy_down_um, f.accuracy_um
            ),
        )?;
        for n in &r.notes {
            w(&mut out, format!("note: {n}"))?;
        }
    }
    if let (Some(path), Some(axis)) = (&a.output, a.axis) {
        let k = axis.index();
        let p = r.positioning();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let text = match ext.as_deref() {
            Some("comp") => {
                let (ty, units) = a.comp.get()?;
                linuxcnc_comp::write(&p, ty, units).map_err(CliError::Message)?
            }
            Some("csv") => {
                let mut s = format!(
                    "# ISO 230-2 mean unidirectional deviations of {} from {}: positioning only\n{}\n",
                    AXES[k],
                    a.runs.display(),
                    model_file::CSV_HEADER
                );
                for (dir, v) in [("forward", &p.forward_um), ("reverse", &p.reverse_um)] {
                    for (x, e) in p.positions_mm.iter().zip(v.iter()) {
                        let mut lin = [0.0; 3];
                        lin[k] = *e;
                        s.push_str(&format!(
                            "{},{dir},{},{},{},{},0,0,0\n",
                            AXES[k],
                            numfmt::mm(*x),
                            numfmt::um(lin[0]),
                            numfmt::um(lin[1]),
                            numfmt::um(lin[2])
                        ));
                    }
                }
                s
            }
            _ => return Err(CliError::Message(format!("{}: write the positioning table as .csv (21-component table rows) or .comp (LinuxCNC)", path.display()))),
        };
        write_atomically(path, &[&a.runs], |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
        eprintln!("volcomp: wrote {}", path.display());
    }
    Ok(())
}

fn example(a: ExampleArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
    let (toml, csv) = kinematic_example::example_files("example21.csv");
    let csv_path = a.output.join("example21.csv");
    let toml_path = a.output.join("example21.toml");
    write_atomically(&csv_path, &[], |w| {
        w.write_all(csv.as_bytes())
            .map_err(|e| CliError::Io(csv_path.clone(), e))
    })?;
    write_atomically(&toml_path, &[], |w| {
        w.write_all(toml.as_bytes())
            .map_err(|e| CliError::Io(toml_path.clone(), e))
    })?;
    eprintln!(
        "volcomp: wrote {} and {}",
        toml_path.display(),
        csv_path.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_parse() {
        use Direction::{Forward as F, Reverse as R};
        assert_eq!(parse_directions("forward").unwrap(), [F, F, F]);
        assert_eq!(parse_directions("-").unwrap(), [R, R, R]);
        assert_eq!(parse_directions("frf").unwrap(), [F, R, F]);
        assert_eq!(parse_directions("+-+").unwrap(), [F, R, F]);
        assert!(parse_directions("fr").is_err());
    }

    #[test]
    fn grid_axis_ends_on_the_range() {
        assert_eq!(
            grid_axis(0.0, 100.0, 25.0),
            vec![0.0, 25.0, 50.0, 75.0, 100.0]
        );
        let g = grid_axis(0.0, 90.0, 25.0);
        assert_eq!(g.len(), 5);
        assert_eq!(*g.last().unwrap(), 90.0);
    }
}
