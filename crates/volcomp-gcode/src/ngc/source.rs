//! Program text held for control flow: the lines of one file, read lazily
//! from the program's reader (main program) or at once (subroutine files).

use std::io::Read;

/// Longest line held in memory, line feed included (1 MiB).
pub const MAX_HELD_LINE_BYTES: usize = 1 << 20;

/// Bytes asked of the reader at a time. At least the 64 KiB buffer the
/// front ends put around a file, so that `BufReader` hands the read to the
/// file directly instead of copying through its own buffer.
const READ_CHUNK_BYTES: usize = 1 << 16;

/// The lines of one file. Line `i` (0-based, absolute) is held when
/// `base <= i < base + starts.len()`.
///
/// The main program is read in chunks into `bytes` and its lines are split
/// where they lie: a line is a range of the read buffer, handed to the
/// lexer without a copy. Lines that nothing can jump back to are
/// forgotten; their bytes are reused at the next read, so a program
/// without control flow needs one buffer of a few chunks whatever its size.
#[derive(Debug, Default)]
pub struct Lines {
    /// Read buffer; `bytes[..filled]` holds data.
    bytes: Vec<u8>,
    filled: usize,
    /// Start of each held line in `bytes`.
    starts: Vec<usize>,
    /// End of the last held line: the bytes after it are read but not yet
    /// split into lines.
    split_to: usize,
    /// `bytes[split_to..searched]` holds no line feed.
    searched: usize,
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
            s = match memchr::memchr(b'\n', &text[s..]) {
                Some(k) => s + k + 1,
                None => text.len(),
            };
        }
        Lines {
            filled: text.len(),
            split_to: text.len(),
            searched: text.len(),
            bytes: text,
            starts,
            base: 0,
            eof: true,
        }
    }

    /// Line `i` with its ending, if held.
    #[inline]
    pub fn get(&self, i: usize) -> Option<&[u8]> {
        let k = i.checked_sub(self.base)?;
        let s = *self.starts.get(k)?;
        let e = self.starts.get(k + 1).copied().unwrap_or(self.split_to);
        Some(&self.bytes[s..e])
    }

    /// Whether line `i` is held.
    #[inline]
    pub fn holds(&self, i: usize) -> bool {
        i >= self.base && i < self.base + self.starts.len()
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
    #[inline]
    pub fn forget_before(&mut self, i: usize) {
        if i <= self.base || self.starts.is_empty() {
            return;
        }
        let k = (i - self.base).min(self.starts.len());
        if k == self.starts.len() {
            self.starts.clear();
        } else {
            self.starts.drain(..k);
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
    #[inline]
    pub fn fill_to<R: Read>(&mut self, reader: &mut R, i: usize) -> std::io::Result<()> {
        while self.read_so_far() <= i {
            if !self.split_next(reader)? {
                break;
            }
        }
        Ok(())
    }

    /// Splits the next line off the read bytes, reading more when they hold
    /// no whole line; `false` at the end of the input.
    fn split_next<R: Read>(&mut self, reader: &mut R) -> std::io::Result<bool> {
        let limit = MAX_HELD_LINE_BYTES + 1;
        loop {
            let start = self.split_to;
            if let Some(k) = memchr::memchr(b'\n', &self.bytes[self.searched..self.filled]) {
                let end = self.searched + k + 1;
                if end - start > limit {
                    return Err(self.too_long());
                }
                self.starts.push(start);
                self.split_to = end;
                self.searched = end;
                return Ok(true);
            }
            self.searched = self.filled;
            if self.filled - start >= limit {
                return Err(self.too_long());
            }
            if self.eof {
                if self.filled == start {
                    return Ok(false);
                }
                // The last line, without a line feed.
                self.starts.push(start);
                self.split_to = self.filled;
                return Ok(true);
            }
            self.read_more(reader)?;
        }
    }

    fn too_long(&self) -> std::io::Error {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "line {} is longer than {MAX_HELD_LINE_BYTES} bytes (LinuxCNC reads at most 252 characters a line)",
                self.read_so_far() + 1
            ),
        )
    }

    /// Reads one chunk after the read bytes (or notes the end of the
    /// input), first moving the held lines and the unsplit bytes to the
    /// front of the buffer when the chunk does not fit after them.
    fn read_more<R: Read>(&mut self, reader: &mut R) -> std::io::Result<()> {
        if self.bytes.len() - self.filled < READ_CHUNK_BYTES {
            let keep = self.starts.first().copied().unwrap_or(self.split_to);
            if keep > 0 {
                self.bytes.copy_within(keep..self.filled, 0);
                for s in &mut self.starts {
                    *s -= keep;
                }
                self.filled -= keep;
                self.split_to -= keep;
                self.searched -= keep;
            }
            if self.bytes.len() - self.filled < READ_CHUNK_BYTES {
                let len = (self.filled + READ_CHUNK_BYTES).max(2 * self.bytes.len());
                self.bytes.resize(len, 0);
            }
        }
        loop {
            match reader.read(&mut self.bytes[self.filled..]) {
                Ok(0) => {
                    self.eof = true;
                    return Ok(());
                }
                Ok(n) => {
                    self.filled += n;
                    return Ok(());
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}
