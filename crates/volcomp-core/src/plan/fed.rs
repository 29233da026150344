//! The original's machining-time estimate beside a compensation, fed the
//! moves of the compensation's own reading of the original
//! ([`super::compare_while_writing_fed`]): the original is read, lexed
//! and interpreted once, not a second time for its estimate.
//!
//! The writing thread turns each line into the [`Step`]s the estimate's
//! own reading gives ([`steps_of_line`], the function that reading uses)
//! and sends them in chunks through a bounded channel: the memory held
//! stays bounded whatever the program's length. The estimate plans them
//! in its [`Turns`], as it reads the file in [`super::compare_while_writing`].
//!
//! The same steps, so the same estimate to the bit, as long as the lines
//! are the ones the estimate's reader would give: the same set-up reads
//! the same file, but a compensation writes computed values (`X[1/3]`)
//! with the program's decimals (`InterpOptions::computed_decimals`),
//! where the estimate's reader keeps every digit. From the first line
//! with computed values on (`LineEvent::rendered`) the estimate
//! therefore reads the original itself, from its start.

use super::compare::{Stoppable, Turns};
use super::program::{check_limits, estimate_program, steps_of_line, Step};
use super::{Limits, Planner, ProgramEstimate};
use crate::compensate::MachineSetup;
use crate::error::Error;
use std::io::Read;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use volcomp_gcode::LineEvent;

/// Steps sent to the estimate at a time, and how many chunks may wait for
/// it: with a move's step about 130 bytes, at most about 1 MB in flight.
const CHUNK_STEPS: usize = 1024;
pub(super) const CHUNKS_IN_FLIGHT: usize = 8;

/// What the writing thread sends the original's estimate.
pub(super) enum Fed {
    /// The steps of the next lines.
    Steps(Vec<Step>),
    /// A line with computed values: the estimate reads the original itself.
    ReadOriginal,
}

/// The writing thread's end: the steps of the lines it is given, sent in
/// chunks (nothing when there is no original to estimate, or once the
/// estimate reads the original itself).
pub(super) struct Feed<'a> {
    tx: Option<SyncSender<Fed>>,
    steps: Vec<Step>,
    spindle_rpm: f64,
    turns: &'a Turns,
}

impl<'a> Feed<'a> {
    pub(super) fn new(tx: Option<SyncSender<Fed>>, turns: &'a Turns) -> Self {
        let steps = match tx {
            Some(_) => Vec::with_capacity(CHUNK_STEPS),
            None => Vec::new(),
        };
        Feed {
            tx,
            steps,
            spindle_rpm: 0.0,
            turns,
        }
    }

    /// The steps of the original's next line.
    pub(super) fn line(&mut self, ev: &LineEvent<'_>) {
        if self.tx.is_none() {
            return;
        }
        if ev.rendered {
            self.steps.clear();
            self.put(Fed::ReadOriginal);
            self.tx = None;
            return;
        }
        let steps = &mut self.steps;
        steps_of_line(ev, &mut self.spindle_rpm, |s| steps.push(s));
        if self.steps.len() >= CHUNK_STEPS {
            self.send();
        }
    }

    /// Sends the steps kept (at the end of the program, the last of them).
    pub(super) fn send(&mut self) {
        if self.steps.is_empty() || self.tx.is_none() {
            return;
        }
        let full = std::mem::replace(&mut self.steps, Vec::with_capacity(CHUNK_STEPS));
        self.put(Fed::Steps(full));
    }

    fn put(&mut self, msg: Fed) {
        let Some(tx) = &self.tx else {
            return;
        };
        let sent = match tx.try_send(msg) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(msg)) => {
                // The estimate is behind: it may take the idle core while
                // the writing waits for it.
                self.turns.writer_waits(true);
                let sent = tx.send(msg);
                self.turns.writer_waits(false);
                sent.map_err(drop)
            }
            Err(TrySendError::Disconnected(_)) => Err(()),
        };
        if sent.is_err() {
            // The estimate ended (on an error, which is what is reported).
            self.tx = None;
        }
    }
}

