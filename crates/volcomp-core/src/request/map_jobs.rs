//! The map jobs besides the export: convert a map, import LinuxCNC comp
//! files or an ISO 230-1 parameter file, build a model from measurement
//! runs, evaluate an ISO 230-2 test, a map's chart report. Each goes from
//! plain values to a [`JobOutput`] (the files to write and what to say),
//! so that a front end only reads its arguments, writes and prints.

use super::export::{positioning_tables, CompRequest, MapToolRequest, MapView};
use crate::identify::{build, iso230_2};
use crate::io::controllers::{table_error, ControllerCorrection, Format};
use crate::io::exchange;
use crate::io::grid::{self, GridError};
use crate::io::linuxcnc_comp;
use crate::io::model_file;
use crate::model::axis_table::AxisTableMap;
use crate::model::kinematic::KinematicModel;
use crate::model::topology::Topology;
use crate::model::Directions;
use crate::report::{Document, InputFile};
use crate::Error;
use std::path::{Path, PathBuf};
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// A file a job writes: where, and its text.
#[derive(Debug, Clone, PartialEq)]
pub struct JobFile {
    /// Where it goes.
    pub path: PathBuf,
    /// What it holds.
    pub text: String,
}

/// What a job gives its front end: lines for standard output, warnings
/// (always shown), folders to create, the files to write in order, and
/// notes for a person (left out when asked to be quiet), said after the
/// files are written. Messages name options as `{name}`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JobOutput {
    /// Lines for standard output.
    pub stdout: Vec<String>,
    /// Warnings, said before anything is written.
    pub warnings: Vec<String>,
    /// Folders to create before writing.
    pub dirs: Vec<PathBuf>,
    /// The files, in the order they are written.
    pub files: Vec<JobFile>,
    /// Notes, said once the files are written.
    pub notes: Vec<String>,
}

impl JobOutput {
    fn file(&mut self, path: impl Into<PathBuf>, text: String) {
        self.files.push(JobFile {
            path: path.into(),
            text,
        });
    }

    /// `model` as `out` (TOML) with its tables beside it (same stem, .csv).
    fn model(
        &mut self,
        model: &KinematicModel,
        out: &Path,
        description: Option<&str>,
    ) -> Result<(), Error> {
        let files = model_file::model_files(model, out, description)?;
        self.notes.push(format!(
            "volcomp: wrote {} and {}",
            out.display(),
            files.csv_path.display()
        ));
        self.file(files.csv_path, files.csv);
        self.file(out, files.toml);
        Ok(())
    }

    /// The parent folder of `out`, when it names one, to create.
    fn parent_of(&mut self, out: &Path) {
        if let Some(d) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
            self.dirs.push(d.to_path_buf());
        }
    }
}

/// The facts every report of a run starts with: the command, volcomp's
/// version, the date (UTC; `SOURCE_DATE_EPOCH` when set).
pub fn run_facts(command: &str) -> Vec<(String, String)> {
    vec![
        ("command".into(), command.to_string()),
        ("volcomp".into(), env!("CARGO_PKG_VERSION").into()),
        ("date (UTC)".into(), crate::io::provenance::now_utc()),
    ]
}

/// What `map convert` writes.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ConvertTo {
    /// Axis-table CSV for one tool, exact on the lines through the reference.
    AxisTable,
    /// A 3-D grid CSV.
    Grid,
    /// LinuxCNC comp files x.comp, y.comp, z.comp in a folder.
    Linuxcnc,
    /// A 21-component model (TOML + CSV beside it).
    Model,
}

/// Converting a map into another form (`map convert`).
#[derive(Debug, Clone)]
pub struct MapConvert<'a> {
    /// What to write.
    pub to: ConvertTo,
    /// The file written (a folder for LinuxCNC comp files).
    pub output: &'a Path,
    /// The reference position (mm) of axis tables and comp files.
    pub at: Option<Vec3>,
    /// The tool and the model's form.
    pub tool: &'a MapToolRequest,
    /// Grid spacing, or the comp files' resampling (mm).
    pub step_mm: Option<f64>,
    /// The direction state of the grid.
    pub directions: Directions,
    /// The comp files' type and units.
    pub comp: &'a CompRequest,
    /// The largest deviation of comp files from the map (µm).
    pub max_table_error_um: f64,
    /// The chain of a model made from axis tables.
    pub chain: Topology,
}

