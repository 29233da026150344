//! Mirror compensation of a free-form surface (docs/mirror.md), as plain
//! values: the nominal surface and the probe points, the method's options,
//! and the finishing program with its tool.

use super::machine::{Machine, MachineRequest, MACHINE_OPTIONS};
use super::option::{Input, OptionError, Spelling};
use super::positive;
use crate::compensate::{file_name, refuse_if_compensated, survey_style, HEAD_BYTES};
use crate::io::provenance::{sha256_hex, HeaderWriter, ProgramHeader};
use crate::surface::bspline::Parameterization;
use crate::surface::mirror::report::{
    compensated_surface_text, header_method, header_options, CompensatedSurfaceText, FinishingJson,
    RunInputs, SurfaceFiles,
};
use crate::surface::mirror::{
    compensate_finishing, mirror, program_frame_offset, read_nominal, read_probe_points, BallTool,
    ClPoint, CompensatedSurface, DeviationField, FinishingOptions, FinishingSummary, FitMethod,
    MaterialSide, MirrorError, MirrorOptions, MirrorResult, NominalFormat, NominalSurface,
    SurfaceModel,
};
use crate::Error;
use std::io::{BufRead, Read, Write};

request! {
    /// A mirror compensation, as plain values (each field is the option of the
    /// same name).
    #[allow(missing_docs)]
    pub struct MirrorRequest {
        pub machine: MachineRequest,
    }
    /// The options of [`MirrorRequest`] beside the machine's.
    pub const MIRROR_OPTIONS;
    options [MIRROR_OPTIONS, MACHINE_OPTIONS], unknown "nominal";

    nominal: Option<Input> = None, Input.value("SURF").required(),
        "Nominal finishing surface: a B-spline surface (.toml) or a grid of points (.csv), in the program frame.";

    measured: Option<Input> = None, Input.value("POINTS").required(),
        "Probe points of the semi-finished part (CSV: x_mm,y_mm,z_mm; optional id, i, j).";

    stock_mm: Option<f64> = None, Number.flag("stock").value("D").required(),
        "Stock D the semi-finishing pass leaves on the nominal surface (mm).";

    nominal_format: Option<String> = None, Choice.value("FORMAT").choices(&[
        ("bspline", "A B-spline surface (TOML)"),
        ("grid", "A grid of points (CSV)"),
    ]),
        "The nominal's format when its file name does not say it (a file object in Python).";

    material: String = "below".into(), Choice.value("MATERIAL").default("below").choices(&[
        ("below", "Below the surface (−Z): the tool comes from above"),
        ("above", "Above the surface (+Z)"),
        ("normal-out", "The surface's own normal (Su × Sv) points out of the material"),
        ("normal-in", "The surface's own normal (Su × Sv) points into the material"),
    ]),
        "Which side of the surface the material is on.";

    probe_radius_mm: Option<f64> = None, Number.flag("probe-radius").value("MM"),
        "Probe ball radius (mm) when the points are ball centres; leave out when the probing software already compensated it.";

    max_error_mm: f64 = 0.1, Number.flag("max-error").value("MM").default("0.1"),
        "Largest accepted distance of a probe point from where it should be (nominal + stock), in mm; farther points are refused as mismatched.";

    fit: String = "least-squares".into(), Choice.value("FIT").default("least-squares").choices(&[
        (
            "least-squares",
            "Bicubic least squares, the control net chosen by leave-one-out cross-validation (any probe pattern)",
        ),
        (
            "interpolate",
            "Bicubic interpolation through every point (probe grid with i,j columns)",
        ),
    ]),
        "How the compensation points are fitted.";

    tolerance_um: Option<f64> = None, Number.flag("tolerance").value("UM"),
        "Only consider control nets whose residual at every compensation point is within this (µm). Every residual includes the probe noise: give at least 3× its σ. Without it the net is chosen by leave-one-out cross-validation alone.";

    refuse_worse: bool = false, Switch,
        "Refuse (write nothing) when the leave-one-out prediction of the finishing error after compensation is worse (larger std) than not compensating; without it a warning is given.";

    grid_params: String = "chord-length".into(),
        Choice.value("PARAMS").default("chord-length").choices(&[
            ("chord-length", "Chord length, averaged over the grid rows"),
            ("centripetal", "Centripetal (square root of the chord length), averaged"),
            ("uniform", "Equally spaced"),
        ]),
        "Parameters used to interpolate a grid nominal (CSV).";

    grid_size: u64 = 41, Count.value("N").default("41"),
        "Nodes per direction of the compensated grid when the nominal is a B-spline (a grid nominal keeps its own nodes).";

    finishing: Option<Input> = None, Input.value("PROGRAM"),
        "Ball-end finishing program to compensate.";

    tool_radius_mm: Option<f64> = None, Number.flag("tool-radius").value("MM"),
        "Ball radius of the finishing tool (mm; half its diameter).";

    cl_point: String = "tip".into(), Choice.value("CL").default("tip").choices(&[
        ("tip", "The tool tip (the ball centre is one radius above it, +Z)"),
        ("center", "The ball centre"),
    ]),
        "Which point of the tool the program's coordinates give.";

    contact_tolerance_mm: f64 = 0.02, Number.flag("contact-tolerance").value("MM").default("0.02"),
        "A CL point is on the surface when its ball is this close to it (mm).";

    segment_length_mm: f64 = 2.0, Number.flag("segment-length").value("MM").default("2"),
        "Split feed moves into pieces of at most this length (mm).";

    no_split: bool = false, Switch,
        "Do not split feed moves (arcs are still linearised).";

    decimals: Option<u64> = None, Count.value("DECIMALS"),
        "Decimal places of written coordinates (default 5 in mm, 6 in inch).";

    trace: bool = true, Switch.default("true"),
        "Do not tag inserted lines with `(volcomp Ln)` comments.";

    allow_recompensate: bool = false, Switch,
        "Compensate a finishing program that volcomp compensated already.";
}

