//! The original program's machining time from the lines a compensation
//! interprets anyway: the program is then interpreted once, not once for
//! the compensation and once more for its estimate.
//!
//! The compensation hands each interpreted line ([`LineEvent`]) to an
//! [`OriginalFeed`], which copies what the estimate takes of it (the
//! line's waits and units, [`TimedLine`], and its motions) into batches
//! sent through a bounded channel to the estimate's thread, where
//! [`Timing`] plans them as [`super::estimate_program`] plans the lines of
//! its own interpreter: the same code on the same values.
//!
//! Exact only while both interpreters give the same lines. They read the
//! same bytes with the same set-up but for one option: a compensation
//! writes computed values (`X[#1/3]`) with the program's decimals
//! (`InterpOptions::computed_decimals`) where the estimate keeps every
//! digit, so a line rendered from parameters or expressions can move the
//! tool differently. At the first rendered line the feed therefore stops,
//! and the estimate reads and interprets the original itself, from its
//! start; it does so too whenever the feed ends without the program's end
//! (the compensation failed, or the feed was not used).

use super::compare::{Stoppable, Turns};
use super::program::{estimate_program, TimedLine, Timing};
use super::{Limits, ProgramEstimate};
use crate::compensate::MachineSetup;
use crate::error::Error;
use std::io::Read;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use volcomp_gcode::interp::Motion;
use volcomp_gcode::LineEvent;

/// Lines handed over at a time, and how many batches may wait at once:
/// about 2 MiB held whatever the program's length. Few hand-overs: each
/// may wake the estimate's thread, which costs the compensation's.
const FEED_LINES: usize = 1024;
pub(super) const BATCHES_IN_FLIGHT: usize = 3;

/// Lines of the program: what the estimate takes of each line, and the
/// motions of all of them in order (`motions` of each line in turn).
#[derive(Default)]
pub(super) struct Batch {
    lines: Vec<(TimedLine, u32)>,
    motions: Vec<Motion>,
}

impl Batch {
    fn with_capacity(lines: usize) -> Self {
        Self {
            lines: Vec::with_capacity(lines),
            motions: Vec::with_capacity(lines + lines / 4),
        }
    }
}

/// What the feed sends: lines, then the end of the program.
pub(super) enum Fed {
    Lines(Batch),
    /// The program ended: every line was sent.
    End,
}

/// Hands a compensation's interpreted lines to the estimate of the
/// original program (see the [module doc](self)).
pub struct OriginalFeed<'a> {
    /// `None` once the feed stopped (a rendered line, or the estimate
    /// no longer reads).
    tx: Option<SyncSender<Fed>>,
    /// Batches planned, back to be filled again (no allocation, and no
    /// fresh pages, per batch).
    empty: Option<Receiver<Batch>>,
    batch: Batch,
    turns: &'a Turns,
}

/// Takes the lines a compensation interprets, in order (see
/// `Compensator::feed_lines_to`).
pub trait LineFeed {
    /// The next line, as the interpreter gave it.
    fn line(&mut self, ev: &LineEvent<'_>);
    /// The program ended: every line was given.
    fn end(&mut self);
}

impl LineFeed for OriginalFeed<'_> {
    fn line(&mut self, ev: &LineEvent<'_>) {
        OriginalFeed::line(self, ev);
    }

    fn end(&mut self) {
        OriginalFeed::end(self);
    }
}

impl<'a> OriginalFeed<'a> {
    pub(super) fn new(tx: Option<(SyncSender<Fed>, Receiver<Batch>)>, turns: &'a Turns) -> Self {
        let (tx, empty) = tx.unzip();
        Self {
            tx,
            empty,
            batch: Batch::with_capacity(FEED_LINES),
            turns,
        }
    }