fn positive_step(step: Option<f64>) -> Result<Option<f64>, Error> {
    match step {
        Some(s) if !(s.is_finite() && s > 0.0) => Err(Error::Request(format!(
            "{{step_mm}} must be a positive length in mm; got {s}"
        ))),
        other => Ok(other),
    }
}

impl MapConvert<'_> {
    /// The files the conversion writes (to check them before any work):
    /// `(what, path)`.
    pub fn outputs(&self) -> Vec<(String, PathBuf)> {
        match self.to {
            ConvertTo::Linuxcnc => AXES
                .iter()
                .map(|a| {
                    let name = format!("{}.comp", a.to_ascii_lowercase());
                    (format!("(its {name})"), self.output.join(&name))
                })
                .collect(),
            ConvertTo::Model => model_outputs(self.output),
            _ => vec![(String::new(), self.output.to_path_buf())],
        }
    }

    /// Converts `map` (named `map_name`).
    pub fn run(&self, map: MapView<'_>, map_name: &str) -> Result<JobOutput, Error> {
        let mut out = JobOutput::default();
        let form = self.tool.form()?;
        match self.to {
            ConvertTo::AxisTable => self.axis_tables(map, map_name, form, &mut out)?,
            ConvertTo::Grid => {
                let step = positive_step(self.step_mm)?.unwrap_or(25.0);
                let tool = self.tool.offset()?.unwrap_or(Vec3::ZERO);
                let (text, count) =
                    grid::grid_csv(map.model(), map_name, tool, self.directions, step).map_err(
                        |e| match e {
                            GridError::TooManyPoints { step_mm, points } => Error::Request(format!(
                                "a {step_mm} mm grid over this range has {points} points; choose a larger {{step_mm}}"
                            )),
                            GridError::Model(m) => Error::Request(m.to_string()),
                        },
                    )?;
                out.notes.push(format!(
                    "volcomp: wrote {} ({count} points)",
                    self.output.display()
                ));
                out.file(self.output, text);
            }
            ConvertTo::Linuxcnc => self.linuxcnc(map, form, &mut out)?,
            ConvertTo::Model => {
                let model = match map {
                    MapView::Tables(t) => KinematicModel::from_axis_tables(t, self.chain),
                    MapView::Kinematic(m) => m.clone(),
                };
                out.model(&model, self.output, None)?;
            }
        }
        Ok(out)
    }

    fn axis_tables(
        &self,
        map: MapView<'_>,
        map_name: &str,
        form: crate::model::kinematic::Form,
        out: &mut JobOutput,
    ) -> Result<(), Error> {
        let MapView::Kinematic(m) = map else {
            return Err(Error::Request(format!(
                "{map_name} already is an axis-table map"
            )));
        };
        let mut m = m.clone();
        m.form = form;
        let Some(tool) = self.tool.offset()? else {
            return Err(Error::Request("axis tables hold the deviation for one tool: pass {tool_length_mm} MM (or {tool_offset_mm} X,Y,Z), e.g. the length of the tool the program uses".into()));
        };
        let Some(reference) = self.at.or(m.shared_measuring().0) else {
            return Err(Error::Request("the model's axes were measured along different lines: pass {at} X,Y,Z, the position whose three lines the axis tables should reproduce (e.g. the middle of the part)".into()));
        };
        let tables = m.to_axis_tables(reference, tool, form)?;
        let worst = m.largest_difference_um(tool, &tables)?;
        out.notes.push(format!(
            "volcomp: wrote {} for tool length offset ({}, {}, {}) mm, exact on the lines through ({}, {}, {}) mm; elsewhere it differs from the model by up to {worst:.3} µm (the Abbe cross terms an axis-table map cannot hold)",
            self.output.display(), tool.x, tool.y, tool.z, reference.x, reference.y, reference.z
        ));
        out.file(self.output, tables.to_csv());
        Ok(())
    }

    fn linuxcnc(
        &self,
        map: MapView<'_>,
        form: crate::model::kinematic::Form,
        out: &mut JobOutput,
    ) -> Result<(), Error> {
        let (ty, units) = self.comp.get()?;
        let (at, tool) = match map {
            MapView::Tables(_) => (None, None),
            MapView::Kinematic(_) => (self.at, self.tool.offset()?),
        };
        let original = positioning_tables(map, at, tool, form)?;
        let step = positive_step(self.step_mm)?;
        let tables = match step {
            Some(step) => original.clone().map(|p| p.resample(step)),
            None => original.clone(),
        };
        let mut applied = ControllerCorrection::empty(Format::Linuxcnc);
        for (k, p) in tables.iter().enumerate() {
            let text = linuxcnc_comp::write(p, ty, units).map_err(|m| {
                Error::Request(format!(
                    "axis {}: {m}; pass {{step_mm}} MM to resample the table (linear interpolation) at a spacing LinuxCNC can hold",
                    AXES[k]
                ))
            })?;
            applied.axes[k] = Some(
                linuxcnc_comp::parse(&text, "comp", ty, units)
                    .map_err(|e| Error::Request(e.to_string()))?,
            );
            let name = format!("{}.comp", AXES[k].to_ascii_lowercase());
            out.file(self.output.join(name), text);
        }
        // How far the written tables lie from the map, checked before writing.
        let max_um = self.max_table_error_um;
        if !(max_um.is_finite() && max_um > 0.0) {
            return Err(Error::Request(format!(
                "{{max_table_error_um}} must be positive; got {max_um}"
            )));
        }
        let err = table_error::table_error(
            &original.map(Some),
            &applied,
            [table_error::Holds::BothDirections; 3],
            None,
        );
        table_error::check("linuxcnc", &err, 0.0, step, max_um)?;
        out.dirs.push(self.output.to_path_buf());
        out.notes.push(format!(
            "volcomp: the comp files lie at most {} µm from the map's positioning errors (checked at every point of both tables); {{max_table_error_um}} allows {}",
            table_error::um(err.max_um),
            table_error::um(max_um)
        ));
        out.stdout.push("# LinuxCNC INI lines (joints 0, 1, 2 = X, Y, Z with trivkins); remove BACKLASH, the comp files hold the reversal".into());
        for (k, f) in out.files.iter().enumerate() {
            out.stdout.push(format!(
                "[JOINT_{k}]\nCOMP_FILE = {}\nCOMP_FILE_TYPE = {}",
                f.path.display(),
                ty.number()
            ));
        }
        Ok(())
    }
}

