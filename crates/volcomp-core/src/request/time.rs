//! Machining time on the planner model (`crate::plan`, docs/planner.md):
//! the `time` job as plain values, and the time the compensate and
//! simulate jobs give beside their own figures.

use super::compensate::Compensation;
use super::machine::{Machine, MachineRequest, MACHINE_OPTIONS};
use super::option::{Input, Kind, OptionError, OptionInfo, Value};
use super::simulate::SimulateRequest;
use crate::compensate::{CompensateSummary, PointRecord};
use crate::limits::LimitedWriter;
use crate::model::ErrorModel;
use crate::plan::{
    compare_programs, compare_programs_per_line, compare_while_writing_fed, LineTime,
    TimeComparison,
};
use crate::simulate::report::SegmentError;
use crate::simulate::SimReport;
use crate::Error;
use std::io::{Read, Write};
use std::path::Path;
use volcomp_gcode::{LineEvent, Warning};

/// The options of [`TimeRequest`] beside the machine's.
pub const TIME_OPTIONS: &[OptionInfo] = &[OptionInfo::new(
    "reference",
    Kind::Input,
    "The program this one was made from (the original of a compensated program): both times and the change are given.",
)
.value("ORIGINAL")];

/// A machining-time estimate, as plain values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeRequest {
    /// The machine (its set-up's `[limits]` give the planner's limits).
    pub machine: MachineRequest,
    /// The program the estimated one was made from.
    pub reference: Option<Input>,
}

impl super::Request for TimeRequest {
    const OPTIONS: &'static [&'static [OptionInfo]] = &[MACHINE_OPTIONS, TIME_OPTIONS];

    fn set(&mut self, name: &str, v: Value) -> Result<(), OptionError> {
        if self.machine.try_set(name, v.clone())? {
            return Ok(());
        }
        match name {
            "reference" => self.reference = Some(v.input("reference")?),
            _ => return Err(OptionError::unknown("reference", name)),
        }
        Ok(())
    }
}

impl TimeRequest {
    /// The time of `program` (named `name`) on `machine` (from
    /// [`MachineRequest::machine`]), and of the reference when given.
    pub fn run(
        &self,
        machine: &Machine,
        program: impl Read,
        name: &str,
    ) -> Result<TimeComparison, Error> {
        self.with_reference(|original| compare_programs((program, name), original, &machine.setup))
    }

    /// [`TimeRequest::run`], and the program's time per line
    /// ([`crate::plan::estimate_program_per_line`]): where the time goes.
    pub fn run_per_line(
        &self,
        machine: &Machine,
        program: impl Read,
        name: &str,
    ) -> Result<(TimeComparison, Vec<LineTime>), Error> {
        self.with_reference(|original| {
            compare_programs_per_line((program, name), original, &machine.setup)
        })
    }

