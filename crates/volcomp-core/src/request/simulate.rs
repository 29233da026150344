//! A simulation of a part program on a machine with an error model, as
//! plain values: the machine, the chord tolerance and the reference
//! program.

use super::machine::{Machine, MachineRequest, MACHINE_OPTIONS};
use super::option::{Input, OptionError};
use crate::model::ErrorModel;
use crate::simulate::DEFAULT_CHORD_TOLERANCE_MM;
use crate::Simulation;

request! {
    /// A simulation, as plain values.
    pub struct SimulateRequest {
        /// The machine.
        pub machine: MachineRequest,
    }
    /// The options of [`SimulateRequest`] beside the machine's.
    pub const SIMULATE_OPTIONS;
    options [MACHINE_OPTIONS, SIMULATE_OPTIONS], unknown "reference";

    /// The original of a compensated program.
    reference: Option<Input> = None, Input.value("ORIGINAL"),
        "The original program whose nominal path the program is judged against (the program written by `volcomp compensate` from it: its `(volcomp Ln)` comments pair them).";

    /// Chord tolerance (mm).
    chord_tolerance_mm: f64 = DEFAULT_CHORD_TOLERANCE_MM,
        Number.flag("chord-tolerance").value("MM").default("0.00001"),
        "Chord tolerance for linearising arcs and splines (mm).";
}

impl SimulateRequest {
    /// The chord tolerance, checked.
    pub fn chord_tolerance_mm(&self) -> Result<f64, OptionError> {
        let t = self.chord_tolerance_mm;
        let min = crate::limits::MIN_CHORD_TOLERANCE_MM;
        let max = crate::limits::MAX_CHORD_TOLERANCE_MM;
        if t.is_finite() && (min..=max).contains(&t) {
            Ok(t)
        } else {
            Err(OptionError::new(
                "chord_tolerance_mm",
                format!("must be a length of {min} mm (1 nm) to {max} mm; got {t}"),
            ))
        }
    }

    /// `machine` with splines linearised within the chord tolerance.
    pub fn prepare(&self, machine: Machine) -> Result<Machine, OptionError> {
        let t = self.chord_tolerance_mm()?;
        let mut machine = machine;
        machine.setup = machine.setup.with_spline_tolerance(t);
        Ok(machine)
    }

    /// The simulation of a program named `file` for `model` on `machine`
    /// (from [`SimulateRequest::prepare`]), against the reference when one
    /// was given (read here).
    pub fn simulation<'a>(
        &'a self,
        model: &'a dyn ErrorModel,
        machine: &Machine,
        file: &str,
    ) -> Result<Simulation<'a>, crate::Error> {
        let mut sim = Simulation::new(model)
            .setup(machine.setup.clone())
            .file_name(file)
            .chord_tolerance_mm(self.chord_tolerance_mm()?);
        if let Some(r) = &self.reference {
            sim = sim.reference_named(r.name(), r.reader()?);
        }
        Ok(sim)
    }
}