/// The files a model written as `out` (.toml) consists of: it and its
/// tables beside it (same stem, .csv), as `(what, path)`.
pub fn model_outputs(out: &Path) -> Vec<(String, PathBuf)> {
    let mut files = vec![(String::new(), out.to_path_buf())];
    let is_toml = out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_toml {
        files.push(("(its tables beside it)".into(), out.with_extension("csv")));
    }
    files
}

/// LinuxCNC comp files of the X, Y and Z joints read into axis tables (an
/// `.csv` `out`) or a 21-component model (`.toml`) of the chain `chain`.
pub fn import_linuxcnc(
    files: [&Path; 3],
    comp: &CompRequest,
    out: &Path,
    chain: Topology,
) -> Result<JobOutput, Error> {
    let (ty, units) = comp.get()?;
    let read =
        |f: &Path| linuxcnc_comp::read(f, ty, units).map_err(|e| Error::Request(e.to_string()));
    let p = [read(files[0])?, read(files[1])?, read(files[2])?];
    let tables = AxisTableMap::from_positioning(&p);
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut job = JobOutput::default();
    match ext.as_deref() {
        Some("csv") => {
            job.file(out, linuxcnc_comp::imported_tables_csv(&tables, ty, units));
            job.notes.push(format!("volcomp: wrote {}", out.display()));
        }
        Some("toml") => job.model(
            &KinematicModel::from_axis_tables(&tables, chain),
            out,
            Some("imported from LinuxCNC comp files: positioning errors only"),
        )?,
        _ => {
            return Err(Error::Request(format!(
                "{}: write an axis-table .csv or a 21-component .toml",
                out.display()
            )))
        }
    }
    Ok(job)
}

/// The formats of ISO 230-1 parameter files.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ParamsFormat {
    /// ISG CSV (the ISG kernel's volumetric compensation).
    IsgCsv,
    /// Etalon exchange format, "Vendor" variant.
    Etalon,
}

