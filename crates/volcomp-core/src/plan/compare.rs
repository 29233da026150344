//! A program's estimated machining time, alone or beside the program it
//! was made from, in the words a summary, a report and a JSON output
//! share.

use super::{estimate_program, Limits, ProgramEstimate};
use crate::compensate::MachineSetup;
use crate::error::Error;
use std::io::Read;

/// The estimated time of a program and, when given, of its original.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct TimeComparison {
    /// The limits the planner ran with.
    pub limits: Limits,
    /// Whether they come from the set-up's `[limits]` (else defaults).
    pub limits_from_setup: bool,
    /// The program (the compensated one, when there is an original).
    pub program: ProgramEstimate,
    /// The program it was made from.
    pub original: Option<ProgramEstimate>,
}

/// Relative change `new/old − 1`, `None` when `old` is zero.
fn change(new: f64, old: f64) -> Option<f64> {
    (old > 0.0).then(|| new / old - 1.0)
}

fn pct(c: Option<f64>) -> String {
    c.map_or_else(|| "—".into(), |c| format!("{:+.1} %", c * 100.0))
}

impl TimeComparison {
    /// Whole-program time of the program over its original's, minus one.
    pub fn change(&self) -> Option<f64> {
        let o = self.original?;
        change(self.program.motion.total_s, o.motion.total_s)
    }

    /// Cutting time of the program over its original's, minus one.
    pub fn cutting_change(&self) -> Option<f64> {
        let o = self.original?;
        change(self.program.motion.cutting_s, o.motion.cutting_s)
    }

    /// Where the limits come from, in words.
    pub fn limits_note(&self) -> String {
        let src = if self.limits_from_setup {
            "from the set-up's [limits]"
        } else {
            "defaults: the set-up has no [limits]; give the machine's for a true estimate"
        };
        format!("{} ({src})", self.limits.describe())
    }

    /// The summary as `(label, text)` rows: the times, dwells when there
    /// are any, the planner and its limits.
    pub fn rows(&self) -> Vec<(&'static str, String)> {
        let p = &self.program;
        let mut rows = Vec::new();
        rows.push((
            "machining time",
            match &self.original {
                Some(o) => format!(
                    "{:.3} s -> {:.3} s ({}), cutting {:.3} s -> {:.3} s ({})",
                    o.motion.total_s,
                    p.motion.total_s,
                    pct(self.change()),
                    o.motion.cutting_s,
                    p.motion.cutting_s,
                    pct(self.cutting_change())
                ),
                None => format!(
                    "{:.3} s (cutting {:.3} s, rapids {:.3} s)",
                    p.motion.total_s, p.motion.cutting_s, p.motion.rapid_s
                ),
            },
        ));
        if p.dwell_s > 0.0 {
            rows.push(("dwells", format!("{:.3} s more (G4)", p.dwell_s)));
        }
        rows.push((
            "planner model",
            format!("LinuxCNC 2.9's trajectory planner, {}", self.limits_note()),
        ));
        rows
    }

    /// The summary in lines of text, `label: text`.
    pub fn summary_lines(&self) -> Vec<String> {
        self.rows()
            .into_iter()
            .map(|(label, text)| format!("{label}: {text}"))
            .collect()
    }
}

/// Estimates `program` and, when given, `original` (both read with
/// `setup`; the limits from its `[limits]`, else [`Limits::default`]).
/// The original is estimated on a second thread meanwhile: the same CPU
/// time, about half the wait on a machine with two cores.
pub fn compare_programs(
    program: (impl Read, &str),
    original: Option<(Box<dyn Read + Send + '_>, &str)>,
    setup: &MachineSetup,
) -> Result<TimeComparison, Error> {
    let given = setup.setup.limits.as_ref();
    let limits = Limits::from_setup(given);
    let (program, original) = std::thread::scope(|scope| {
        let original = original
            .map(|(r, name)| scope.spawn(move || estimate_program(r, name, setup, &limits)));
        let program = estimate_program(program.0, program.1, setup, &limits);
        let original = original.map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)));
        (program, original)
    });
    let original = original.transpose()?;
    Ok(TimeComparison {
        limits,
        limits_from_setup: given.is_some(),
        program: program?,
        original,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slower_program_reads_as_a_positive_change() {
        let setup = MachineSetup::default();
        let slow = "G21 G90\nG0 X0 Y0 Z0\nG1 X100 F3000\nM2\n";
        let fast = "G21 G90\nG0 X0 Y0 Z0\nG1 X100 F6000\nM2\n";
        let t = compare_programs(
            (slow.as_bytes(), "slow.ngc"),
            Some((Box::new(fast.as_bytes()), "fast.ngc")),
            &setup,
        )
        .unwrap();
        // G64: 100 mm at a/2 = 500 mm/s²: 2.1 s at 50 mm/s, 1.2 s at 100.
        assert!((t.program.motion.cutting_s - 2.1).abs() < 0.003, "{t:?}");
        assert!((t.original.unwrap().motion.cutting_s - 1.2).abs() < 0.003);
        assert!((t.cutting_change().unwrap() - 0.75).abs() < 0.01);
        let lines = t.summary_lines();
        assert!(
            lines[0].starts_with("machining time: 1.200 s -> 2.100 s (+75.0 %)"),
            "{lines:?}"
        );
        assert!(lines[1].contains("no [limits]"), "{lines:?}");
    }
}
