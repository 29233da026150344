//! The machine a program runs on, as every job that reads a program takes
//! it: the set-up file, the work offset, and how the interpreter reads what
//! controllers disagree on.

use super::option::{Input, OptionError};
use crate::compensate::MachineSetup;
use crate::Error;
use std::path::PathBuf;
use volcomp_gcode::{InterpOptions, Vec3};

request! {
    /// How a program is set up on the machine, as plain values.
    pub struct MachineRequest {}
    /// The options of [`MachineRequest`].
    pub const MACHINE_OPTIONS, unknown "setup";

    /// The set-up TOML file (docs/setup.md).
    setup: Option<Input> = None, Input.value("FILE"),
        "TOML setup file: work offsets, tool lengths, reference points.";

    /// G54 in machine coordinates (mm), overriding the set-up's.
    work_offset_mm: Option<[f64; 3]> = None, Triple.flag("work-offset").value("X,Y,Z"),
        "G54 work offset in mm (machine coordinates), overriding the setup's.";

    /// Arc centres are absolute from the start (G90.1).
    absolute_arc_centers: bool = false, Switch,
        "Read I/J/K as absolute arc centres (as if the program began with G90.1).";

    /// Accept `K0` on G17 arcs.
    accept_k0: bool = false, Switch,
        "Accept `K0` on G17 arcs (FreeCAD writes it; LinuxCNC refuses it, and so does volcomp by default).";

    /// Refuse `K0` on G17 arcs (the default; kept for old scripts).
    strict_k0: bool = false, Switch.hidden(),
        "Refuse `K0` on G17 arcs: the default now, kept for old scripts.";

    /// Do not warn about a program without M2, M30 or a closing `%`.
    allow_no_program_end: bool = false, Switch,
        "Do not warn about a program that ends without M2, M30 or a closing `%` (LinuxCNC runs it to its last line, then reports an error; grbl-family and other controllers need no end).";

    /// Most lines executed again (loops, calls) in one run.
    max_repeated_lines: u64 = volcomp_gcode::ngc::flow::MAX_EXECUTED_LINES,
        Count.value("N").default("5000000"),
        "Most lines a run executes again (every pass of a loop after the first, every line of a called subroutine) before it is refused as a loop that never ends; a program without loops runs whatever its length.";
}

/// A machine set-up ready for a job, with where it came from (for the
/// compensated program's header).
#[derive(Debug, Clone)]
pub struct Machine {
    /// The set-up and the interpreter's options.
    pub setup: MachineSetup,
    /// The set-up file, when one was given as a file.
    pub setup_file: Option<PathBuf>,
    /// The work offset came from the work-offset option.
    pub work_offset_given: bool,
}

impl MachineRequest {
    /// The machine: the set-up file read, the work offset applied, the
    /// interpreter's options set (a program must end with M2, M30 or `%`
    /// unless allowed otherwise, as LinuxCNC requires).
    pub fn machine(&self) -> Result<Machine, Error> {
        if self.accept_k0 && self.strict_k0 {
            return Err(OptionError::new("strict_k0", "cannot be given with {accept_k0}").into());
        }
        let mut setup = match &self.setup {
            None => MachineSetup::unset(),
            Some(Input::File(path)) => MachineSetup::from_setup_file(path)?,
            Some(Input::Content { name, bytes }) => {
                let text = std::str::from_utf8(bytes).map_err(|_| {
                    OptionError::new("setup", format!("{name}: the set-up is not UTF-8 text"))
                })?;
                MachineSetup::from_setup_toml(text, name)?
            }
        };
        if let Some(w) = self.work_offset_mm {
            let max = crate::limits::MAX_POSITION_MM;
            if !w.iter().all(|v| v.is_finite() && v.abs() <= max) {
                return Err(OptionError::new(
                    "work_offset_mm",
                    format!(
                        "must be three numbers in mm (X, Y, Z) within ±{max} mm; got {}, {}, {}",
                        w[0], w[1], w[2]
                    ),
                )
                .into());
            }
            setup = setup.with_work_offset(Vec3::new(w[0], w[1], w[2]));
        }
        let setup = setup.with_interp_options(InterpOptions {
            accept_k0_on_xy_arcs: self.accept_k0,
            absolute_arc_centers: self.absolute_arc_centers,
            require_program_end: !self.allow_no_program_end,
            max_executed_lines: self.max_repeated_lines,
            ..InterpOptions::default()
        });
        Ok(Machine {
            setup,
            setup_file: self
                .setup
                .as_ref()
                .and_then(|s| s.path())
                .map(PathBuf::from),
            work_offset_given: self.work_offset_mm.is_some(),
        })
    }
}

