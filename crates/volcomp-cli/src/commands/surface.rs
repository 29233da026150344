//! `volcomp surface mirror`: free-form surface compensation from on-machine
//! probing (the mirror method, `docs/mirror.md`). Flags, validation, files
//! and printing; the method is `volcomp_core::surface::mirror`.

use super::compensate::{date_utc, file_name, refuse_if_compensated};
use super::Machine;
use crate::args::MachineArgs;
use crate::output::{check, write_atomically, CliError, OutputPlan};
use clap::{Args, Subcommand, ValueEnum};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use volcomp_core::surface::bspline::Parameterization;
use volcomp_core::compensate::survey_style;
use volcomp_core::surface::mirror::{
    compensate_finishing, mirror, program_frame_offset, read_bspline_toml, read_grid_csv,
    read_probe_points, write_bspline_toml, BallTool, ClPoint, CompensatedSurface, DeviationField,
    DeviationStats, FinishingOptions, FinishingSummary, FitInfo, FitMethod, MatchedPoint,
    MaterialSide, MirrorOptions, MirrorResult, NominalSurface, SurfaceModel,
};
use volcomp_core::io::provenance::{sha256_hex, HeaderWriter, ProgramHeader};

/// Free-form surfaces.
#[derive(Args, Debug)]
pub struct SurfaceArgs {
    #[command(subcommand)]
    pub command: SurfaceCommand,
}