    /// `f` given the reference, opened, and its name, when there is one.
    fn with_reference<T>(
        &self,
        f: impl FnOnce(Option<(Box<dyn Read + Send + '_>, &str)>) -> Result<T, Error>,
    ) -> Result<T, Error> {
        let ref_name = self.reference.as_ref().map(Input::name);
        let original = match (&self.reference, &ref_name) {
            (Some(r), Some(n)) => Some((r.reader()?, n.as_str())),
            _ => None,
        };
        f(original)
    }
}

fn open(path: &Path) -> Result<std::fs::File, Error> {
    crate::io::inputs::open(path, "the program").map_err(|e| Error::io(path, e))
}

impl Compensation {
    /// The machining time of the compensated program (`compensated`,
    /// named `name`) beside the original's, the program file `program`
    /// (not read again when it is standard input, `-`).
    pub fn machining_time(
        &self,
        program: &Path,
        compensated: impl Read,
        name: &str,
    ) -> Result<TimeComparison, Error> {
        let shown = program.display().to_string();
        let original = if program.as_os_str() == "-" {
            None
        } else {
            Some((
                Box::new(open(program)?) as Box<dyn Read + Send>,
                shown.as_str(),
            ))
        };
        compare_programs((compensated, name), original, &self.machine.setup)
    }

    /// [`Compensation::machining_time`] of the program `write` writes,
    /// estimated while it is written (see [`compare_while_writing_fed`]:
    /// `write` compensates the program file `program` with this job's
    /// set-up and gives each line it reads to the function it is handed,
    /// [`crate::compensate::Compensator::on_line`]): what `write` gives,
    /// and the times (an error opening the original is the times' error,
    /// as it is there).
    pub fn machining_time_while<T, E>(
        &self,
        program: &Path,
        name: &str,
        write: impl FnOnce(&mut dyn Write, &mut dyn FnMut(&LineEvent<'_>)) -> Result<T, E>,
    ) -> Result<(T, Result<TimeComparison, Error>), E> {
        let shown = program.display().to_string();
        let original = match program.as_os_str() == "-" {
            true => None,
            false => match open(program) {
                Ok(f) => Some((Box::new(f) as Box<dyn Read + Send>, shown.as_str())),
                Err(e) => return write(&mut std::io::sink(), &mut |_| {}).map(|t| (t, Err(e))),
            },
        };
        compare_while_writing_fed(name, original, &self.machine.setup, write)
    }
}

impl SimulateRequest {
    /// The machining time of the simulated program file `program` (and of
    /// the reference when given); `None` for standard input (`-`), which
    /// is read once.
    pub fn machining_time(
        &self,
        machine: &Machine,
        program: &Path,
    ) -> Result<Option<TimeComparison>, Error> {
        if program.as_os_str() == "-" {
            return Ok(None);
        }
        let name = program.display().to_string();
        let t = self.time_request();
        t.run(machine, open(program)?, &name).map(Some)
    }

    /// The machining time of the simulated program and its reference.
    pub fn time_request(&self) -> TimeRequest {
        TimeRequest {
            machine: self.machine.clone(),
            reference: self.reference.clone(),
        }
    }

    /// Simulates `program` (named `file`, held in memory) as
    /// [`SimulateRequest::simulation`] does, keeping the warnings, the
    /// measured commands when asked for, and the machining time.
    pub fn run_in_memory(
        &self,
        model: &dyn ErrorModel,
        machine: &Machine,
        (program, file): (&[u8], &str),
        keep_segments: bool,
    ) -> Result<Simulated, Error> {
        let (mut segments, mut warnings) = (Vec::new(), Vec::new());
        let mut sim = self
            .simulation(model, machine, file)?
            .on_warning(|w| warnings.push(w.clone()));
        if keep_segments {
            sim = sim.on_segment(|s| segments.push(*s));
        }
        let report = sim.run(program)?;
        let time = self.time_request().run(machine, program, file)?;
        Ok(Simulated {
            report,
            segments,
            warnings,
            time,
        })
    }
}

/// A simulation run in memory ([`SimulateRequest::run_in_memory`]).
pub struct Simulated {
    /// The metrics.
    pub report: SimReport,
    /// The measured feed commands (when asked for).
    pub segments: Vec<SegmentError>,
    /// What the interpreter assumed.
    pub warnings: Vec<Warning>,
    /// The machining time of the program (and of the reference).
    pub time: TimeComparison,
}

/// A compensation run in memory ([`Compensation::run_in_memory`]).
pub struct Compensated {
    /// The compensated program.
    pub program: Vec<u8>,
    /// What was done.
    pub summary: CompensateSummary,
    /// The per-point records (when asked for).
    pub points: Vec<PointRecord>,
    /// What the interpreter assumed.
    pub warnings: Vec<Warning>,
    /// The machining time of the compensated program beside the original's.
    pub time: TimeComparison,
}

impl Compensation {
    /// Compensates `program` (named `file`, held in memory) within the
    /// output limit, keeping the warnings, the per-point records when asked
    /// for, and the machining time of both programs.
    pub fn run_in_memory(
        &self,
        model: &dyn ErrorModel,
        (program, file): (&[u8], &str),
        keep_points: bool,
    ) -> Result<Compensated, Error> {
        let (mut out, mut points, mut warnings) = (Vec::new(), Vec::new(), Vec::new());
        let mut limited = LimitedWriter::new(&mut out, self.max_output_bytes);
        let summary = self
            .compensator(model, file)
            .on_point(|p| {
                if keep_points {
                    points.push(*p);
                }
            })
            .on_warning(|w| warnings.push(w.clone()))
            .run(program, &mut limited)?;
        let original = Some((Box::new(program) as Box<dyn Read + Send>, file));
        let time = compare_programs(
            (out.as_slice(), "<compensated>"),
            original,
            &self.machine.setup,
        )?;
        Ok(Compensated {
            program: out,
            summary,
            points,
            warnings,
            time,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::Request;

    #[test]
    fn the_reference_is_estimated_beside_the_program() {
        let mut r = TimeRequest::default();
        r.set(
            "reference",
            Value::Content {
                name: "o.ngc".into(),
                bytes: b"G21 G90 G61\nG1 X100 F6000\nM2\n".to_vec(),
            },
        )
        .unwrap();
        let machine = r.machine.machine().unwrap();
        let t = r
            .run(
                &machine,
                "G21 G90 G61\nG1 X100 F3000\nM2\n".as_bytes(),
                "p.ngc",
            )
            .unwrap();
        // G61 trapezoids at 1000 mm/s²: 100/50 + 50/1000 = 2.05 s against
        // 100/100 + 100/1000 = 1.1 s.
        assert!((t.program.motion.total_s - 2.05).abs() <= 0.002, "{t:?}");
        assert!((t.original.unwrap().motion.total_s - 1.1).abs() <= 0.002);
        assert!(r.set("bogus", Value::Bool(true)).is_err());
    }
}