/// An ISO 230-1 parameter file (`text`, read from `file`) as a 21-component
/// model of the chain `chain`, written as `out`.
pub fn import_params(
    text: &str,
    file: &Path,
    from: ParamsFormat,
    out: &Path,
    chain: Topology,
) -> Result<JobOutput, Error> {
    let name = file.display().to_string();
    let params = match from {
        ParamsFormat::IsgCsv => exchange::parse_isg_csv(text, &name)?,
        ParamsFormat::Etalon => exchange::parse_etalon(text, &name)?,
    };
    let imported = exchange::to_model(&params, &name, text, chain)?;
    let mut job = JobOutput::default();
    job.parent_of(out);
    if !imported.assumed_zero.is_empty() {
        job.warnings.push(format!(
            "volcomp: not in the file, taken as zero: {}",
            imported.assumed_zero.join(", ")
        ));
    }
    if !imported.not_used.is_empty() {
        job.warnings.push(format!(
            "volcomp: not used (rotary axes or zero): {}",
            imported.not_used.join(", ")
        ));
    }
    let format = match from {
        ParamsFormat::IsgCsv => "ISG CSV",
        ParamsFormat::Etalon => "Etalon exchange format",
    };
    job.model(
        &imported.model,
        out,
        Some(&format!("imported from {name} ({format})")),
    )?;
    Ok(job)
}

/// Reads a text input of a map job (bounded, UTF-8).
pub fn read_text(path: &Path, what: &str) -> Result<String, Error> {
    let bytes = crate::io::inputs::read(path, what).map_err(|e| Error::io(path, e))?;
    Ok(crate::io::table::utf8(&bytes, &path.display().to_string())?.to_string())
}

/// A model built from measurement runs: the plan (`plan_text`, read from
/// `plan`) names the run files beside it.
#[derive(Debug, Clone)]
pub struct MapBuild {
    plan: build::Plan,
    plan_name: String,
    runs: Vec<(String, PathBuf)>,
}

impl MapBuild {
    /// Reads the plan.
    pub fn new(plan_text: &str, plan: &Path) -> Result<Self, Error> {
        let plan_name = plan.display().to_string();
        let (parsed, runs) = build::parse_plan(plan_text, &plan_name)?;
        let dir = plan.parent().unwrap_or(Path::new(""));
        Ok(Self {
            plan: parsed,
            plan_name,
            runs: runs.into_iter().map(|(c, f)| (c, dir.join(f))).collect(),
        })
    }

    /// The run files, as `(component, path)`.
    pub fn runs(&self) -> &[(String, PathBuf)] {
        &self.runs
    }

    /// Reads the runs and builds the model, written as `out`.
    pub fn run(&self, out: &Path) -> Result<JobOutput, Error> {
        let mut read_runs = Vec::new();
        for (c, p) in &self.runs {
            let text = read_text(p, "an input")?;
            read_runs.push(build::read_run(c, &text, &p.display().to_string())?);
        }
        let (model, summary) = build::build(&self.plan, &read_runs, &self.plan_name)?;
        let mut job = JobOutput {
            stdout: summary.lines(),
            ..JobOutput::default()
        };
        job.parent_of(out);
        let description = format!("built from the runs of {}", self.plan_name);
        job.model(&model, out, Some(&description))?;
        Ok(job)
    }
}

/// An ISO 230-2 bidirectional positioning test (`map iso230-2`).
#[derive(Debug, Clone)]
pub struct Iso230_2Job<'a> {
    /// The runs file.
    pub runs: &'a Path,
    /// The axis tested (for `output`).
    pub axis: Option<Axis>,
    /// The positioning table to write (.csv rows or .comp).
    pub output: Option<&'a Path>,
    /// The comp file's type and units.
    pub comp: &'a CompRequest,
    /// The HTML report to write.
    pub report_html: Option<&'a Path>,
    /// The command line, for the report.
    pub command: &'a str,
}

impl Iso230_2Job<'_> {
    /// Evaluates the test (`text`, read from `runs`): its report, and the
    /// text lines and files.
    pub fn run(&self, text: &str) -> Result<(iso230_2::Iso230_2Report, JobOutput), Error> {
        let r = iso230_2::from_csv(text, &self.runs.display().to_string())?;
        let mut job = JobOutput {
            stdout: iso230_2_lines(&self.runs.display().to_string(), &r),
            ..JobOutput::default()
        };
        if let Some(path) = self.report_html {
            let axis = self.axis.map_or("not given (--axis)".to_string(), |x| {
                AXES[x.index()].to_string()
            });
            let mut facts = run_facts(self.command);
            facts.push(("axis".into(), axis));
            facts.push((
                "evaluation".into(),
                "ISO 230-2:2014, clause 3 (bidirectional)".into(),
            ));
            let doc = Document {
                title: format!("volcomp positioning test report: {}", self.runs.display()),
                facts,
                inputs: vec![InputFile::from_bytes(
                    "runs",
                    self.runs.display().to_string(),
                    text.as_bytes(),
                )],
                sections: crate::report::iso230_2::sections(&r),
                ..Default::default()
            };
            job.file(path, doc.to_html());
            job.notes.push(format!("volcomp: wrote {}", path.display()));
        }
        if let (Some(path), Some(axis)) = (self.output, self.axis) {
            job.file(path, self.table(&r, path, axis)?);
            job.notes.push(format!("volcomp: wrote {}", path.display()));
        }
        Ok((r, job))
    }

    fn table(
        &self,
        r: &iso230_2::Iso230_2Report,
        path: &Path,
        axis: Axis,
    ) -> Result<String, Error> {
        let k = axis.index();
        let p = r.positioning();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("comp") => {
                let (ty, units) = self.comp.get()?;
                linuxcnc_comp::write(&p, ty, units).map_err(|e| Error::Request(e.to_string()))
            }
            Some("csv") => Ok(model_file::positioning_rows_csv(
                &p,
                Axis::ALL[k],
                &format!(
                    "ISO 230-2 mean unidirectional deviations of {} from {}: positioning only",
                    AXES[k],
                    self.runs.display()
                ),
            )),
            _ => Err(Error::Request(format!("{}: write the positioning table as .csv (21-component table rows) or .comp (LinuxCNC)", path.display()))),
        }
    }
}

