//! What is left after compensation: the same probing run again, on the
//! compensated machine (the controller applying the model, or the model
//! applied to the touches here), identified like the calibration; its
//! parameters are the machine's remaining error (docs/probing.md,
//! "Verification").

use super::identify::{fit_and_identify, Identified, IdentifyOptions, Status};
use super::request::{read_inputs, Input};
use super::result::{grid, rms_modulo_rigid};
use super::ProbeError;
use crate::model::{Components, ErrorModel, ALL_FORWARD};
use volcomp_gcode::Vec3;

/// How the verification run was compensated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Applied {
    /// The machine ran compensated (the controller's tables or a
    /// compensated program): the touches are what is left.
    Machine,
    /// The run was made uncompensated; the model is applied to the touches
    /// here (each touch moved to `q + e(q, s)`).
    Software,
}

/// Check a model against a probing run.
pub struct VerifyRequest<'a> {
    /// The artifacts (TOML).
    pub artifacts: Vec<Input>,
    /// The verification run's logs.
    pub logs: Vec<Input>,
    /// The model being checked.
    pub model: &'a dyn ErrorModel,
    /// How the run was compensated.
    pub applied: Applied,
    /// Identification options (as for the calibration).
    pub options: IdentifyOptions,
}

/// What is left.
#[derive(Debug, Clone)]
pub struct VerifyOutput {
    /// The identification of the remaining error.
    pub identified: Identified,
    /// RMS over the volume of the remaining error's identified part,
    /// modulo a rigid motion (µm).
    pub left_rms_um: f64,
    /// Identified parameters more than three standard uncertainties from zero.
    pub significant: Vec<String>,
}

impl VerifyRequest<'_> {
    /// Reads the run, applies the model if asked, identifies what is left.
    pub fn run(&self) -> Result<VerifyOutput, ProbeError> {
        let (artifacts, mut touches) = read_inputs(&self.artifacts, &self.logs)?;
        if self.applied == Applied::Software {
            for t in &mut touches {
                let s = t.states.unwrap_or(ALL_FORWARD);
                let e = self
                    .model
                    .deviation_with_tool_um(
                        t.q_mm,
                        s,
                        Components::All,
                        Vec3::new(0.0, 0.0, t.tool_length_mm),
                    )
                    .map_err(|e| {
                        ProbeError::Invalid(format!(
                            "{}:{}: the model cannot be evaluated at this touch: {e}",
                            t.source.file, t.source.line
                        ))
                    })?;
                t.q_mm += e * 1e-3;
            }
        }
        let (_, identified) = fit_and_identify(&artifacts, &touches, &self.options)?;
        let theta = identified.theta();
        let pts = grid(self.options.ranges_mm, 5);
        let tool = Vec3::new(0.0, 0.0, identified.probe_length_mm);
        let field: Vec<Vec3> = pts
            .iter()
            .map(|q| identified.model.deviation_um(&theta, *q, tool, false))
            .collect();
        let left_rms_um = rms_modulo_rigid(&pts, &field);
        let significant = identified
            .params
            .iter()
            .filter_map(|p| match p.status {
                Status::Identified(e) if e.value.abs() > 3.0 * e.sigma => Some(p.name.clone()),
                _ => None,
            })
            .collect();
        Ok(VerifyOutput {
            identified,
            left_rms_um,
            significant,
        })
    }
}
