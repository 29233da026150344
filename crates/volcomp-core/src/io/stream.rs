//! Helpers for a program streamed from reader to writer: a reader that
//! reads ahead on its own thread, a writer that keeps a copy of what
//! passes, and the progress a LinuxCNC filter reports.

use std::io::{BufRead, Write};
use std::path::Path;

/// A writer that also keeps a copy of what passes through it (when `copy`
/// is given) and hands it on to a second writer (when `stream` is given:
/// a machining-time estimate made while the program is written).
pub struct Tee<'a, 'b, 'c> {
    /// Where the bytes go.
    pub inner: &'a mut dyn Write,
    /// The copy, if one is kept.
    pub copy: Option<&'b mut Vec<u8>>,
    /// The second writer, if any.
    pub stream: Option<&'c mut dyn Write>,
}

impl Write for Tee<'_, '_, '_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        if let Some(c) = self.copy.as_mut() {
            c.extend_from_slice(&buf[..n]);
        }
        if let Some(s) = self.stream.as_mut() {
            s.write_all(&buf[..n])?;
        }
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Bytes read at a time by [`ReadAhead`].
const READ_AHEAD_CHUNK_BYTES: usize = 1 << 16;
/// Chunks [`ReadAhead`] reads before they are asked for.
const READ_AHEAD_CHUNKS: usize = 4;

/// A reader whose source is read on a thread of its own, up to
/// [`READ_AHEAD_CHUNKS`] chunks of [`READ_AHEAD_CHUNK_BYTES`] ahead: the
/// thread that uses the bytes (the interpreter) does not wait for the
/// system's reads and copies. What it yields, errors included, is what the
/// source yields, in order; after an error or the end it yields nothing
/// more. Chunks are handed back to be filled again (no allocation per
/// chunk); dropping the reader stops the thread at its next chunk.
pub struct ReadAhead {
    chunks: std::sync::mpsc::Receiver<std::io::Result<Vec<u8>>>,
    spent: std::sync::mpsc::SyncSender<Vec<u8>>,
    chunk: Vec<u8>,
    at: usize,
    done: bool,
}

impl ReadAhead {
    /// Starts reading `source` on a new thread.
    pub fn new<R: std::io::Read + Send + 'static>(mut source: R) -> ReadAhead {
        let (tx, chunks) = std::sync::mpsc::sync_channel(READ_AHEAD_CHUNKS);
        let (spent, spent_rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(READ_AHEAD_CHUNKS + 2);
        std::thread::spawn(move || loop {
            let mut buf = spent_rx.try_recv().unwrap_or_default();
            buf.resize(READ_AHEAD_CHUNK_BYTES, 0);
            let read = loop {
                match source.read(&mut buf) {
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    r => break r,
                }
            };
            let last = !matches!(read, Ok(n) if n > 0);
            let sent = tx.send(read.map(|n| {
                buf.truncate(n);
                buf
            }));
            if last || sent.is_err() {
                return;
            }
        });
        ReadAhead {
            chunks,
            spent,
            chunk: Vec::new(),
            at: 0,
            done: false,
        }
    }
}

impl std::io::BufRead for ReadAhead {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at == self.chunk.len() && !self.done {
            let used = std::mem::take(&mut self.chunk);
            if used.capacity() > 0 {
                let _ = self.spent.try_send(used);
            }
            self.at = 0;
            match self.chunks.recv() {
                Ok(Ok(chunk)) => {
                    self.done = chunk.is_empty();
                    self.chunk = chunk;
                }
                Ok(Err(e)) => {
                    self.done = true;
                    return Err(e);
                }
                Err(_) => {
                    self.done = true;
                    return Err(std::io::Error::other("the thread reading ahead stopped"));
                }
            }
        }
        Ok(&self.chunk[self.at..])
    }

    fn consume(&mut self, n: usize) {
        self.at = (self.at + n).min(self.chunk.len());
    }
}

impl std::io::Read for ReadAhead {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let available = std::io::BufRead::fill_buf(self)?;
        let n = available.len().min(out.len());
        out[..n].copy_from_slice(&available[..n]);
        std::io::BufRead::consume(self, n);
        Ok(n)
    }
}

