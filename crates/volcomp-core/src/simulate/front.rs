//! The front door of simulation: a builder ([`Simulation`]) that runs a
//! program on a machine with the model's errors and measures the tool path
//! against its nominal path (the program itself, or the original program a
//! compensated one was written from).
//!
//! ```
//! use volcomp_core::{example::example_map, MachineSetup, Simulation};
//! # fn main() -> Result<(), volcomp_core::Error> {
//! let map = example_map();
//! let program = "G21 G90\nG0 X100 Y100 Z100\nG1 X200 F500\n";
//! let report = Simulation::new(&map)
//!     .setup(MachineSetup::default())
//!     .run(program.as_bytes())?;
//! assert_eq!(report.points, 1);
//! assert!(report.contour_max_um > 0.0);
//! # Ok(())
//! # }
//! ```

use super::report::{simulate_program, SegmentError, SimReport};
use crate::compensate::MachineSetup;
use crate::error::Error;
use crate::model::ErrorModel;
use std::io::{BufReader, Read};
use volcomp_gcode::Warning;

/// Chord tolerance used to linearise arcs and splines when none is given
/// (mm): 10 nm. The simulated path of a commanded arc follows its chords,
/// so their sagitta is an error of the measurement itself; it must sit well
/// under the errors measured (the contour tolerance of 0.1 µm): with
/// 0.1 µm chords the contour RMS of a compensated arc program read about
/// 0.07 µm whatever was written (the chords' own, `0.1·√(8/15)`), with
/// 10 nm the arc's real remainder shows (GEAR_CLAMP.nc on the ripple map:
/// RMS 0.051 → 0.036 µm, 1 nm gives the same). It costs about 2.5× the
/// simulation time on arc programs.
pub const DEFAULT_CHORD_TOLERANCE_MM: f64 = 1e-5;

/// A caller's function called on each item as it is produced.
type Callback<'a, T> = Box<dyn FnMut(&T) + 'a>;

/// Simulates a program and measures its point and contour errors (see
/// [`crate::simulate::report`] for the definitions).
///
/// Defaults: [`MachineSetup::default`], the program is its own nominal path,
/// chord tolerance [`DEFAULT_CHORD_TOLERANCE_MM`], the program named
/// `<program>` in messages.
pub struct Simulation<'a> {
    model: &'a dyn ErrorModel,
    setup: MachineSetup,
    reference: Option<(String, Box<dyn Read + 'a>)>,
    chord_tolerance_mm: f64,
    file: String,
    on_segment: Option<Callback<'a, SegmentError>>,
    on_warning: Option<Callback<'a, Warning>>,
}

impl<'a> Simulation<'a> {
    /// A simulation of programs on a machine with `model`'s errors.
    pub fn new(model: &'a dyn ErrorModel) -> Self {
        Self {
            model,
            setup: MachineSetup::default(),
            reference: None,
            chord_tolerance_mm: DEFAULT_CHORD_TOLERANCE_MM,
            file: "<program>".into(),
            on_segment: None,
            on_warning: None,
        }
    }

    /// The machine the program runs on.
    pub fn setup(mut self, setup: impl Into<MachineSetup>) -> Self {
        self.setup = setup.into();
        self
    }

    /// The original program the simulated one was compensated from: its
    /// moves are the nominal path (paired by the `(volcomp Ln)` comments).
    pub fn reference(self, reference: impl Read + 'a) -> Self {
        self.reference_named("<reference>", reference)
    }

    /// [`Self::reference`], naming the reference `name` in messages.
    pub fn reference_named(mut self, name: impl Into<String>, reference: impl Read + 'a) -> Self {
        self.reference = Some((name.into(), Box::new(reference)));
        self
    }

    /// Chord tolerance for arcs (mm, positive).
    pub fn chord_tolerance_mm(mut self, tolerance_mm: f64) -> Self {
        self.chord_tolerance_mm = tolerance_mm;
        self
    }

    /// The program's name in messages.
    pub fn file_name(mut self, name: impl Into<String>) -> Self {
        self.file = name.into();
        self
    }

    /// Called with every measured feed command, in order.
    pub fn on_segment(mut self, f: impl FnMut(&SegmentError) + 'a) -> Self {
        self.on_segment = Some(Box::new(f));
        self
    }

    /// Called, once the run ends (also when it fails), with what the
    /// interpreter assumed about the simulated program.
    pub fn on_warning(mut self, f: impl FnMut(&Warning) + 'a) -> Self {
        self.on_warning = Some(Box::new(f));
        self
    }

    /// Simulates `program` and measures it.
    pub fn run<R: Read>(mut self, program: R) -> Result<SimReport, Error> {
        let mut walker = self
            .setup
            .walker(BufReader::with_capacity(1 << 16, program), &self.file);
        let mut reference = self.reference.take().map(|(name, r)| {
            self.setup
                .walker(BufReader::with_capacity(1 << 16, r), &name)
        });
        let mut no_op = |_: &SegmentError| {};
        let on_segment: &mut dyn FnMut(&SegmentError) = match self.on_segment.as_mut() {
            Some(f) => f.as_mut(),
            None => &mut no_op,
        };
        let result = simulate_program(
            &mut walker,
            &self.file,
            reference.as_mut(),
            self.model,
            self.chord_tolerance_mm,
            on_segment,
        );
        if let Some(f) = self.on_warning.as_mut() {
            walker.warnings().iter().for_each(f);
        }
        Ok(result?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::Compensator;
    use crate::example::example_map;
    use volcomp_gcode::Vec3;

    #[test]
    fn compensation_through_the_front_doors_lowers_the_contour_error() {
        let map = example_map();
        let setup = MachineSetup::default().with_work_offset(Vec3::new(100.0, 100.0, 100.0));
        let program = "G21 G90\nG0 X0 Y0 Z0\nG1 X200 Y50 F500\nG1 Y150\n";
        let before = Simulation::new(&map)
            .setup(setup.clone())
            .run(program.as_bytes())
            .unwrap();
        let mut out = Vec::new();
        Compensator::new(&map)
            .setup(setup.clone())
            .run(program.as_bytes(), &mut out)
            .unwrap();
        let after = Simulation::new(&map)
            .setup(setup)
            .reference(program.as_bytes())
            .run(out.as_slice())
            .unwrap();
        // The same nominal targets (the two feed-move ends) are measured
        // before and after.
        assert_eq!(before.points, after.points);
        assert!(before.contour_max_um > 1.0, "{before:?}");
        assert!(
            after.contour_max_um < 0.1 * before.contour_max_um,
            "{after:?}"
        );
        assert_eq!(after.nominal, "reference");
    }
}
