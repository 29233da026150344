//! Program text held for control flow: the lines of one file, read lazily
//! from the program's reader (main program) or at once (subroutine files).

use std::io::BufRead;

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
    pub fn fill_to<R: BufRead>(&mut self, reader: &mut R, i: usize) -> std::io::Result<()> {
        while !self.eof && self.read_so_far() <= i {
            let start = self.bytes.len();
            let n = reader.read_until(b'\n', &mut self.bytes)?;
            if n == 0 {
                self.eof = true;
            } else {
                self.starts.push(start);
            }
        }
        Ok(())
    }
}