/// The HTML report of a map's components over their axes (`map plot`), for
/// the map read from `map_path`; with the number of charts.
pub fn map_plot_report(
    map: MapView<'_>,
    map_path: &Path,
    command: &str,
) -> Result<(String, usize), Error> {
    let name = map_file_name(map_path);
    let charts = map_charts(map, &name);
    let mut inputs = vec![InputFile::read("map", map_path)?];
    if let MapView::Tables(_) = map {
        inputs[0].role = "map (axis tables)".into();
    }
    let doc = Document {
        title: format!("volcomp error map report: {name}"),
        facts: run_facts(command),
        inputs,
        sections: crate::report::map::sections(&charts),
        ..Default::default()
    };
    Ok((doc.to_html(), charts.len()))
}

/// A map file's name as its charts say it.
pub fn map_file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// Every component of a map over its axis, one chart each.
pub fn map_charts(map: MapView<'_>, name: &str) -> Vec<crate::report::map::ComponentChart> {
    use crate::report::map::component_charts;
    match map {
        MapView::Tables(m) => component_charts::tables(name, m),
        MapView::Kinematic(m) => component_charts::kinematic(name, m),
    }
}

/// The ISO 230-2 evaluation as text: per target, then the axis' figures.
pub fn iso230_2_lines(runs: &str, r: &iso230_2::Iso230_2Report) -> Vec<String> {
    let mut w = vec![
        format!(
            "{runs}: ISO 230-2 evaluation, {} target positions (µm)",
            r.targets.len()
        ),
        "  target_mm     n↑  n↓     x̄↑       x̄↓       s↑      s↓      B_i      x̄_i     R↑_i    R↓_i    R_i".into(),
    ];
    for t in &r.targets {
        w.push(format!(
            "  {:>10.3}  {:>3} {:>3}  {:>+8.3} {:>+8.3} {:>7.3} {:>7.3} {:>+8.3} {:>+8.3} {:>7.3} {:>7.3} {:>7.3}",
            t.target_mm, t.n_up, t.n_down, t.mean_up_um, t.mean_down_um, t.s_up_um, t.s_down_um,
            t.reversal_um, t.mean_um, t.repeatability_up_um, t.repeatability_down_um, t.repeatability_um
        ));
    }
    let f = r.axis;
    w.push(format!(
        "reversal value               B  = {:.3} µm   (mean reversal value B̄ = {:+.3} µm)",
        f.reversal_b_um, f.mean_reversal_um
    ));
    w.push(format!(
        "repeatability                R↑ = {:.3} µm   R↓ = {:.3} µm   R = {:.3} µm",
        f.repeatability_up_um, f.repeatability_down_um, f.repeatability_um
    ));
    w.push(format!(
        "systematic deviation         E↑ = {:.3} µm   E↓ = {:.3} µm   E = {:.3} µm",
        f.systematic_up_um, f.systematic_down_um, f.systematic_um
    ));
    w.push(format!(
        "mean bidirectional range     M  = {:.3} µm",
        f.mean_range_um
    ));
    w.push(format!(
        "accuracy                     A↑ = {:.3} µm   A↓ = {:.3} µm   A = {:.3} µm",
        f.accuracy_up_um, f.accuracy_down_um, f.accuracy_um
    ));
    w.extend(r.notes.iter().map(|n| format!("note: {n}")));
    w
}
