//! How far a long computation has come, for a front end to show (a
//! progress bar on a terminal, a percentage in a GUI). The library only
//! counts; it never draws, and it calls a [`Progress`] often enough to be
//! smooth but cheaply: readers every [`READ_STEP`] bytes, loops once per
//! unit of work.

use std::io::{BufRead, Read};

/// Receives the progress of one piece of work.
pub trait Progress {
    /// The work starts: `total` units (bytes, points, draws), when known.
    fn start(&mut self, _task: &str, _total: Option<u64>) {}
    /// `done` units of the total are done (never decreasing).
    fn advance_to(&mut self, done: u64);
}

impl<P: Progress + ?Sized> Progress for &mut P {
    fn start(&mut self, task: &str, total: Option<u64>) {
        (**self).start(task, total);
    }
    fn advance_to(&mut self, done: u64) {
        (**self).advance_to(done);
    }
}

/// Progress nobody watches.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {
    fn advance_to(&mut self, _done: u64) {}
}

/// Bytes read between two reports of a [`Counted`] reader.
pub const READ_STEP: u64 = 1 << 16;

/// A reader that reports the bytes read so far, every [`READ_STEP`] bytes
/// and at its end: the progress of any work that reads one input
/// front to back (compensation, simulation, a finishing program).
pub struct Counted<R, P> {
    inner: R,
    done: u64,
    reported: u64,
    progress: P,
}

impl<R, P: Progress> Counted<R, P> {
    /// Counts what is read from `inner`.
    pub fn new(inner: R, progress: P) -> Self {
        Self {
            inner,
            done: 0,
            reported: 0,
            progress,
        }
    }

    fn count(&mut self, n: usize) {
        self.done += n as u64;
        if n == 0 || self.done - self.reported >= READ_STEP {
            self.reported = self.done;
            self.progress.advance_to(self.done);
        }
    }
}

impl<R: Read, P: Progress> Read for Counted<R, P> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if !buf.is_empty() {
            self.count(n);
        }
        Ok(n)
    }
}

impl<R: BufRead, P: Progress> BufRead for Counted<R, P> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }
    fn consume(&mut self, amt: usize) {
        self.inner.consume(amt);
        self.count(amt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct Log(Vec<u64>);
    impl Progress for Log {
        fn advance_to(&mut self, done: u64) {
            self.0.push(done);
        }
    }

    #[test]
    fn a_counted_reader_reports_every_step_and_the_end() {
        let data = vec![b'x'; 200_000];
        let mut log = Log::default();
        let mut out = Vec::new();
        std::io::copy(&mut Counted::new(data.as_slice(), &mut log), &mut out).unwrap();
        assert_eq!(out.len(), 200_000);
        // Reports at least every 65 536 bytes, increasing, ending at the
        // whole length (the read that returns 0 marks the end).
        assert!(log.0.len() >= 3, "{:?}", log.0);
        assert!(log
            .0
            .windows(2)
            .all(|w| w[0] <= w[1] && w[1] - w[0] <= READ_STEP + 8192));
        assert_eq!(*log.0.last().unwrap(), 200_000);
    }
}