    /// Runs `f` with a feed that goes nowhere (no original is estimated).
    pub fn unused<T>(f: impl FnOnce(&mut OriginalFeed<'_>) -> T) -> T {
        let turns = Turns::default();
        f(&mut OriginalFeed::new(None, &turns))
    }

    /// The next line the compensation interpreted.
    pub fn line(&mut self, ev: &LineEvent<'_>) {
        if self.tx.is_none() {
            return;
        }
        if ev.rendered {
            // Not surely the line the estimate's interpreter would give:
            // the estimate reads the program itself.
            self.tx = None;
            return;
        }
        if let Some(l) = TimedLine::of(ev) {
            self.batch.lines.push((l, ev.motions.len() as u32));
            self.batch.motions.extend_from_slice(ev.motions);
            if self.batch.lines.len() >= FEED_LINES {
                let empty = match self.empty.as_ref().map(Receiver::try_recv) {
                    Some(Ok(b)) => b,
                    _ => Batch::with_capacity(FEED_LINES),
                };
                let full = std::mem::replace(&mut self.batch, empty);
                self.send(Fed::Lines(full));
            }
        }
    }

    /// The program ended: every line was given to [`OriginalFeed::line`].
    /// Without it the estimate reads the program itself.
    pub fn end(&mut self) {
        if self.tx.is_some() {
            let last = std::mem::take(&mut self.batch);
            if !last.lines.is_empty() {
                self.send(Fed::Lines(last));
            }
            self.send(Fed::End);
        }
        self.tx = None;
    }

    fn send(&mut self, fed: Fed) {
        let Some(tx) = &self.tx else {
            return;
        };
        let sent = match tx.try_send(fed) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(fed)) => {
                // The estimate waits for its turn: it may take it while
                // the compensation waits for it.
                self.turns.writer_waits(true);
                let sent = tx.send(fed);
                self.turns.writer_waits(false);
                sent.map_err(drop)
            }
            Err(TrySendError::Disconnected(_)) => Err(()),
        };
        if sent.is_err() {
            // The estimate ended (on an error, which it reports).
            self.tx = None;
        }
    }
}

/// The original's estimate from the lines `rx` receives, in its
/// [`Turns`]; from `original` itself when the feed stops short of the
/// program's end.
pub(super) fn estimate_fed<R: Read>(
    (rx, empty): (Receiver<Fed>, SyncSender<Batch>),
    original: Stoppable<'_, R>,
    (name, setup, limits): (&str, &MachineSetup, &Limits),
) -> Result<ProgramEstimate, Error> {
    let mut timing = Timing::new(limits)?;
    while let Ok(fed) = rx.recv() {
        match fed {
            Fed::Lines(mut batch) => {
                original.turns.original_turn();
                if original.stopped() {
                    break;
                }
                let mut motions_at = 0;
                for (line, n) in &batch.lines {
                    let end = motions_at + *n as usize;
                    timing.timed_line(line, &batch.motions[motions_at..end]);
                    motions_at = end;
                }
                batch.lines.clear();
                batch.motions.clear();
                // Dropped when the feed has enough.
                let _ = empty.try_send(batch);
            }
            Fed::End => return Ok(timing.finish()),
        }
    }
    drop(rx);
    estimate_program(original, name, setup, limits)
}

#[cfg(test)]
mod tests {
    use super::super::compare::{compare_programs, compare_while_compensating, TimeComparison};
    use crate::compensate::MachineSetup;
    use crate::compensate::{CompensateSummary, Compensator};
    use crate::model::axis_table::AxisTableMap;

    /// A map with slopes: every point corrected.
    fn slope_map() -> AxisTableMap {
        let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
        for a in ["X", "Y", "Z"] {
            csv.push_str(&format!("{a},both,-100,0,0,0\n{a},both,200,9,-6,3\n"));
        }
        AxisTableMap::from_csv(&csv, "slope.csv").unwrap()
    }