/// The checked options of a mirror compensation.
#[derive(Debug, Clone)]
pub struct MirrorPlan {
    /// The method's options.
    pub options: MirrorOptions,
    /// The material side.
    pub side: MaterialSide,
    /// The parameters of a grid nominal.
    pub params: Parameterization,
    /// Nodes per direction of the compensated grid.
    pub grid_size: usize,
    /// The finishing tool, when a finishing program is given.
    pub tool: Option<BallTool>,
    /// How the finishing program is written.
    pub finishing: FinishingOptions,
}

/// A run's outputs held in memory (for a front end that returns them
/// rather than writing files): the compensated surface's files, and the
/// compensated finishing program with its summary when one was given.
pub struct MirrorOutputs {
    /// The compensated surface's grid CSV and B-spline TOML text.
    pub text: CompensatedSurfaceText,
    /// How the summary names those files (`<surface_grid_csv>`, …).
    pub surface: SurfaceFiles,
    /// The compensated finishing program and its summary (named
    /// `<program>`).
    pub finishing: Option<(Vec<u8>, FinishingJson)>,
}

/// The nominal surface, the probe points' result and the inputs as the
/// reports name them.
pub struct MirrorRun {
    /// The nominal surface.
    pub nominal: NominalSurface,
    /// The method's result.
    pub result: MirrorResult,
    /// The run as reports name it.
    pub inputs: RunInputs,
    /// The warning a front end gives when the leave-one-out prediction
    /// says compensating is worse than not (and the run was not refused).
    pub worse: Option<String>,
}