#[derive(Subcommand, Debug)]
pub enum SurfaceCommand {
    /// Mirror compensation: fit the probed error of a semi-finished surface and
    /// move a ball-end finishing program so that it lands on the nominal.
    Mirror(MirrorArgs),
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Material {
    /// Below the surface (−Z): the tool comes from above.
    Below,
    /// Above the surface (+Z).
    Above,
    /// The surface's own normal (Su × Sv) points out of the material.
    NormalOut,
    /// The surface's own normal (Su × Sv) points into the material.
    NormalIn,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Fit {
    /// Bicubic least squares, the control net chosen by leave-one-out
    /// cross-validation (any probe pattern).
    LeastSquares,
    /// Bicubic interpolation through every point (probe grid with i,j columns).
    Interpolate,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum GridParams {
    /// Chord length, averaged over the grid rows.
    ChordLength,
    /// Centripetal (square root of the chord length), averaged.
    Centripetal,
    /// Equally spaced.
    Uniform,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Cl {
    /// The tool tip (the ball centre is one radius above it, +Z).
    Tip,
    /// The ball centre.
    Center,
}

#[derive(Args, Debug)]
pub struct MirrorArgs {
    /// Nominal finishing surface: a B-spline surface (.toml) or a grid of
    /// points (.csv), in the program frame.
    #[arg(long, value_name = "SURF")]
    pub nominal: PathBuf,
    /// Probe points of the semi-finished part (CSV: x_mm,y_mm,z_mm; optional id, i, j).
    #[arg(long, value_name = "POINTS")]
    pub measured: PathBuf,
    /// Stock D the semi-finishing pass leaves on the nominal surface (mm).
    #[arg(long, value_name = "D")]
    pub stock: f64,
    /// Which side of the surface the material is on.
    #[arg(long, value_enum, default_value_t = Material::Below)]
    pub material: Material,
    /// Probe ball radius (mm) when the points are ball centres; leave out when
    /// the probing software already compensated it.
    #[arg(long, value_name = "MM")]
    pub probe_radius: Option<f64>,
    /// Largest accepted distance of a probe point from where it should be
    /// (nominal + stock), in mm; farther points are refused as mismatched.
    #[arg(long, value_name = "MM", default_value_t = 0.1)]
    pub max_error: f64,
    /// How the compensation points are fitted.
    #[arg(long, value_enum, default_value_t = Fit::LeastSquares)]
    pub fit: Fit,
    /// Only consider control nets whose residual at every compensation point is within
    /// this (µm). Every residual includes the probe noise: give at least 3× its σ.
    /// Without it the net is chosen by leave-one-out cross-validation alone.
    #[arg(long, value_name = "UM")]
    pub tolerance: Option<f64>,
    /// Refuse (write nothing, exit non-zero) when the leave-one-out prediction of the
    /// finishing error after compensation is worse (larger std) than not compensating;
    /// without it a warning is printed.
    #[arg(long)]
    pub refuse_worse: bool,
    /// Parameters used to interpolate a grid nominal (CSV).
    #[arg(long, value_enum, default_value_t = GridParams::ChordLength)]
    pub grid_params: GridParams,
    /// Base name of the compensated surface files BASE.csv (grid) and
    /// BASE.toml (B-spline) [default: POINTS without extension + ".compensated"].
    #[arg(long, value_name = "BASE")]
    pub surface_out: Option<PathBuf>,
    /// Nodes per direction of the compensated grid when the nominal is a
    /// B-spline (a grid nominal keeps its own nodes).
    #[arg(long, value_name = "N", default_value_t = 41)]
    pub grid_size: usize,
    /// Ball-end finishing program to compensate.
    #[arg(long, value_name = "PROGRAM", requires_all = ["output", "tool_radius"])]
    pub finishing: Option<PathBuf>,
    /// The compensated finishing program.
    #[arg(short, long, value_name = "OUT", requires = "finishing")]
    pub output: Option<PathBuf>,
    /// Also write the finishing program with the tool-radius baseline (a
    /// constant offset that only removes the mean error), for comparison.
    #[arg(long, value_name = "FILE", requires = "finishing")]
    pub baseline: Option<PathBuf>,
    /// Ball radius of the finishing tool (mm; half its diameter).
    #[arg(long, value_name = "MM")]
    pub tool_radius: Option<f64>,
    /// Which point of the tool the program's coordinates give.
    #[arg(long, value_enum, default_value_t = Cl::Tip)]
    pub cl_point: Cl,
    /// A CL point is on the surface when its ball is this close to it (mm).
    #[arg(long, value_name = "MM", default_value_t = 0.02)]
    pub contact_tolerance: f64,
    /// Split feed moves into pieces of at most this length (mm).
    #[arg(long, value_name = "MM", default_value_t = 2.0)]
    pub segment_length: f64,
    /// Do not split feed moves (arcs are still linearised).
    #[arg(long)]
    pub no_split: bool,
    /// Decimal places of written coordinates (default 4 in mm, 5 in inch).
    #[arg(long)]
    pub decimals: Option<u8>,
    /// Do not tag inserted lines with `(volcomp Ln)` comments.
    #[arg(long)]
    pub no_trace: bool,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Write a report: .json (summary and every point) or CSV (one row per
    /// point, the summary in `#` lines).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Print the summary as one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Compensate a finishing program that volcomp compensated already.
    #[arg(long)]
    pub allow_recompensate: bool,
}

pub fn run(a: SurfaceArgs) -> Result<(), CliError> {
    match a.command {
        SurfaceCommand::Mirror(m) => run_mirror(m),
    }
}

fn read_text(path: &Path) -> Result<String, CliError> {
    std::fs::read_to_string(path).map_err(|e| CliError::Io(path.to_path_buf(), e))
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

fn positive(v: f64, flag: &str, what: &str) -> Result<(), CliError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(CliError::Message(format!("{flag} must be {what}; got {v}")))
    }
}

/// Loads the nominal surface by its extension.
fn load_nominal(a: &MirrorArgs) -> Result<NominalSurface, CliError> {
    let file = a.nominal.display().to_string();
    let text = read_text(&a.nominal)?;
    let side = match a.material {
        Material::Below => MaterialSide::Below,
        Material::Above => MaterialSide::Above,
        Material::NormalOut => MaterialSide::NormalOut,
        Material::NormalIn => MaterialSide::NormalIn,
    };
    match extension(&a.nominal).as_str() {
        "toml" => Ok(NominalSurface::new(
            read_bspline_toml(&text, &file)?,
            side,
            &file,
        )?),
        "csv" => {
            let grid = read_grid_csv(&text, &file)?;
            let params = match a.grid_params {
                GridParams::ChordLength => Parameterization::ChordLength,
                GridParams::Centripetal => Parameterization::Centripetal,
                GridParams::Uniform => Parameterization::Uniform,
            };
            Ok(NominalSurface::from_grid(&grid, &params, side, &file)?)
        }
        _ => Err(CliError::Message(format!(
            "{file}: the nominal surface must be a B-spline surface (.toml) or a grid of points (.csv)"
        ))),
    }
}

fn default_base(measured: &Path) -> PathBuf {
    let stem = measured
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "surface".into());
    measured.with_file_name(format!("{stem}.compensated"))
}

fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// What the finishing part of the run did, for printing.
struct FinishingRun {
    output: PathBuf,
    summary: FinishingSummary,
    baseline: Option<(PathBuf, FinishingSummary)>,
}

/// What was written for the compensated surface.
#[derive(serde::Serialize)]
struct SurfaceFiles {
    grid: String,
    grid_nodes: (usize, usize),
    bspline: String,
    bspline_net: (usize, usize),
    bspline_error_um: f64,
}

fn run_mirror(a: MirrorArgs) -> Result<(), CliError> {
    {
        let base = a
            .surface_out
            .clone()
            .unwrap_or_else(|| default_base(&a.measured));
        let mut plan = OutputPlan::new();
        plan.input("--nominal", &a.nominal)
            .input("--measured", &a.measured)
            .input_opt("--finishing", a.finishing.as_ref())
            .input_opt("--setup", a.machine.setup.as_ref())
            .output_opt("-o", a.output.as_ref())
            .output_opt("--baseline", a.baseline.as_ref())
            .output("--surface-out (grid)", with_suffix(&base, ".csv"))
            .output("--surface-out (B-spline)", with_suffix(&base, ".toml"))
            .output_opt("--report", a.report.as_ref());
        check(&plan)?;
    }
    positive(a.stock, "--stock", "a positive length in mm")?;
    positive(a.max_error, "--max-error", "a positive length in mm")?;
    if let Some(t) = a.tolerance {
        positive(t, "--tolerance", "a positive number of µm")?;
    }
    positive(
        a.contact_tolerance,
        "--contact-tolerance",
        "a positive length in mm",
    )?;
    if let Some(r) = a.probe_radius {
        if !(r.is_finite() && r >= 0.0) {
            return Err(CliError::Message(format!(
                "--probe-radius must be a length ≥ 0 in mm; got {r}"
            )));
        }
    }
    if !a.no_split {
        positive(
            a.segment_length,
            "--segment-length",
            "a positive length in mm",
        )?;
    }
    if !(2..=1001).contains(&a.grid_size) {
        return Err(CliError::Message(format!(
            "--grid-size must be 2 … 1001; got {}",
            a.grid_size
        )));
    }
    if a.decimals.is_some_and(|d| !(1..=9).contains(&d)) {
        return Err(CliError::Message("--decimals must be 1 … 9".into()));
    }
    let tool = match (&a.finishing, a.tool_radius) {
        (Some(_), Some(r)) => {
            positive(r, "--tool-radius", "the ball's radius in mm")?;
            Some(BallTool {
                radius_mm: r,
                cl: match a.cl_point {
                    Cl::Tip => ClPoint::Tip,
                    Cl::Center => ClPoint::Centre,
                },
            })
        }
        _ => None,
    };

    let nominal = load_nominal(&a)?;
    let measured_file = a.measured.display().to_string();
    let probes = read_probe_points(&read_text(&a.measured)?, &measured_file)?;
    let options = MirrorOptions {
        stock_mm: a.stock,
        probe_radius_mm: a.probe_radius,
        max_error_mm: a.max_error,
        fit: match a.fit {
            Fit::LeastSquares => FitMethod::LeastSquares {
                tolerance_um: a.tolerance,
            },
            Fit::Interpolate => FitMethod::Interpolate,
        },
    };
    let result = mirror(&nominal, &probes, &options, &measured_file)?;
    if result.compensation_predicted_worse() {
        let p = result
            .mirror_predicted
            .as_ref()
            .map_or(f64::NAN, |p| p.std_um);
        let message = format!(
            "the leave-one-out prediction of the finishing error after compensation (std {p:.3} µm) is worse than not compensating (std {:.3} µm): the fit ({} × {} control net) does not predict the error between the probe points",
            result.before.std_um, result.fit.net.0, result.fit.net.1
        );
        if a.refuse_worse {
            return Err(CliError::Message(format!(
                "{measured_file}: {message}\n  help: probe more densely or check the probe points (an outlier?); nothing was written"
            )));
        }
        eprintln!(
            "volcomp: warning: {measured_file}: {message}; check the probe points, or pass --refuse-worse to refuse"
        );
    }
    let inputs: Vec<&Path> = [
        Some(a.nominal.as_path()),
        Some(a.measured.as_path()),
        a.finishing.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();

    // The finishing program first: it is the step most likely to be refused,
    // and nothing should be written then.
    let finishing = match (&a.finishing, &a.output, tool) {
        (Some(program), Some(output), Some(tool)) => {
            if program.as_os_str() == "-" {
                return Err(CliError::Message(
                    "--finishing needs a file: the program is read twice (its frame first)".into(),
                ));
            }
            let machine = Machine::from_args(&a.machine)?;
            let file = program.display().to_string();
            let frame = program_frame_offset(&mut machine.walk(program)?, &file)?;
            let opts = FinishingOptions {
                segment_length_mm: (!a.no_split).then_some(a.segment_length),
                decimals: a.decimals,
                trace_comments: !a.no_trace,
                ..FinishingOptions::default()
            };
            let run_one = |field: &DeviationField,
                           out: &Path|
             -> Result<FinishingSummary, CliError> {
                let model = SurfaceModel::new(&nominal, field, tool, frame, a.contact_tolerance)?;
                let mut head = Vec::with_capacity(1 << 16);
                std::fs::File::open(program)
                    .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
                    .map_err(|e| CliError::Io(program.clone(), e))?;
                if !a.allow_recompensate {
                    refuse_if_compensated(&head, &file)?;
                }
                let style = survey_style(&head);
                let mut walker = machine.walk(program)?;
                let mut summary = None;
                let header = mirror_header(
                    &a,
                    &machine,
                    out == a.baseline.as_deref().unwrap_or(Path::new("")),
                )?;
                write_atomically(out, &inputs, |w| {
                    let mut w = HeaderWriter::new(w, header.lines());
                    summary = Some(compensate_finishing(
                        &mut walker,
                        &file,
                        &style,
                        &model,
                        &opts,
                        &mut w,
                    )?);
                    w.finish().map_err(|e| CliError::Io(out.to_path_buf(), e))?;
                    Ok(())
                })?;
                summary.ok_or_else(|| {
                    CliError::Message("the finishing run produced no summary".into())
                })
            };
            let summary = run_one(&result.field, output)?;
            let baseline = match &a.baseline {
                Some(path) => {
                    let s = nominal.surface();
                    let constant = DeviationField::constant(
                        result.baseline_offset_um,
                        s.domain_u(),
                        s.domain_v(),
                    );
                    Some((path.clone(), run_one(&constant, path)?))
                }
                None => None,
            };
            Some(FinishingRun {
                output: output.clone(),
                summary,
                baseline,
            })
        }
        _ => None,
    };

    let surface = write_surface(&a, &nominal, &result, &inputs)?;
    if let Some(path) = &a.report {
        write_report(path, &a, &result, &inputs)?;
    }
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if a.json {
        let text = serde_json::to_string(&summary_json(
            &a,
            &result,
            Some(&surface),
            finishing.as_ref(),
            false,
        ))?;
        writeln!(out, "{text}").map_err(CliError::Stdout)?;
    } else {
        print_summary(&mut out, &a, &result, &surface, finishing.as_ref())
            .map_err(CliError::Stdout)?;
    }
    Ok(())
}

/// The header of a mirror-compensated finishing program: the nominal
/// surface and the probe points it was made from, the set-up and options.
fn mirror_header(
    a: &MirrorArgs,
    machine: &Machine,
    baseline: bool,
) -> Result<ProgramHeader, CliError> {
    let mut files = Vec::new();
    for (label, p) in [("surf", &a.nominal), ("probes", &a.measured)] {
        let bytes = std::fs::read(p).map_err(|e| CliError::Io(p.clone(), e))?;
        files.push((label.to_string(), file_name(p), sha256_hex(&bytes)));
    }
    let fit = match a.fit {
        Fit::LeastSquares => match a.tolerance {
            Some(t) => format!("least-squares fit within {t} um"),
            None => "least-squares fit, net by leave-one-out".to_string(),
        },
        Fit::Interpolate => "interpolating fit".to_string(),
    };
    let split = if a.no_split {
        "no split".to_string()
    } else {
        format!("segment length {} mm", a.segment_length)
    };
    let options = format!(
        "stock {} mm, tool radius {} mm, CL point {}, {fit}, {split}, contact tolerance {} mm",
        a.stock,
        a.tool_radius.unwrap_or(0.0),
        match a.cl_point {
            Cl::Tip => "tip",
            Cl::Center => "center",
        },
        a.contact_tolerance
    );
    Ok(ProgramHeader {
        version: env!("CARGO_PKG_VERSION").to_string(),
        files,
        setup_file: a.machine.setup.as_deref().map(file_name),
        work_offset_note: a
            .machine
            .work_offset
            .as_ref()
            .map(|_| "G54 from --work-offset".to_string()),
        setup: machine.setup.clone(),
        method: if baseline {
            "surface mirror baseline, constant offset".into()
        } else {
            "surface mirror".into()
        },
        options,
        date_utc: date_utc(),
    })
}

fn write_surface(
    a: &MirrorArgs,
    nominal: &NominalSurface,
    result: &MirrorResult,
    inputs: &[&Path],
) -> Result<SurfaceFiles, CliError> {
    let base = a
        .surface_out
        .clone()
        .unwrap_or_else(|| default_base(&a.measured));
    let grid_path = with_suffix(&base, ".csv");
    let toml_path = with_suffix(&base, ".toml");
    let comp = CompensatedSurface {
        nominal,
        field: &result.field,
    };
    let nodes = comp.grid(a.grid_size);
    let ni = nodes.iter().map(|n| n.i + 1).max().unwrap_or(0);
    let nj = nodes.iter().map(|n| n.j + 1).max().unwrap_or(0);
    let mut csv = format!(
        "# volcomp surface mirror: compensated surface S_C = S_F + offset·n (program frame, mm)\n# nominal {}, probe points {}, stock {} mm\ni,j,x_mm,y_mm,z_mm,offset_um\n",
        a.nominal.display(),
        a.measured.display(),
        a.stock
    );
    for n in &nodes {
        use std::fmt::Write as _;
        let _ = writeln!(
            csv,
            "{},{},{:.6},{:.6},{:.6},{:.4}",
            n.i, n.j, n.point_mm.x, n.point_mm.y, n.point_mm.z, n.offset_um
        );
    }
    write_atomically(&grid_path, inputs, |w| {
        w.write_all(csv.as_bytes())
            .map_err(|e| CliError::Io(grid_path.clone(), e))
    })?;
    let (bs, err_mm) = comp.to_bspline(1e-4)?;
    let text = write_bspline_toml(
        &bs,
        &format!(
            "compensated surface from volcomp surface mirror\nnominal {}, probe points {}, stock {} mm\nwithin {:.4} µm of S_F + offset·n",
            a.nominal.display(),
            a.measured.display(),
            a.stock,
            err_mm * 1e3
        ),
    );
    write_atomically(&toml_path, inputs, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| CliError::Io(toml_path.clone(), e))
    })?;
    Ok(SurfaceFiles {
        grid: grid_path.display().to_string(),
        grid_nodes: (ni, nj),
        bspline: toml_path.display().to_string(),
        bspline_net: (bs.count_u(), bs.count_v()),
        bspline_error_um: err_mm * 1e3,
    })
}

#[derive(serde::Serialize)]
struct FinishingJson {
    output: String,
    lines_in: u64,
    lines_out: u64,
    feed_points: u64,
    moved: u64,
    outside_probed_area: u64,
    min_offset_um: f64,
    max_offset_um: f64,
}

impl FinishingJson {
    fn new(path: &Path, s: &FinishingSummary) -> Self {
        Self {
            output: path.display().to_string(),
            lines_in: s.program.lines_in,
            lines_out: s.program.lines_out,
            feed_points: s.feed_points,
            moved: s.in_contact,
            outside_probed_area: s.outside_field,
            min_offset_um: s.min_offset_um,
            max_offset_um: s.max_offset_um,
        }
    }
}

#[derive(serde::Serialize)]
struct SummaryJson<'a> {
    nominal: String,
    measured: String,
    stock_mm: f64,
    probe_radius_mm: Option<f64>,
    points: usize,
    fit: &'a FitInfo,
    /// The measured errors (what an uncompensated finishing pass repeats).
    before: DeviationStats,
    baseline_offset_um: f64,
    baseline: DeviationStats,
    mirror_predicted: Option<DeviationStats>,
    /// The leave-one-out prediction is worse (larger std) than no compensation.
    compensation_predicted_worse: bool,
    mirror_fit: DeviationStats,
    #[serde(skip_serializing_if = "Option::is_none")]
    surface: Option<&'a SurfaceFiles>,
    #[serde(skip_serializing_if = "Option::is_none")]
    finishing: Option<FinishingJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    baseline_program: Option<FinishingJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    probe_points: Option<&'a [MatchedPoint]>,
}

fn summary_json<'a>(
    a: &MirrorArgs,
    r: &'a MirrorResult,
    surface: Option<&'a SurfaceFiles>,
    finishing: Option<&FinishingRun>,
    with_points: bool,
) -> SummaryJson<'a> {
    SummaryJson {
        nominal: a.nominal.display().to_string(),
        measured: a.measured.display().to_string(),
        stock_mm: a.stock,
        probe_radius_mm: a.probe_radius,
        points: r.points.len(),
        fit: &r.fit,
        before: r.before,
        baseline_offset_um: r.baseline_offset_um,
        baseline: r.baseline,
        mirror_predicted: r.mirror_predicted,
        compensation_predicted_worse: r.compensation_predicted_worse(),
        mirror_fit: r.mirror_fit,
        surface,
        finishing: finishing.map(|f| FinishingJson::new(&f.output, &f.summary)),
        baseline_program: finishing
            .and_then(|f| f.baseline.as_ref())
            .map(|(p, s)| FinishingJson::new(p, s)),
        probe_points: with_points.then_some(r.points.as_slice()),
    }
}