    /// Corners, arcs, every path mode, waits (S, M3, G4, M0), inverse-time
    /// and per-revolution feeds, inch and mm, over many feed batches.
    fn program(expression: bool) -> String {
        let mut p = String::from("%\n(a part)\nG21 G90 G17 G64\nG0 X0 Y0 Z1\nG1 Z0 F300\n");
        for i in 0..700 {
            let y = i as f64 * 0.1;
            p += &format!("G1 X{} Y{y:.1} F{}\n", [0, 60][i % 2], [1200, 3000][i % 2]);
            p += &format!("G3 X{} Y{:.2} R0.05\n", [0, 60][i % 2], y + 0.05);
            if i == 350 && expression {
                p += "#1 = 0.3\nG1 X[#1/3] Y70.1\n";
            }
        }
        p += "M3 S1000\nG61\nG1 X10 Y10\nG4 P0.5\nG2 X20 Y10 I5 J0\nG64 P0.01 Q0.005\n";
        p += "G93 G1 X30 F20\nG95 G1 X40 F0.2\nG94 G61.1 G20 G1 X2 F40\nM0\nG21 G0 Z5\nM2\n%\n";
        p
    }

    /// The comparison `compensate` makes: the compensated program's
    /// estimate and its original's beside the compensation, the original
    /// read from `original`.
    fn while_compensating(
        program: &str,
        original: Box<dyn std::io::Read + Send + '_>,
    ) -> (Vec<u8>, Result<TimeComparison, crate::Error>) {
        let (map, setup) = (slope_map(), MachineSetup::default());
        let (written, time) =
            compare_while_compensating("out.ngc", Some((original, "p.ngc")), &setup, |w, feed| {
                let mut out = Vec::new();
                Compensator::new(&map)
                    .copy_program_to(w)
                    .feed_lines_to(feed)
                    .run(program.as_bytes(), &mut out)
                    .map(|_: CompensateSummary| out)
            })
            .unwrap();
        (written, time)
    }

    /// A reader that fails: the original is not read.
    struct Unread;

    impl std::io::Read for Unread {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            Err(std::io::Error::other("the original was read"))
        }
    }

    #[test]
    fn the_original_fed_by_the_compensation_times_as_when_read_and_is_not_read_again() {
        let p = program(false);
        // The original is not read: its estimate comes from the lines.
        let (written, fed) = while_compensating(&p, Box::new(Unread));
        // The second method: both programs read and interpreted whole.
        let setup = MachineSetup::default();
        let read = compare_programs(
            (written.as_slice(), "out.ngc"),
            Some((Box::new(p.as_bytes()), "p.ngc")),
            &setup,
        )
        .unwrap();
        let fed = fed.unwrap();
        assert_eq!(fed, read);
        let o = read.original.unwrap();
        // M3 S1000 and G4 wait before their line, M0 after it.
        assert!(o.moves > 1400 && o.waits >= 3 && o.dwell_s == 0.5, "{o:?}");
        assert_eq!(o.moves_by_mode.iter().filter(|&&n| n > 0).count(), 3);
    }

    #[test]
    fn a_rendered_line_makes_the_estimate_read_the_original_itself() {
        let p = program(true);
        // The original must be read: computed values are written with the
        // program's decimals by the compensation, not by the estimate.
        let (_, fed) = while_compensating(&p, Box::new(Unread));
        assert!(fed
            .unwrap_err()
            .to_string()
            .contains("the original was read"));
        let (written, fed) = while_compensating(&p, Box::new(p.as_bytes()));
        let setup = MachineSetup::default();
        let read = compare_programs(
            (written.as_slice(), "out.ngc"),
            Some((Box::new(p.as_bytes()), "p.ngc")),
            &setup,
        )
        .unwrap();
        assert_eq!(fed.unwrap(), read);
    }

    #[test]
    fn a_failed_compensation_is_reported_with_the_fed_estimate_stopped() {
        // Refused at its last line, after many batches were fed.
        let mut p = program(false);
        p.insert_str(p.len() - 5, "G1 X1 Y\n");
        let (map, setup) = (slope_map(), MachineSetup::default());
        let got = compare_while_compensating(
            "out.ngc",
            Some((Box::new(p.as_bytes()), "p.ngc")),
            &setup,
            |w, feed| {
                Compensator::new(&map)
                    .file_name("p.ngc")
                    .copy_program_to(w)
                    .feed_lines_to(feed)
                    .run(p.as_bytes(), Vec::new())
            },
        );
        let e = got.unwrap_err().to_string();
        let line = p.lines().count() - 2;
        assert!(e.starts_with(&format!("p.ngc:{line}:")), "{e}");
    }
}
