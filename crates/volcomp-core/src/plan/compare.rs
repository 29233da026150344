//! A program's estimated machining time, alone or beside the program it
//! was made from, in the words a summary, a report and a JSON output
//! share.

use super::{estimate_program, estimate_program_per_line, Limits, LineTime, ProgramEstimate};
use crate::compensate::MachineSetup;
use crate::error::Error;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError, TrySendError};
use std::sync::{Condvar, Mutex};
use volcomp_gcode::LineEvent;

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
    compare(program, original, setup, false).map(|(t, _)| t)
}

/// [`compare_programs`], and the program's time per line
/// ([`estimate_program_per_line`]; the original's is not broken down).
pub fn compare_programs_per_line(
    program: (impl Read, &str),
    original: Option<(Box<dyn Read + Send + '_>, &str)>,
    setup: &MachineSetup,
) -> Result<(TimeComparison, Vec<LineTime>), Error> {
    compare(program, original, setup, true)
}

/// [`compare_programs`], with the program's time per line when
/// `per_line` (else none).
fn compare(
    program: (impl Read, &str),
    original: Option<(Box<dyn Read + Send + '_>, &str)>,
    setup: &MachineSetup,
    per_line: bool,
) -> Result<(TimeComparison, Vec<LineTime>), Error> {
    let limits = Limits::from_setup(setup.setup.limits.as_ref());
    let (program, original) = std::thread::scope(|scope| {
        let original = original
            .map(|(r, name)| scope.spawn(move || estimate_program(r, name, setup, &limits)));
        let program = if per_line {
            estimate_program_per_line(program.0, program.1, setup, &limits)
        } else {
            estimate_program(program.0, program.1, setup, &limits).map(|e| (e, Vec::new()))
        };
        (program, original.map(joined))
    });
    let (program, lines) = match program {
        Ok((p, l)) => (Ok(p), l),
        Err(e) => (Err(e), Vec::new()),
    };
    Ok((comparison(setup, program, original)?, lines))
}

/// Estimates the program `write` writes (named `name`) while it is being
/// written, and, when given, its `original`, each on a thread of its own
/// beside the writing. The written bytes reach the estimate in chunks of
/// fixed size through a bounded channel, so the memory held stays bounded
/// whatever the program's length. While the writing goes on the two
/// estimates take turns (see [`Turns`]): together they keep to one core,
/// and the writing, which the estimate of its program follows, keeps the
/// other of a two-core machine to itself; once it is done both run at
/// once. When `write` fails the estimates are stopped and its error
/// returned.
pub fn compare_while_writing<T, E>(
    name: &str,
    original: Option<(Box<dyn Read + Send + '_>, &str)>,
    setup: &MachineSetup,
    write: impl FnOnce(&mut dyn Write) -> Result<T, E>,
) -> Result<(T, Result<TimeComparison, Error>), E> {
    while_writing(name, original, setup, false, |w, _| write(w))
}

/// [`compare_while_writing`] where `write` also reads the original with
/// the estimate's set-up and gives each of its lines, as
/// [`volcomp_gcode::Walker`] read it, to the function it is handed (a
/// compensation does: [`crate::compensate::Compensator::on_line`]). The
/// original's estimate plans the moves of those lines instead of reading
/// and interpreting the original again ([`super::fed`]); from a line
/// with computed values on (which its reader may have written with other
/// decimals) it reads the original itself from the start. `write` must
/// give every line of the original, in order, when it succeeds.
pub fn compare_while_writing_fed<T, E>(
    name: &str,
    original: Option<(Box<dyn Read + Send + '_>, &str)>,
    setup: &MachineSetup,
    write: impl FnOnce(&mut dyn Write, &mut dyn FnMut(&LineEvent<'_>)) -> Result<T, E>,
) -> Result<(T, Result<TimeComparison, Error>), E> {
    while_writing(name, original, setup, true, write)
}

/// [`compare_while_writing`], the original's estimate fed by `write`'s
/// lines when `fed` ([`compare_while_writing_fed`]).
fn while_writing<T, E>(
    name: &str,
    original: Option<(Box<dyn Read + Send + '_>, &str)>,
    setup: &MachineSetup,
    fed: bool,
    write: impl FnOnce(&mut dyn Write, &mut dyn FnMut(&LineEvent<'_>)) -> Result<T, E>,
) -> Result<(T, Result<TimeComparison, Error>), E> {
    let limits = Limits::from_setup(setup.setup.limits.as_ref());
    let stop = AtomicBool::new(false);
    let turns = Turns::default();
    let (tx, rx) = sync_channel(CHUNKS_IN_FLIGHT);
    let (lines_tx, lines_rx) = sync_channel(super::fed::CHUNKS_IN_FLIGHT);
    let lines_tx = (fed && original.is_some()).then_some(lines_tx);
    let (written, program, original) = std::thread::scope(|scope| {
        let (stop, turns) = (&stop, &turns);
        // However the writing ends (a panic included), the original's
        // estimate no longer waits for turns.
        let _writing = WritingDone(turns);
        let original = original.map(|(r, name)| {
            let r = Stoppable {
                inner: r,
                stop,
                turns,
            };
            let limits = &limits;
            scope.spawn(move || match fed {
                true => super::fed::estimate_fed(lines_rx, r, name, setup, limits, turns),
                false => estimate_program(r, name, setup, limits),
            })
        });
        let program = scope.spawn(move || {
            let r = ChunkReader {
                rx,
                chunk: Vec::new(),
                at: 0,
                turns,
            };
            estimate_program(r, name, setup, &limits)
        });
        let mut sink = ChunkWriter {
            tx: Some(tx),
            buf: Vec::with_capacity(CHUNK_BYTES),
            turns,
        };
        let mut feed = super::fed::Feed::new(lines_tx, turns);
        let written = write(&mut sink, &mut |ev| feed.line(ev));
        if written.is_ok() {
            sink.send();
            feed.send();
        } else {
            stop.store(true, Ordering::Relaxed);
        }
        // The end of the program: the estimates read to here.
        drop(sink);
        drop(feed);
        turns.writing_done();
        (written, joined(program), original.map(joined))
    });
    Ok((written?, comparison(setup, program, original)))
}

/// The result of an estimate's thread (its panic goes on in this one).
fn joined<T>(h: std::thread::ScopedJoinHandle<'_, T>) -> T {
    h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
}

fn comparison(
    setup: &MachineSetup,
    program: Result<ProgramEstimate, Error>,
    original: Option<Result<ProgramEstimate, Error>>,
) -> Result<TimeComparison, Error> {
    let given = setup.setup.limits.as_ref();
    let original = original.transpose()?;
    Ok(TimeComparison {
        limits: Limits::from_setup(given),
        limits_from_setup: given.is_some(),
        program: program?,
        original,
    })
}

/// The size of the chunks a program being written is estimated in, and
/// how many may wait for the estimate at once.
const CHUNK_BYTES: usize = 64 * 1024;
const CHUNKS_IN_FLIGHT: usize = 4;

/// Collects written bytes into chunks and sends each when full. Once the
/// estimate no longer reads (it ended on an error), the bytes are
/// dropped: the writing goes on, the estimate's error is what is reported.
struct ChunkWriter<'a> {
    tx: Option<SyncSender<Vec<u8>>>,
    buf: Vec<u8>,
    turns: &'a Turns,
}

impl ChunkWriter<'_> {
    fn send(&mut self) {
        if self.buf.is_empty() {
            return;
        }
        let full = std::mem::replace(&mut self.buf, Vec::with_capacity(CHUNK_BYTES));
        let Some(tx) = &self.tx else {
            return;
        };
        let sent = match tx.try_send(full) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(full)) => {
                // The estimate is behind: while the writing waits for
                // it, the original's estimate may take the idle core.
                self.turns.writer_waits(true);
                let sent = tx.send(full);
                self.turns.writer_waits(false);
                sent.map_err(drop)
            }
            Err(TrySendError::Disconnected(_)) => Err(()),
        };
        if sent.is_err() {
            self.tx = None;
        }
    }
}

impl Write for ChunkWriter<'_> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        if self.tx.is_some() {
            self.buf.extend_from_slice(bytes);
            if self.buf.len() >= CHUNK_BYTES {
                self.send();
            }
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Which of the two estimates beside a writing runs: the written
/// program's whenever it has bytes to read, the original's only while
/// that one waits for the writing, until the writing is done (then both).
///
/// Three busy threads on two cores get two thirds of a core each, so
/// the writing, which the written program's estimate follows, would run
/// at two thirds of its speed for as long as the original's estimate
/// runs; taking turns, the estimates share one core (they need less
/// time than the writing) and the writing keeps the other.
#[derive(Default)]
pub(super) struct Turns {
    state: Mutex<TurnState>,
    changed: Condvar,
}

#[derive(Default)]
struct TurnState {
    /// The written program's estimate has bytes to read.
    program_busy: bool,
    /// The writing waits for the written program's estimate (its chunks
    /// in flight are full): the original's estimate may run meanwhile.
    writer_waits: bool,
    /// The writing is done (or failed): no more turns.
    writing_done: bool,
}

impl Turns {
    fn lock(&self) -> std::sync::MutexGuard<'_, TurnState> {
        // A thread that panicked holding the lock left plain flags,
        // valid as they are.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The written program's estimate has bytes to read (`true`) or
    /// waits for the writing (`false`).
    fn program_busy(&self, busy: bool) {
        let mut s = self.lock();
        if s.program_busy != busy {
            s.program_busy = busy;
            if !busy {
                self.changed.notify_all();
            }
        }
    }

    /// The writing waits for the written program's estimate (`true`), or
    /// no longer.
    pub(super) fn writer_waits(&self, waits: bool) {
        self.lock().writer_waits = waits;
        if waits {
            self.changed.notify_all();
        }
    }

    fn writing_done(&self) {
        self.lock().writing_done = true;
        self.changed.notify_all();
    }

    /// Waits until the original's estimate may run.
    pub(super) fn original_turn(&self) {
        let mut s = self.lock();
        while s.program_busy && !s.writer_waits && !s.writing_done {
            s = self.changed.wait(s).unwrap_or_else(|p| p.into_inner());
        }
    }
}

/// Ends the turns when dropped (the writing returned or unwound).
struct WritingDone<'a>(&'a Turns);

impl Drop for WritingDone<'_> {
    fn drop(&mut self) {
        self.0.writing_done();
    }
}

/// Reads the chunks a [`ChunkWriter`] sends, to the end of the program
/// (the writer dropped), telling the [`Turns`] whether it has bytes.
struct ChunkReader<'a> {
    rx: Receiver<Vec<u8>>,
    chunk: Vec<u8>,
    at: usize,
    turns: &'a Turns,
}

impl Drop for ChunkReader<'_> {
    fn drop(&mut self) {
        // The estimate ended (or failed): it reads no more.
        self.turns.program_busy(false);
    }
}

impl Read for ChunkReader<'_> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        while self.at == self.chunk.len() {
            let chunk = match self.rx.try_recv() {
                Ok(c) => Ok(c),
                Err(TryRecvError::Empty) => {
                    self.turns.program_busy(false);
                    self.rx.recv().map_err(|_| ())
                }
                Err(TryRecvError::Disconnected) => Err(()),
            };
            match chunk {
                Ok(c) => {
                    self.turns.program_busy(true);
                    (self.chunk, self.at) = (c, 0);
                }
                Err(()) => {
                    self.turns.program_busy(false);
                    return Ok(0);
                }
            }
        }
        let n = out.len().min(self.chunk.len() - self.at);
        out[..n].copy_from_slice(&self.chunk[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// The original's reader beside a writing: it reads in its [`Turns`],
/// and fails once `stop` is set (the writing failed: its estimate is not
/// wanted).
pub(super) struct Stoppable<'a, R> {
    inner: R,
    stop: &'a AtomicBool,
    turns: &'a Turns,
}

impl<R: Read> Read for Stoppable<'_, R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        self.turns.original_turn();
        if self.stop.load(Ordering::Relaxed) {
            return Err(std::io::Error::other("the estimate was stopped"));
        }
        self.inner.read(out)
    }
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

    /// A program of many lines (over several chunks), written in pieces
    /// of uneven sizes.
    fn zigzag(lines: usize) -> String {
        let mut p = String::from("G21 G90 G64\nG0 X0 Y0 Z0\n");
        for i in 0..lines {
            let y = (i / 2) as f64 * 0.5;
            let x = if i % 4 < 2 { 0.0 } else { 80.0 };
            p += &format!("G1 X{x:.3} Y{y:.3} F{}\n", 1500 + 500 * (i % 3));
        }
        p + "M2\n"
    }

    #[test]
    fn a_program_estimated_while_written_times_as_when_read_whole() {
        let setup = MachineSetup::default();
        let program = zigzag(20_000);
        let original = zigzag(2_000);
        assert!(program.len() > 4 * CHUNK_BYTES);
        let whole = compare_programs(
            (program.as_bytes(), "p.ngc"),
            Some((Box::new(original.as_bytes()), "o.ngc")),
            &setup,
        )
        .unwrap();
        let (n, streamed) = compare_while_writing(
            "p.ngc",
            Some((Box::new(original.as_bytes()), "o.ngc")),
            &setup,
            |w| {
                let mut rest = program.as_bytes();
                let mut k = 0;
                while !rest.is_empty() {
                    k += 1;
                    let n = (k * 7919 % 3001).min(rest.len());
                    w.write_all(&rest[..n])?;
                    rest = &rest[n..];
                }
                Ok::<_, std::io::Error>(k)
            },
        )
        .unwrap();
        assert!(n > 100);
        assert_eq!(streamed.unwrap(), whole);
        assert!(whole.program.motion.total_s > 10.0 * whole.original.unwrap().motion.total_s);
    }

    #[test]
    fn the_original_waits_while_the_written_program_has_bytes_until_the_writing_is_done() {
        use std::sync::mpsc::channel;
        use std::time::Duration;
        let turns = Turns::default();
        // Nothing written yet: the original's turn.
        turns.original_turn();
        std::thread::scope(|scope| {
            let (go, go_rx) = channel::<()>();
            let (ran, ran_rx) = channel();
            let turns = &turns;
            // The original's estimate: a turn each time it is told to try.
            scope.spawn(move || {
                for k in 1..=3 {
                    go_rx.recv().unwrap();
                    turns.original_turn();
                    ran.send(k).unwrap();
                }
            });
            let short = Duration::from_millis(50);
            turns.program_busy(true);
            go.send(()).unwrap();
            assert!(
                ran_rx.recv_timeout(short).is_err(),
                "ran beside a busy estimate"
            );
            turns.program_busy(false);
            assert_eq!(ran_rx.recv().unwrap(), 1);
            // Busy again, but the writing waits for it: the original runs.
            turns.program_busy(true);
            turns.writer_waits(true);
            go.send(()).unwrap();
            assert_eq!(ran_rx.recv().unwrap(), 2);
            turns.writer_waits(false);
            go.send(()).unwrap();
            assert!(
                ran_rx.recv_timeout(short).is_err(),
                "ran beside a busy estimate"
            );
            turns.writing_done();
            assert_eq!(ran_rx.recv().unwrap(), 3);
        });
    }

    #[test]
    fn a_failed_writing_is_reported_and_its_estimates_stopped() {
        let setup = MachineSetup::default();
        let original = zigzag(200_000);
        let got = compare_while_writing(
            "p.ngc",
            Some((Box::new(original.as_bytes()), "o.ngc")),
            &setup,
            |w| {
                w.write_all(zigzag(10).as_bytes()).unwrap();
                Err::<(), _>("disk full")
            },
        );
        assert_eq!(got.unwrap_err(), "disk full");
    }
}
