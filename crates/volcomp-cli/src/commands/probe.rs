//! `volcomp probe`: calibrating a machine with a touch probe and the
//! artifacts a shop has (docs/probing.md). `plan` writes the LinuxCNC
//! probing program of an artifact, `fit` identifies the machine from the
//! logs and writes the 21-component model, `verify` identifies what a
//! compensated run leaves, `example` writes a synthetic campaign. Flags are
//! turned into the library's requests; the library does the work.

use crate::options::Options;
use crate::output::{check, write_file, CliError, OutputPlan, Staged};
use clap::{Args, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use volcomp_core::identify::probe::request::{FitRequest, Input, PlanRequest};
use volcomp_core::identify::probe::verify::{Applied, VerifyRequest};
use volcomp_core::request::{probe, ProbeFitRequest, ProbeIdentifyRequest, ProbePlanRequest};
use volcomp_core::MachineSetup;

/// Calibrate with a touch probe: probing programs, fit, verification.
#[derive(Args, Debug)]
pub struct ProbeArgs {
    #[command(subcommand)]
    pub command: ProbeCommand,
}

#[derive(Subcommand, Debug)]
pub enum ProbeCommand {
    /// Write the LinuxCNC program that probes an artifact in its placements.
    Plan(PlanArgs),
    /// Identify the machine from probing logs and write its model (TOML + CSV).
    Fit(FitArgs),
    /// Identify what a run after compensation leaves.
    Verify(VerifyArgs),
    /// Write a synthetic probing campaign (artifacts, set-up, logs).
    Example(ExampleArgs),
}

#[derive(Args, Debug)]
pub struct PlanArgs {
    /// The artifact description (TOML, docs/probing.md).
    pub artifact: PathBuf,
    /// The machine's set-up: work offsets and tool table (docs/gcode.md).
    #[arg(long, value_name = "TOML")]
    pub setup: Option<PathBuf>,
    #[command(flatten)]
    pub job: Options<ProbePlanRequest>,
    /// Output program.
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct IdentifyArgs {
    /// An artifact description (TOML); one per artifact the logs touched.
    #[arg(long = "artifact", value_name = "TOML", required = true)]
    pub artifacts: Vec<PathBuf>,
    /// A probing log written by the program, or a CSV of points.
    #[arg(long = "log", value_name = "FILE", required = true)]
    pub logs: Vec<PathBuf>,
}

#[derive(Args, Debug)]
pub struct FitArgs {
    #[command(flatten)]
    pub id: IdentifyArgs,
    #[command(flatten)]
    pub job: Options<ProbeFitRequest>,
    /// Also write the HTML report.
    #[arg(long, value_name = "HTML")]
    pub report: Option<PathBuf>,
    /// Output model (TOML); its tables go beside it as <stem>.csv.
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum AppliedArg {
    /// The machine ran compensated (controller tables or a compensated program).
    Machine,
    /// The run was uncompensated: apply the model to the touches here.
    Software,
}

#[derive(Args, Debug)]
pub struct VerifyArgs {
    #[command(flatten)]
    pub id: IdentifyArgs,
    #[command(flatten)]
    pub job: Options<ProbeIdentifyRequest>,
    /// The model to check.
    #[arg(long, value_name = "MODEL")]
    pub map: PathBuf,
    /// How the run was compensated.
    #[arg(long, value_enum, default_value = "machine")]
    pub applied: AppliedArg,
}

#[derive(Args, Debug)]
pub struct ExampleArgs {
    /// Directory to write into (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn run(a: ProbeArgs) -> Result<(), CliError> {
    match a.command {
        ProbeCommand::Plan(a) => plan_cmd(a),
        ProbeCommand::Fit(a) => fit_cmd(a),
        ProbeCommand::Verify(a) => verify_cmd(a),
        ProbeCommand::Example(a) => example_cmd(a),
    }
}

/// Reads an input whole, recorded as `role` for the output plan (bounded).
fn input(path: &Path, role: &str) -> Result<Input, CliError> {
    let text = volcomp_core::io::inputs::read_to_string(path, role)
        .map_err(|e| CliError::Io(path.to_path_buf(), e))?;
    Ok(Input::new(path.display().to_string(), text))
}

fn plan_cmd(a: PlanArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.input("artifact", &a.artifact)
        .input_opt("--setup", a.setup.as_ref())
        .output("-o", &a.output);
    check(&plan)?;
    let setup = match &a.setup {
        Some(p) => MachineSetup::from_setup_file(p)?,
        None => {
            eprintln!("volcomp: warning: no --setup: the program runs in G54 = 0 (machine coordinates) without a tool length offset unless --probe-tool is given with a set-up");
            MachineSetup::unset()
        }
    };
    let options = a.job.options()?;
    let (fast, slow) = (options.fast_feed_mm_min, options.slow_feed_mm_min);
    let request = PlanRequest {
        artifact: input(&a.artifact, "ARTIFACT")?,
        setup,
        placement: a.job.placement.clone(),
        options,
        title: probe::plan_title(&a.artifact.display().to_string()),
    };
    let out = request.run()?;
    write_file(&a.output, &[&a.artifact], out.program.as_bytes())?;
    for line in probe::plan_lines(&out, &a.job, (fast, slow), &a.output) {
        println!("{line}");
    }
    Ok(())
}

fn inputs(paths: &[PathBuf], role: &str) -> Result<Vec<Input>, CliError> {
    paths.iter().map(|p| input(p, role)).collect()
}

fn fit_cmd(a: FitArgs) -> Result<(), CliError> {
    let (csv_name, csv_path) = super::tables_beside(&a.output);
    let mut plan = OutputPlan::new();
    for p in &a.id.artifacts {
        plan.input("--artifact", p);
    }
    for p in &a.id.logs {
        plan.input("--log", p);
    }
    plan.output("-o", &a.output)
        .output("-o (its tables beside it)", &csv_path)
        .output_opt("--report", a.report.as_ref());
    check(&plan)?;
    let options = a.job.identify.options()?;
    let ranges = options.ranges_mm;
    let (order, chain) = (options.order, options.chain.clone());
    let request = FitRequest {
        artifacts: inputs(&a.id.artifacts, "ARTIFACT")?,
        logs: inputs(&a.id.logs, "LOG")?,
        options,
        leave_one_out: a.job.leave_one_out,
        monte_carlo: a.job.monte_carlo as usize,
    };
    let out = request.run()?;
    let (toml, csv) = out.model_files(
        &csv_name,
        &format!(
            "volcomp probe fit of {}",
            a.id.logs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        ranges,
    );
    let mut staged = Staged::new();
    staged.write_bytes(&csv_path, csv.as_bytes())?;
    staged.write_bytes(&a.output, toml.as_bytes())?;
    if let Some(path) = &a.report {
        let html = fit_report(&a, &out, ranges, (order, &chain))?;
        staged.write_bytes(path, html.as_bytes())?;
    }
    staged.commit()?;
    for w in &out.fitted.warnings {
        eprintln!("volcomp: warning: {w}");
    }
    for line in out.summary(ranges) {
        println!("{line}");
    }
    println!(
        "wrote {} and {}; use it with `volcomp compensate --map {}`",
        a.output.display(),
        csv_path.display(),
        a.output.display()
    );
    Ok(())
}

/// The fit's HTML report, with its inputs.
fn fit_report(
    a: &FitArgs,
    out: &volcomp_core::identify::probe::request::FitOutput,
    ranges: [[f64; 2]; 3],
    chain: (usize, &str),
) -> Result<String, CliError> {
    let mut inputs = Vec::new();
    for (role, list) in [("artifact", &a.id.artifacts), ("log", &a.id.logs)] {
        for p in list {
            inputs.push(volcomp_core::report::InputFile::read(role, p)?);
        }
    }
    let command = super::command_line();
    Ok(probe::fit_report_html(
        out, ranges, chain, &a.output, &command, inputs,
    ))
}

fn verify_cmd(a: VerifyArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for p in a.id.artifacts.iter().chain(&a.id.logs) {
        plan.input("input", p);
    }
    plan.input("--map", &a.map);
    check(&plan)?;
    let loaded = volcomp_core::io::load_model(&a.map, &volcomp_core::io::LoadOptions::default())?;
    let options = a.job.options()?;
    let request = VerifyRequest {
        artifacts: inputs(&a.id.artifacts, "ARTIFACT")?,
        logs: inputs(&a.id.logs, "LOG")?,
        model: loaded.model(),
        applied: match a.applied {
            AppliedArg::Machine => Applied::Machine,
            AppliedArg::Software => Applied::Software,
        },
        options,
    };
    let out = request.run()?;
    for line in probe::verify_lines(&out) {
        println!("{line}");
    }
    Ok(())
}

fn example_cmd(a: ExampleArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.output).map_err(|e| CliError::Io(a.output.clone(), e))?;
    for (name, text) in volcomp_core::example::probe::example_files() {
        let path = a.output.join(&name);
        write_file(&path, &[], text.as_bytes())?;
    }
    for line in probe::example_lines(&a.output) {
        println!("{line}");
    }
    Ok(())
}