fn write_report(
    path: &Path,
    a: &MirrorArgs,
    r: &MirrorResult,
    inputs: &[&Path],
) -> Result<(), CliError> {
    let bytes = if extension(path) == "json" {
        let j = summary_json(a, r, None, None, true);
        let mut text = serde_json::to_string_pretty(&j)?;
        text.push('\n');
        text.into_bytes()
    } else {
        report_csv(a, r).into_bytes()
    };
    write_atomically(path, inputs, |w| {
        w.write_all(&bytes)
            .map_err(|e| CliError::Io(path.to_path_buf(), e))
    })
}

fn stats_line(name: &str, s: &DeviationStats) -> String {
    // No "-0.000" for values that round to zero.
    let z = |x: f64| if x.abs() < 5e-4 { 0.0 } else { x };
    let s = DeviationStats {
        mean_um: z(s.mean_um),
        min_um: z(s.min_um),
        max_um: z(s.max_um),
        ..*s
    };
    format!(
        "{name:<30} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3}",
        s.mean_um, s.std_um, s.min_um, s.max_um, s.profile_um, s.range_um
    )
}

fn stats_table(r: &MirrorResult) -> Vec<String> {
    let mut v = vec![
        format!(
            "{:<30} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "deviations (µm)", "mean", "std", "min", "max", "profile", "range"
        ),
        stats_line("measured (no compensation)", &r.before),
        stats_line("tool-radius baseline", &r.baseline),
    ];
    if let Some(p) = &r.mirror_predicted {
        v.push(stats_line("mirror, predicted (LOO)", p));
    }
    v.push(stats_line("mirror, fit residual", &r.mirror_fit));
    v
}