/// The original's estimate from the steps `rx` brings until the writing
/// ends, or read from `original` (named `file`) when told to
/// ([`Fed::ReadOriginal`]): [`estimate_program`]'s result.
pub(super) fn estimate_fed<R: Read>(
    rx: Receiver<Fed>,
    original: Stoppable<'_, R>,
    file: &str,
    setup: &MachineSetup,
    limits: &Limits,
    turns: &Turns,
) -> Result<ProgramEstimate, Error> {
    let mut planner = Planner::new(*limits);
    check_limits(planner.limits())?;
    let mut out = ProgramEstimate::default();
    loop {
        turns.original_turn();
        match rx.recv() {
            Ok(Fed::Steps(steps)) => {
                for s in steps {
                    s.apply(&mut planner, &mut out);
                }
            }
            Ok(Fed::ReadOriginal) => return estimate_program(original, file, setup, limits),
            // The writing is done (or failed: then the estimate is not
            // wanted).
            Err(_) => break,
        }
    }
    out.motion = planner.finish();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::{compare_programs, compare_while_writing_fed, TimeComparison};
    use crate::compensate::{Compensator, MachineSetup};
    use crate::model::axis_table::AxisTableMap;
    use std::fmt::Write as _;

    /// A map with slopes: every point is corrected, so the compensated
    /// program's moves are not the original's.
    fn slope_map() -> AxisTableMap {
        let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
        for a in ["X", "Y", "Z"] {
            csv.push_str(&format!("{a},both,-500,0,0,0\n{a},both,500,9,-6,3\n"));
        }
        AxisTableMap::from_csv(&csv, "slope.csv").unwrap()
    }

    /// Rapids, feeds at several rates, arcs, G61 and G64 P, a dwell,
    /// spindle words (waits), feed per revolution, and `zigzag` lines of
    /// more: many chunks of steps, more than the channel holds at once.
    /// `computed` lines with computed values are put in the middle.
    fn program(zigzag: usize, computed: &str) -> String {
        let mut p = String::from("G21 G90 G17 G64\nG0 X0 Y0 Z5\nM3 S1000\nG1 Z0 F300\n");
        for i in 0..zigzag {
            // Within the map's table (±500 mm).
            let y = ((i / 2) % 200) as f64 * 0.25;
            let x = if i % 4 < 2 { 0.0 } else { 40.0 };
            writeln!(p, "G1 X{x:.3} Y{y:.3} F{}", 1500 + 500 * (i % 3)).unwrap();
            if i == zigzag / 2 {
                p += computed;
                p += "G1 X0 Y0\nG61\nG2 X10 Y0 I5 J0\nG3 X20 Y0 R6\nG61.1\nG1 X21\n";
                p += "G4 P0.5\nG64 P0.01\n";
                p += "G95 G1 X45 F0.2\nG94 G0 Z5\nS2000\nG1 Z0 F600\n";
            }
        }
        p + "M5\nM2\n"
    }

    /// The estimates of the original and of its compensation, the
    /// original's fed by the compensation's reading ([`compare_while_writing_fed`]),
    /// and both read whole from the programs ([`compare_programs`]).
    fn fed_and_read(original: &str) -> (TimeComparison, TimeComparison) {
        let map = slope_map();
        let setup = MachineSetup::default();
        let (out, fed) = compare_while_writing_fed(
            "p.ngc",
            Some((Box::new(original.as_bytes()), "o.ngc")),
            &setup,
            |w, on_line| {
                let mut out = Vec::new();
                Compensator::new(&map)
                    .setup(setup.clone())
                    .copy_program_to(w)
                    .on_line(on_line)
                    .run(original.as_bytes(), &mut out)
                    .map(|_| out)
            },
        )
        .unwrap();
        let read = compare_programs(
            (out.as_slice(), "p.ngc"),
            Some((Box::new(original.as_bytes()), "o.ngc")),
            &setup,
        )
        .unwrap();
        (fed.unwrap(), read)
    }

    #[test]
    fn the_original_fed_by_its_reading_times_as_when_read_whole() {
        let (fed, read) = fed_and_read(&program(30_000, ""));
        // Every figure to the bit: the moves, waits, dwells and times.
        assert_eq!(fed, read);
        let o = read.original.unwrap();
        assert!(o.moves > 30_000 && o.waits >= 4, "{o:?}");
        assert!(
            o.dwell_s == 0.5 && o.moves_by_mode.iter().all(|n| *n > 0),
            "{o:?}"
        );
        assert!(o.motion.total_s > 100.0, "{o:?}");
    }

    #[test]
    fn an_original_with_computed_values_is_read_again_for_its_estimate() {
        // The compensation writes `X[10/3]` with the program's decimals;
        // the estimate's reading keeps every digit (3.3333333333333335),
        // so the original is read again from its start, after chunks of
        // steps were sent. A dwell of `P[1/3]`, written `P0.333`, would
        // change the dwell's sum were the compensation's lines planned.
        let computed = "#1=[2/3]\nG1 X[10/3] Y#1 F[1000/3]\nG4 P[1/3]\n";
        let (fed, read) = fed_and_read(&program(20_000, computed));
        assert_eq!(fed, read);
        let o = read.original.unwrap();
        assert!(o.moves > 20_000);
        assert_eq!(o.dwell_s, 0.5 + 1.0 / 3.0);
    }

    #[test]
    fn a_failed_writing_with_a_fed_original_is_reported() {
        let setup = MachineSetup::default();
        let original = program(200, "");
        let got = compare_while_writing_fed(
            "p.ngc",
            Some((Box::new(original.as_bytes()), "o.ngc")),
            &setup,
            |w, _on_line| {
                w.write_all(b"G1 X1 F100\n").unwrap();
                Err::<(), _>("disk full")
            },
        );
        assert_eq!(got.unwrap_err(), "disk full");
    }
}
