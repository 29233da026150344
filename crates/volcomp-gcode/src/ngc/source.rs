//! Program text held for control flow: the lines of one file, read lazily
//! from the program's reader (main program) or at once (subroutine files).

use std::io::BufRead;

/// Longest line held in memory, line feed included (1 MiB).
pub const MAX_HELD_LINE_BYTES: usize = 1 << 20;

/// The lines of one file. Line `i` (0-based, absolute) is held when
/// `base <= i < base + starts.len()`.
#[derive(Debug, Default)]
pub struct Lines {
    bytes: Vec<u8>,
    starts: Vec<usize>,
    base: usize,
    /// The whole file has been read.
    pub eof: bool,
}

impl Lines {
    /// The lines of `text` (a subroutine file).
    pub fn of(text: Vec<u8>) -> Lines {
        let mut starts = Vec::new();
        let mut s = 0;
        while s < text.len() {
            starts.push(s);
            s = match text[s..].iter().position(|&b| b == b'\n') {
                Some(k) => s + k + 1,
                None => text.len(),
            };
        }
        Lines {
            bytes: text,
            starts,
            base: 0,
            eof: true,
        }
    }

    /// Line `i` with its ending, if held.
    pub fn get(&self, i: usize) -> Option<&[u8]> {
        let k = i.checked_sub(self.base)?;
        let s = *self.starts.get(k)?;
        let e = self.starts.get(k + 1).copied().unwrap_or(self.bytes.len());
        Some(&self.bytes[s..e])
    }

    /// Number of lines held.
    pub fn held(&self) -> usize {
        self.starts.len()
    }

    /// Number of lines read so far (absolute).
    pub fn read_so_far(&self) -> usize {
        self.base + self.starts.len()
    }

    /// Forgets every held line before `i` (nothing can jump back to them).
    pub fn forget_before(&mut self, i: usize) {
        if i <= self.base || self.starts.is_empty() {
            return;
        }
        let k = (i - self.base).min(self.starts.len());
        if k == self.starts.len() {
            self.bytes.clear();
            self.starts.clear();
        } else {
            let cut = self.starts[k];
            self.bytes.drain(..cut);
            self.starts.drain(..k);
            for s in &mut self.starts {
                *s -= cut;
            }
        }
        self.base += k;
    }

    /// Reads lines from `reader` until line `i` is held or the input ends.
    ///
    /// A line longer than [`MAX_HELD_LINE_BYTES`] is an
    /// [`std::io::ErrorKind::InvalidData`] error, raised before more of it is
    /// held: memory stays bounded whatever the input (a file of one line
    /// without a line feed, say). LinuxCNC itself reads at most 252
    /// characters a line; the reader refuses those lines with that message,
    /// the larger bound here only keeps the bytes after a program's end
    /// (copied as they are) from being cut.
    pub fn fill_to<R: BufRead>(&mut self, reader: &mut R, i: usize) -> std::io::Result<()> {
        use std::io::Read;
        while !self.eof && self.read_so_far() <= i {
            let start = self.bytes.len();
            let limit = MAX_HELD_LINE_BYTES as u64 + 1;
            let n = reader
                .by_ref()
                .take(limit)
                .read_until(b'\n', &mut self.bytes)?;
            if n == 0 {
                self.eof = true;
            } else if n as u64 == limit && self.bytes.last() != Some(&b'\n') {
                self.bytes.truncate(start);
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!(
                        "line {} is longer than {MAX_HELD_LINE_BYTES} bytes (LinuxCNC reads at most 252 characters a line)",
                        self.read_so_far() + 1
                    ),
                ));
            } else {
                self.starts.push(start);
            }
        }
        Ok(())
    }
}