fn report_csv(a: &MirrorArgs, r: &MirrorResult) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# volcomp surface mirror: nominal {}, probe points {}, stock {} mm, {} points",
        a.nominal.display(),
        a.measured.display(),
        a.stock,
        r.points.len()
    );
    let _ = writeln!(s, "# fit: {}", fit_text(&r.fit));
    let _ = writeln!(
        s,
        "# tool-radius baseline: constant offset {:.4} µm",
        r.baseline_offset_um
    );
    for line in stats_table(r) {
        let _ = writeln!(s, "# {line}");
    }
    let _ = writeln!(s, "# profile = 2·max|d| (zone centred on the nominal, ISO 1101); range = max − min; error > 0: material left");
    let _ = writeln!(s, "row,id,i,j,x_mm,y_mm,z_mm,u,v,nominal_x_mm,nominal_y_mm,nominal_z_mm,nx,ny,nz,error_um,mirror_distance_um,comp_x_mm,comp_y_mm,comp_z_mm,offset_um,fit_residual_um,predicted_um,baseline_um");
    for p in &r.points {
        let (i, j) = p
            .grid
            .map(|(i, j)| (i.to_string(), j.to_string()))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{},{},{:.6},{:.6},{:.6},{:.9},{:.9},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.4},{:.4},{:.6},{:.6},{:.6},{:.4},{:.4},{},{:.4}",
            p.row,
            p.id.as_deref().unwrap_or(""),
            i,
            j,
            p.measured_mm.x,
            p.measured_mm.y,
            p.measured_mm.z,
            p.u,
            p.v,
            p.nominal_mm.x,
            p.nominal_mm.y,
            p.nominal_mm.z,
            p.normal.x,
            p.normal.y,
            p.normal.z,
            p.error_um,
            p.mirror_distance_um,
            p.compensation_mm.x,
            p.compensation_mm.y,
            p.compensation_mm.z,
            p.offset_um,
            p.fit_residual_um,
            p.predicted_um.map(|x| format!("{x:.4}")).unwrap_or_default(),
            p.error_um + r.baseline_offset_um
        );
    }
    s
}