/// The first words of every message about a missing work offset.
pub const NO_WORK_OFFSET: &str = "no work offset was given (G54 = 0)";

impl Machine {
    /// The warning a front end shows when no work offset was given (`None`
    /// when one was); options as `{name}`.
    pub fn work_offset_warning(&self) -> Option<String> {
        self.setup.no_work_offset.then(|| {
            format!("{NO_WORK_OFFSET}: program coordinates are taken as machine coordinates; give the offsets with {{setup}} or {{work_offset_mm}}")
        })
    }

    /// `e` with the help that fixes a point outside the map: first a missing
    /// work offset, then the set-up and clamping (options as `{name}`);
    /// `None` when `e` is not about a point outside the map.
    pub fn explain(&self, e: &Error) -> Option<String> {
        use crate::error::CompensationError;
        if !matches!(e, Error::Compensation(CompensationError::Model { .. })) {
            return None;
        }
        if let Some(help) = self.inch_setup_in_mm(e) {
            // The set-up, not the map: the map's unit is not in question.
            let text = e.to_string();
            let text = match (
                text.find("; the map may be in another unit: "),
                text.find("; check the work offset"),
            ) {
                (Some(a), Some(b)) if a < b => format!("{}{}", &text[..a], &text[b..]),
                _ => text,
            };
            return Some(format!("{text}\n  help: {help}"));
        }
        Some(if self.setup.no_work_offset {
            format!("{NO_WORK_OFFSET}: {e}\n  help: give the program's work offsets with {{setup}} or {{work_offset_mm}} first; {{clamp}} holds the error at the table ends")
        } else {
            format!("{e}\n  help: check {{setup}} / {{work_offset_mm}}; {{clamp}} holds the error at the table ends")
        })
    }

    /// When the set-up file says `units = "inch"` and a point outside the
    /// map comes inside it at 1/25.4 of its value, the likely cause: the
    /// set-up's numbers (offsets, tool lengths, start) were written in mm
    /// and read as inches, which puts the part 25.4 times as far from the
    /// machine's zero. The map is not the suspect then: its range is where
    /// the part would be with the numbers read as mm.
    fn inch_setup_in_mm(&self, e: &Error) -> Option<String> {
        use crate::error::{CompensationError, ModelError};
        let Error::Compensation(CompensationError::Model {
            source:
                ModelError::OutOfRange {
                    axis,
                    position_mm,
                    min_mm,
                    max_mm,
                },
            ..
        }) = e
        else {
            return None;
        };
        if self.setup.setup.machine_units != volcomp_gcode::geom::Units::Inch {
            return None;
        }
        let margin = 0.05 * (max_mm - min_mm).abs();
        let read_as_mm = position_mm / 25.4;
        if read_as_mm < min_mm - margin || read_as_mm > max_mm + margin {
            return None;
        }
        Some(format!(
            "the set-up says units = \"inch\", and {axis} / 25.4 = {} mm is inside the map: the set-up's offsets, tool lengths and start are likely in mm; write units = \"mm\" in {{setup}}, or give those numbers in inches",
            crate::error::fmt_mm(read_as_mm)
        ))
    }
}
