//! The machine a program runs on ([`MachineSetup`]): work offsets, tool
//! lengths, start position and units (LinuxCNC's set-up, docs/setup.md),
//! and how the interpreter reads what controllers disagree on. Below the
//! folders that read it (io, identify, compensate, simulate, plan).

use crate::error::Error;
use std::path::Path;
use volcomp_gcode::{InterpOptions, Setup, Vec3, Walker};

/// The machine a program runs on: its set-up (work offsets, tool lengths,
/// start position, units), the interpreter's options, and whether any work
/// offset was given at all.
#[derive(Debug, Clone, Default)]
pub struct MachineSetup {
    /// Work offsets, tools, start position (LinuxCNC's set-up).
    pub setup: Setup,
    /// How the interpreter reads what controllers disagree on.
    pub interp: InterpOptions,
    /// No set-up file and no work offset were given: G54 is zero, so program
    /// coordinates are taken as machine coordinates.
    pub no_work_offset: bool,
}

impl From<Setup> for MachineSetup {
    fn from(setup: Setup) -> Self {
        Self {
            setup,
            ..Self::default()
        }
    }
}

impl MachineSetup {
    /// A machine with nothing set: G54 = 0 (and [`Self::no_work_offset`]).
    pub fn unset() -> Self {
        Self {
            no_work_offset: true,
            ..Self::default()
        }
    }

    /// The set-up read from a set-up TOML file (docs/setup.md).
    pub fn from_setup_file(path: &Path) -> Result<Self, Error> {
        let text = volcomp_geom::inputs::read_to_string(path, "the set-up")
            .map_err(|e| Error::io(path, e))?;
        Self::from_setup_toml(&text, &path.display().to_string())
    }

    /// The set-up of a set-up TOML text; `file` names it in errors.
    pub fn from_setup_toml(text: &str, file: &str) -> Result<Self, Error> {
        Ok(Setup::from_toml_in(text, file)
            .map_err(Error::Setup)?
            .into())
    }

    /// This set-up with G54 set to `offset_mm` (machine coordinates of the
    /// program zero).
    pub fn with_work_offset(mut self, offset_mm: Vec3) -> Self {
        self.setup.work_offsets_mm[0] = offset_mm;
        self.no_work_offset = false;
        self
    }

    /// This set-up with the interpreter's options.
    pub fn with_interp_options(mut self, interp: InterpOptions) -> Self {
        self.interp = interp;
        self
    }

    /// This set-up with splines (G5, G5.1, G5.2) linearised within
    /// `tolerance_mm`, like arcs within the chord tolerance.
    pub fn with_spline_tolerance(mut self, tolerance_mm: f64) -> Self {
        self.interp.spline_tolerance_mm = tolerance_mm;
        self
    }

    /// An interpreter over `program`, naming it `file` in its errors.
    pub fn walker<R: std::io::BufRead>(&self, program: R, file: &str) -> Walker<R> {
        Walker::new(
            program,
            Some(file.to_string()),
            self.setup.clone(),
            self.interp,
        )
    }
}