fn fit_text(f: &FitInfo) -> String {
    match f.method.as_str() {
        "least-squares" => format!(
            "least squares, bicubic, {} × {} control points (least leave-one-out error{}); residual max {:.3} µm, RMS {:.3} µm; probe noise σ ≈ {} µm; leave-one-out RMS {} µm",
            f.net.0,
            f.net.1,
            f.tolerance_um
                .map(|t| format!(" among nets within ±{t} µm"))
                .unwrap_or_default(),
            f.max_residual_um,
            f.rms_residual_um,
            f.noise_estimate_um
                .map_or("?".into(), |v| format!("{v:.3}")),
            f.leave_one_out_rms_um
                .map_or("?".into(), |v| format!("{v:.3}")),
        ),
        _ => format!(
            "interpolation, bicubic, {} × {} control points; residual max {:.3} µm",
            f.net.0, f.net.1, f.max_residual_um
        ),
    }
}

fn print_summary(
    out: &mut dyn Write,
    a: &MirrorArgs,
    r: &MirrorResult,
    surface: &SurfaceFiles,
    finishing: Option<&FinishingRun>,
) -> std::io::Result<()> {
    writeln!(
        out,
        "probe points  {} ({}), stock {} mm{}",
        r.points.len(),
        a.measured.display(),
        a.stock,
        a.probe_radius
            .map(|p| format!(", probe radius {p} mm"))
            .unwrap_or_default()
    )?;
    writeln!(out, "fit           {}", fit_text(&r.fit))?;
    writeln!(out)?;
    for line in stats_table(r) {
        writeln!(out, "{line}")?;
    }
    writeln!(
        out,
        "(profile: 2·max|d|, the zone centred on the nominal; range: max − min; error > 0: material left)"
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "baseline      constant offset {:.3} µm (a tool-radius change): removes the mean only",
        r.baseline_offset_um
    )?;
    writeln!(
        out,
        "surface       {} ({} × {} nodes), {} (bicubic {} × {}, within {:.3} µm of S_F + offset·n)",
        surface.grid,
        surface.grid_nodes.0,
        surface.grid_nodes.1,
        surface.bspline,
        surface.bspline_net.0,
        surface.bspline_net.1,
        surface.bspline_error_um
    )?;
    if let Some(f) = finishing {
        let line = |path: &Path, s: &FinishingSummary| {
            format!(
                "{} ({} lines from {}; {} of {} feed points on the surface moved by {:.3} … {:.3} µm{})",
                path.display(),
                s.program.lines_out,
                s.program.lines_in,
                s.in_contact,
                s.feed_points,
                s.min_offset_um,
                s.max_offset_um,
                if s.outside_field > 0 {
                    format!(
                        "; {} outside the probed area took the value at its edge",
                        s.outside_field
                    )
                } else {
                    String::new()
                }
            )
        };
        writeln!(out, "finishing     {}", line(&f.output, &f.summary))?;
        if let Some((p, s)) = &f.baseline {
            writeln!(out, "baseline      {}", line(p, s))?;
        }
    }
    Ok(())
}