/// The choice of option `name` that `value` names.
fn choice(name: &'static str, value: &str) -> Result<&'static str, OptionError> {
    let info = <MirrorRequest as super::Request>::info(name).expect("a mirror option");
    info.choice(value).map_err(|p| OptionError::new(name, p))
}

impl MirrorRequest {
    fn input<'a>(
        &self,
        v: &'a Option<Input>,
        name: &'static str,
    ) -> Result<&'a Input, OptionError> {
        v.as_ref()
            .ok_or_else(|| OptionError::new(name, "is required"))
    }

    /// Every option checked.
    pub fn plan(&self) -> Result<MirrorPlan, OptionError> {
        let stock = self
            .stock_mm
            .ok_or_else(|| OptionError::new("stock_mm", "is required"))?;
        let stock_mm = positive("stock_mm", stock, "a positive length in mm")?;
        let max_error_mm = positive("max_error_mm", self.max_error_mm, "a positive length in mm")?;
        let tolerance_um = self
            .tolerance_um
            .map(|t| positive("tolerance_um", t, "a positive number of µm"))
            .transpose()?;
        let contact = self.contact_tolerance_mm;
        positive("contact_tolerance_mm", contact, "a positive length in mm")?;
        if let Some(r) = self.probe_radius_mm {
            if !(r.is_finite() && r >= 0.0) {
                return Err(OptionError::new(
                    "probe_radius_mm",
                    format!("must be a length ≥ 0 in mm; got {r}"),
                ));
            }
        }
        let segment_length_mm = match self.no_split {
            true => None,
            false => Some(positive(
                "segment_length_mm",
                self.segment_length_mm,
                "a positive length in mm",
            )?),
        };
        if !(2..=1001).contains(&self.grid_size) {
            return Err(OptionError::new(
                "grid_size",
                format!("must be 2 … 1001; got {}", self.grid_size),
            ));
        }
        let decimals = match self.decimals {
            None => None,
            Some(d @ 1..=9) => Some(d as u8),
            Some(_) => return Err(OptionError::new("decimals", "must be 1 … 9")),
        };
        let side = match choice("material", &self.material)? {
            "above" => MaterialSide::Above,
            "normal-out" => MaterialSide::NormalOut,
            "normal-in" => MaterialSide::NormalIn,
            _ => MaterialSide::Below,
        };
        let params = match choice("grid_params", &self.grid_params)? {
            "centripetal" => Parameterization::Centripetal,
            "uniform" => Parameterization::Uniform,
            _ => Parameterization::ChordLength,
        };
        let fit = match choice("fit", &self.fit)? {
            "interpolate" => FitMethod::Interpolate,
            _ => FitMethod::LeastSquares { tolerance_um },
        };
        let cl = match choice("cl_point", &self.cl_point)? {
            "center" => ClPoint::Centre,
            _ => ClPoint::Tip,
        };
        let tool = match (&self.finishing, self.tool_radius_mm) {
            (Some(_), Some(r)) => Some(BallTool {
                radius_mm: positive("tool_radius_mm", r, "the ball's radius in mm")?,
                cl,
            }),
            (Some(_), None) => {
                return Err(OptionError::new(
                    "finishing",
                    "needs {tool_radius_mm}: the ball's radius in mm",
                ))
            }
            _ => None,
        };
        Ok(MirrorPlan {
            options: MirrorOptions {
                stock_mm,
                probe_radius_mm: self.probe_radius_mm,
                max_error_mm,
                fit,
            },
            side,
            params,
            grid_size: self.grid_size as usize,
            tool,
            finishing: FinishingOptions {
                segment_length_mm,
                decimals,
                trace_comments: self.trace,
                ..FinishingOptions::default()
            },
        })
    }

    /// The nominal surface's format: as given, or by its file's extension.
    fn nominal_format(&self, nominal: &Input) -> Result<NominalFormat, Error> {
        match (self.nominal_format.as_deref(), nominal) {
            (Some(f), _) => Ok(match choice("nominal_format", f)? {
                "grid" => NominalFormat::GridCsv,
                _ => NominalFormat::BSplineToml,
            }),
            (None, Input::File(p)) => Ok(NominalFormat::of_path(p)?),
            (None, Input::Content { name, .. }) => Err(OptionError::new(
                "nominal_format",
                format!("is needed for {name} (not a file whose extension says it): bspline (TOML) or grid (CSV)"),
            )
            .into()),
        }
    }

    /// Reads the inputs and runs the method; refuses (with
    /// [`MirrorRequest::refuse_worse`]) a compensation the leave-one-out
    /// prediction says is worse than none.
    pub fn run(&self, plan: &MirrorPlan) -> Result<MirrorRun, Error> {
        let nominal_in = self.input(&self.nominal, "nominal")?;
        let measured_in = self.input(&self.measured, "measured")?;
        let format = self.nominal_format(nominal_in)?;
        let text = |i: &Input| -> Result<String, Error> {
            String::from_utf8(i.bytes()?.into_owned()).map_err(|_| {
                OptionError::new("nominal", format!("{}: not UTF-8 text", i.name())).into()
            })
        };
        let (nominal_name, measured_name) = (nominal_in.name(), measured_in.name());
        let nominal = read_nominal(
            &text(nominal_in)?,
            &nominal_name,
            format,
            plan.side,
            &plan.params,
        )?;
        let probes = read_probe_points(&text(measured_in)?, &measured_name)?;
        let result = mirror(&nominal, &probes, &plan.options, &measured_name)?;
        let worse = result.compensation_predicted_worse().then(|| {
            let p = result.mirror_predicted.as_ref().map_or(f64::NAN, |p| p.std_um);
            format!(
                "{measured_name}: the leave-one-out prediction of the finishing error after compensation (std {p:.3} µm) is worse than not compensating (std {:.3} µm): the fit ({} × {} control net) does not predict the error between the probe points",
                result.before.std_um, result.fit.net.0, result.fit.net.1
            )
        });
        if let (true, Some(w)) = (self.refuse_worse, &worse) {
            return Err(MirrorError::Method {
                message: w.clone(),
                help: "probe more densely or check the probe points (an outlier?); nothing was written".into(),
            }
            .into());
        }
        let inputs = RunInputs {
            nominal: nominal_name,
            measured: measured_name,
            stock_mm: plan.options.stock_mm,
            probe_radius_mm: plan.options.probe_radius_mm,
        };
        Ok(MirrorRun {
            nominal,
            result,
            inputs,
            worse: worse.map(|w| {
                format!("{w}; check the probe points, or refuse such a run ({{refuse_worse}})")
            }),
        })
    }

    /// The header of a finishing program compensated with this run (or,
    /// `baseline`, with the tool-radius baseline), dated `date_utc`;
    /// `spelling` names the work-offset option as the front end does.
    pub fn finishing_header(
        &self,
        plan: &MirrorPlan,
        tool: &BallTool,
        machine: &Machine,
        baseline: bool,
        date_utc: String,
        spelling: &dyn Spelling,
    ) -> Result<ProgramHeader, Error> {
        let mut files = Vec::new();
        for (label, input, default) in [
            ("surf", &self.nominal, "nominal"),
            ("probes", &self.measured, "probes"),
        ] {
            let Some(input) = input else { continue };
            let name = input
                .path()
                .map(file_name)
                .unwrap_or_else(|| default.into());
            files.push((label.to_string(), name, sha256_hex(&input.bytes()?)));
        }
        Ok(ProgramHeader {
            version: env!("CARGO_PKG_VERSION").to_string(),
            files,
            setup_file: machine.setup_file.as_deref().map(file_name),
            work_offset_note: machine
                .work_offset_given
                .then(|| format!("G54 from {}", spelling.option("work_offset_mm"))),
            setup: machine.setup.setup.clone(),
            method: header_method(baseline).into(),
            options: header_options(
                plan.options.stock_mm,
                tool,
                &plan.options.fit,
                plan.finishing.segment_length_mm,
                self.contact_tolerance_mm,
            ),
            date_utc,
        })
    }

    /// The finishing program's frame: its first cutting position's work
    /// offset, read from `program` (a first pass over it).
    pub fn finishing_frame(
        &self,
        machine: &Machine,
        program: impl BufRead,
        file: &str,
    ) -> Result<volcomp_gcode::Vec3, Error> {
        Ok(program_frame_offset(
            &mut machine.setup.walker(program, file),
            file,
        )?)
    }

    /// Writes the finishing program read from `program` (named `file`)
    /// compensated for `field` (the run's deviation field, or the
    /// baseline's constant one) to `out` with `header` on top; refuses a
    /// program volcomp compensated already unless allowed.
    #[allow(clippy::too_many_arguments)]
    pub fn compensate_finishing(
        &self,
        plan: &MirrorPlan,
        run: &MirrorRun,
        field: &DeviationField,
        machine: &Machine,
        frame: volcomp_gcode::Vec3,
        (mut program, file): (impl Read, &str),
        header: &ProgramHeader,
        out: &mut dyn Write,
    ) -> Result<FinishingSummary, Error> {
        let tool = plan
            .tool
            .ok_or_else(|| OptionError::new("tool_radius_mm", "is required"))?;
        let model = SurfaceModel::new(&run.nominal, field, tool, frame, self.contact_tolerance_mm)?;
        let mut head = Vec::with_capacity(HEAD_BYTES as usize);
        (&mut program)
            .take(HEAD_BYTES)
            .read_to_end(&mut head)
            .map_err(|e| Error::io(file, e))?;
        if !self.allow_recompensate {
            refuse_if_compensated(&head, file)?;
        }
        let style = survey_style(&head);
        let reader = std::io::BufReader::with_capacity(
            HEAD_BYTES as usize,
            std::io::Cursor::new(head).chain(program),
        );
        let mut walker = machine.setup.walker(reader, file);
        let mut w = HeaderWriter::new(out, header.lines());
        let summary =
            compensate_finishing(&mut walker, file, &style, &model, &plan.finishing, &mut w)?;
        w.finish()
            .map_err(|e| MirrorError::Program(crate::error::CompensationError::Io(e)))?;
        Ok(summary)
    }

    /// The run's outputs in memory ([`MirrorOutputs`]): the finishing
    /// program (when given, with the tool) compensated and dated
    /// `date_utc`, `spelling` naming options as the front end does.
    pub fn outputs(
        &self,
        plan: &MirrorPlan,
        run: &MirrorRun,
        date_utc: impl FnOnce() -> String,
        spelling: &dyn Spelling,
    ) -> Result<MirrorOutputs, Error> {
        let comp = CompensatedSurface {
            nominal: &run.nominal,
            field: &run.result.field,
        };
        let text = compensated_surface_text(&run.inputs, &comp, plan.grid_size)?;
        let surface = SurfaceFiles {
            grid: "<surface_grid_csv>".into(),
            grid_nodes: text.grid_nodes,
            bspline: "<surface_bspline_toml>".into(),
            bspline_net: text.bspline_net,
            bspline_error_um: text.bspline_error_um,
        };
        let finishing = match (&self.finishing, &plan.tool) {
            (Some(f), Some(tool)) => {
                let machine = self.machine.machine()?;
                let (file, bytes) = (f.name(), f.bytes()?);
                let frame = self.finishing_frame(&machine, bytes.as_ref(), &file)?;
                let header =
                    self.finishing_header(plan, tool, &machine, false, date_utc(), spelling)?;
                let mut out = Vec::new();
                let field = &run.result.field;
                let program = (bytes.as_ref(), file.as_str());
                let summary = self.compensate_finishing(
                    plan, run, field, &machine, frame, program, &header, &mut out,
                )?;
                Some((out, FinishingJson::new("<program>", &summary)))
            }
            _ => None,
        };
        Ok(MirrorOutputs {
            text,
            surface,
            finishing,
        })
    }
}
