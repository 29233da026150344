//! Helpers for a program streamed from reader to writer: a writer that
//! keeps a copy of what passes, and the progress a LinuxCNC filter reports.
//! (Reading ahead on a thread of its own is volcomp-gcode's `ahead`.)

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
}
