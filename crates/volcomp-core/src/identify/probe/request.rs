//! The probing jobs as library requests: built from plain values (file
//! texts and names, numbers), validated once here, run by any front end.
//! Messages name options, never a front end's flags.

use super::artifact::{parse_artifact, Artifact};
use super::fit::{Estimate, Fitted};
use super::identify::{fit_and_identify, leave_one_out, HeldOut, Identified, IdentifyOptions};
use super::plan::{plan, Plan, PlanOptions};
use super::program::{check_program, write_program, Frame};
use super::ProbeError;
use crate::io::probe_log::{read_touches, Touch};
use crate::model::kinematic::KinematicModel;
use crate::model::setup::MachineSetup;

/// A named text input (a file's name and its contents).
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    /// The name errors use.
    pub name: String,
    /// The contents.
    pub text: String,
}

impl Input {
    /// An input from a name and its text.
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            text: text.into(),
        }
    }
}

/// Make a probing program.
#[derive(Debug, Clone)]
pub struct PlanRequest {
    /// The artifact description (TOML).
    pub artifact: Input,
    /// The machine's offsets and tool table (work offsets, probe length).
    pub setup: MachineSetup,
    /// Only this placement (`None`: all, with a pause between them).
    pub placement: Option<String>,
    /// Feeds, distances, touches, log file, coordinate system, probe tool.
    pub options: PlanOptions,
    /// The program's first comment (what made it).
    pub title: String,
}

/// A probing program and its plan.
#[derive(Debug, Clone)]
pub struct PlanOutput {
    /// The artifact as read.
    pub artifact: Artifact,
    /// The plan (touches, time).
    pub plan: Plan,
    /// The program text, checked by volcomp's interpreter.
    pub program: String,
}

impl PlanRequest {
    /// Plans, writes and checks the program.
    pub fn run(&self) -> Result<PlanOutput, ProbeError> {
        self.options.validate()?;
        let artifact = parse_artifact(&self.artifact.text, &self.artifact.name)?;
        let plan = plan(&artifact, self.placement.as_deref(), &self.options)?;
        let frame = Frame::of(&self.setup, &self.options)?;
        let program = write_program(&plan, &self.options, &frame, &self.title);
        check_program(
            &program,
            &plan,
            &self.setup,
            &frame,
            self.options.probe_tool,
        )?;
        Ok(PlanOutput {
            artifact,
            plan,
            program,
        })
    }
}

/// Identify a machine from probing logs.
#[derive(Debug, Clone)]
pub struct FitRequest {
    /// Every artifact the logs touched (TOML).
    pub artifacts: Vec<Input>,
    /// LinuxCNC logs or CSV points.
    pub logs: Vec<Input>,
    /// Model, ranges, order, threshold.
    pub options: IdentifyOptions,
    /// Also predict every placement from a model fitted without it.
    pub leave_one_out: bool,
    /// Repeats of the Monte Carlo of the whole chain (0: least squares
    /// only; [`super::monte_carlo`]).
    pub monte_carlo: usize,
}

/// What a fit found.
#[derive(Debug, Clone)]
pub struct FitOutput {
    /// The artifacts as read.
    pub artifacts: Vec<Artifact>,
    /// Every touch read.
    pub touches: Vec<Touch>,
    /// Calibrations, sphere centres, face touches.
    pub fitted: Fitted,
    /// The identification.
    pub identified: Identified,
    /// The axes' reversal values put into the model.
    pub reversal_um: [Option<Estimate>; 3],
    /// Leave-one-placement-out predictions (empty unless asked).
    pub held_out: Vec<HeldOut>,
    /// The model file's content.
    pub model: KinematicModel,
}

impl FitOutput {
    /// The identification as text lines.
    pub fn summary(&self, ranges_mm: [[f64; 2]; 3]) -> Vec<String> {
        super::result::summary(
            &self.identified,
            &self.fitted,
            &self.reversal_um,
            &self.held_out,
            ranges_mm,
        )
    }

    /// The model's TOML (naming `tables` as its CSV, with the summary as
    /// comments) and CSV texts.
    pub fn model_files(
        &self,
        tables: &str,
        description: &str,
        ranges_mm: [[f64; 2]; 3],
    ) -> (String, String) {
        let mut toml = String::new();
        for line in self.summary(ranges_mm) {
            toml.push_str("# ");
            toml.push_str(&line);
            toml.push('\n');
        }
        toml.push_str(&crate::io::model_file::model_to_toml(
            &self.model,
            tables,
            Some(description),
        ));
        (
            toml,
            crate::io::model_file::components_to_csv(&self.model.axes),
        )
    }
}

/// The Monte Carlo's seed: the same logs give the same uncertainties.
const MONTE_CARLO_SEED: u64 = 0x5EED;

/// Reads artifacts and logs (every error located).
pub fn read_inputs(
    artifacts: &[Input],
    logs: &[Input],
) -> Result<(Vec<Artifact>, Vec<Touch>), ProbeError> {
    if artifacts.is_empty() {
        return Err(ProbeError::Invalid(
            "no artifact: give the description of every artifact the logs touched".into(),
        ));
    }
    if logs.is_empty() {
        return Err(ProbeError::Invalid(
            "no log: give the probing log(s) or CSV points".into(),
        ));
    }
    let mut arts: Vec<Artifact> = Vec::new();
    for a in artifacts {
        let art = parse_artifact(&a.text, &a.name)?;
        if arts.iter().any(|b| b.name == art.name) {
            return Err(ProbeError::Invalid(format!(
                "{}: artifact name `{}` is used by another artifact file too; give each artifact its own name",
                a.name, art.name
            )));
        }
        arts.push(art);
    }
    let mut touches = Vec::new();
    for l in logs {
        touches.extend(read_touches(&l.text, &l.name)?);
    }
    Ok((arts, touches))
}

impl FitRequest {
    /// Reads, fits, identifies, and builds the model.
    pub fn run(&self) -> Result<FitOutput, ProbeError> {
        let (artifacts, touches) = read_inputs(&self.artifacts, &self.logs)?;
        let (fitted, mut identified) = fit_and_identify(&artifacts, &touches, &self.options)?;
        if self.monte_carlo > 0 {
            super::monte_carlo::apply(
                &artifacts,
                &touches,
                &self.options,
                &mut identified,
                self.monte_carlo,
                MONTE_CARLO_SEED,
            )?;
        }
        let held_out = if self.leave_one_out {
            leave_one_out(&artifacts, &fitted, &self.options)?
        } else {
            Vec::new()
        };
        let reversal_um = super::result::reversal(&fitted);
        let model = super::result::kinematic_model(&identified, &reversal_um);
        Ok(FitOutput {
            artifacts,
            touches,
            fitted,
            identified,
            reversal_um,
            held_out,
            model,
        })
    }
}