/// Progress in percent of a program's lines, as a LinuxCNC filter reports
/// it (`FILTER_PROGRESS=n` on standard error, read by AXIS: axis.py,
/// `filter_program`): below 100 until the work ends, each step once.
pub struct LinePercent {
    total: Option<u64>,
    shown: u64,
}

impl LinePercent {
    /// Over the lines of the file `program` (`-`, standard input, whose
    /// length is unknown, or an unreadable file: no percent).
    pub fn of(program: &Path) -> Self {
        let total = (program.as_os_str() != "-")
            .then(|| count_lines(program))
            .flatten();
        LinePercent { total, shown: 0 }
    }

    /// The percent reached at `line`, when it is more than last reported.
    pub fn at(&mut self, line: u64) -> Option<u64> {
        let pct = (line.saturating_mul(100) / self.total?).min(99);
        (pct > self.shown).then(|| {
            self.shown = pct;
            pct
        })
    }
}

/// Lines of the file `program` (at least one).
fn count_lines(program: &Path) -> Option<u64> {
    let f = volcomp_geom::inputs::open(program, "the program").ok()?;
    let mut f = std::io::BufReader::new(f);
    let mut n = 0u64;
    loop {
        let buf = f.fill_buf().ok()?;
        if buf.is_empty() {
            break;
        }
        n += buf.iter().filter(|&&b| b == b'\n').count() as u64;
        let len = buf.len();
        f.consume(len);
    }
    Some(n.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_of_lines_steps_once_and_stays_below_100() {
        // 200 lines: line 3 is 1 %, line 199 is 99 %, line 200 stays 99.
        let mut p = LinePercent {
            total: Some(200),
            shown: 0,
        };
        assert_eq!(p.at(1), None);
        assert_eq!(p.at(3), Some(1));
        assert_eq!(p.at(3), None);
        assert_eq!(p.at(199), Some(99));
        assert_eq!(p.at(200), None);
        let mut unknown = LinePercent::of(Path::new("-"));
        assert_eq!(unknown.at(10), None);
    }
    /// Hands out its bytes in pieces of the lengths given in turn, then
    /// an error if one is given.
    struct Pieces {
        bytes: Vec<u8>,
        lengths: Vec<usize>,
        next: usize,
        error: bool,
    }

    impl std::io::Read for Pieces {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            if self.bytes.is_empty() && self.error {
                return Err(std::io::Error::other("the disk went away"));
            }
            let want = self.lengths[self.next % self.lengths.len()];
            self.next += 1;
            let n = want.min(out.len()).min(self.bytes.len());
            out[..n].copy_from_slice(&self.bytes[..n]);
            self.bytes.drain(..n);
            Ok(n)
        }
    }

    #[test]
    fn reading_ahead_yields_the_bytes_then_the_error_of_the_source() {
        let bytes: Vec<u8> = (0..700_000u32).map(|i| (i * 7 % 251) as u8).collect();
        for lengths in [vec![1 << 16], vec![1, 5000, 70_000], vec![1 << 20]] {
            for error in [false, true] {
                let mut r = ReadAhead::new(Pieces {
                    bytes: bytes.clone(),
                    lengths: lengths.clone(),
                    next: 0,
                    error,
                });
                let mut got = Vec::new();
                let mut buf = vec![0; 40_000];
                let end = loop {
                    match std::io::Read::read(&mut r, &mut buf) {
                        Ok(0) => break None,
                        Ok(n) => got.extend_from_slice(&buf[..n]),
                        Err(e) => break Some(e.to_string()),
                    }
                };
                assert!(got == bytes, "reads {lengths:?}: {} bytes", got.len());
                assert_eq!(end.is_some(), error, "{end:?}");
                if error {
                    assert_eq!(end.as_deref(), Some("the disk went away"));
                    assert_eq!(std::io::Read::read(&mut r, &mut buf).unwrap(), 0);
                }
            }
        }
        // Dropped before the end of an endless source: the thread stops
        // (it would otherwise keep the process busy; nothing waits here).
        let mut endless = ReadAhead::new(std::io::repeat(b'x'));
        assert_eq!(endless.fill_buf().unwrap()[0], b'x');
        drop(endless);
    }
}
