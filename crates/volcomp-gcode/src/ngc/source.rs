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
/// `base <= i < base + held()`.
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
    /// Start of each held line in `bytes`, from `starts[head]` on (those
    /// before it are forgotten; dropped when the buffer is compacted, so
    /// that forgetting a line costs no shift).
    starts: Vec<usize>,
    head: usize,
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
            head: 0,
            base: 0,
            eof: true,
        }
    }

    /// Line `i` with its ending, if held.
    #[inline]
    pub fn get(&self, i: usize) -> Option<&[u8]> {
        let k = self.head + i.checked_sub(self.base)?;
        let s = *self.starts.get(k)?;
        let e = self.starts.get(k + 1).copied().unwrap_or(self.split_to);
        Some(&self.bytes[s..e])
    }

    /// Whether line `i` is held.
    #[inline]
    pub fn holds(&self, i: usize) -> bool {
        i >= self.base && i < self.read_so_far()
    }

    /// Number of lines held.
    pub fn held(&self) -> usize {
        self.starts.len() - self.head
    }

    /// Number of lines read so far (absolute).
    #[inline]
    pub fn read_so_far(&self) -> usize {
        self.base + self.held()
    }

    /// Forgets every held line before `i` (nothing can jump back to them).
    #[inline]
    pub fn forget_before(&mut self, i: usize) {
        if i <= self.base || self.held() == 0 {
            return;
        }
        let k = (i - self.base).min(self.held());
        self.head += k;
        if self.head == self.starts.len() {
            self.starts.clear();
            self.head = 0;
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
    /// no whole line; `false` at the end of the input. Every other whole
    /// line already read is split in the same pass (one search over the
    /// bytes instead of one per line); a line too long to hold stops that
    /// pass, so that it is refused only when it is the line asked for.
    fn split_next<R: Read>(&mut self, reader: &mut R) -> std::io::Result<bool> {
        let limit = MAX_HELD_LINE_BYTES + 1;
        loop {
            let before = self.starts.len();
            let mut start = self.split_to;
            let mut searched = self.filled;
            let from = self.searched;
            for k in memchr::memchr_iter(b'\n', &self.bytes[from..self.filled]) {
                let end = from + k + 1;
                if end - start > limit {
                    searched = start;
                    break;
                }
                self.starts.push(start);
                start = end;
            }
            self.split_to = start;
            self.searched = searched.max(start);
            if self.starts.len() > before {
                return Ok(true);
            }
            if searched < self.filled || self.filled - start >= limit {
                return Err(self.too_long());
            }
            if self.eof {
                if self.filled == start {
                    return Ok(false);
                }
                // The last line, without a line feed.
                self.starts.push(start);
                self.split_to = self.filled;
                self.searched = self.filled;
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
            self.starts.drain(..self.head);
            self.head = 0;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Hands out its bytes in pieces of the lengths given in turn (a pipe,
    /// a slow device).
    struct Pieces<'a> {
        bytes: &'a [u8],
        lengths: Vec<usize>,
        next: usize,
    }

    impl Read for Pieces<'_> {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            let want = self.lengths[self.next % self.lengths.len()];
            self.next += 1;
            let n = want.min(out.len()).min(self.bytes.len());
            out[..n].copy_from_slice(&self.bytes[..n]);
            self.bytes = &self.bytes[n..];
            Ok(n)
        }
    }

    /// The lines of `text` as a plain split gives them (endings kept).
    fn split(text: &[u8]) -> Vec<&[u8]> {
        text.split_inclusive(|&b| b == b'\n').collect()
    }

    #[test]
    fn lines_come_out_as_written_whatever_the_reads_and_the_forgetting() {
        // Lines of many lengths (empty, CR LF, longer than a read chunk),
        // the last without its line feed; read in pieces of every size,
        // forgetting behind as the walker does (or keeping everything).
        let mut text = Vec::new();
        let mut seed = 7u64;
        for i in 0..3000 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let len = match i % 97 {
                0 => 70_000,
                _ => (seed >> 33) as usize % 40,
            };
            text.extend(std::iter::repeat_n(b'a' + (i % 26) as u8, len));
            text.extend_from_slice(if i % 5 == 0 { b"\r\n" } else { b"\n" });
        }
        text.extend_from_slice(b"G0 X1");
        let want = split(&text);
        for lengths in [
            vec![1],
            vec![3, 1, 7],
            vec![65_536],
            vec![100_000, 5],
            vec![13],
        ] {
            for forget in [true, false] {
                let mut reader = Pieces {
                    bytes: &text,
                    lengths: lengths.clone(),
                    next: 0,
                };
                let mut lines = Lines::default();
                for (i, line) in want.iter().enumerate() {
                    if forget {
                        lines.forget_before(i);
                    }
                    lines.fill_to(&mut reader, i).unwrap();
                    assert_eq!(lines.get(i), Some(*line), "line {i}, reads {lengths:?}");
                    if !forget {
                        assert_eq!(lines.get(0), Some(want[0]));
                    }
                }
                lines.fill_to(&mut reader, want.len()).unwrap();
                assert!(!lines.holds(want.len()));
                assert_eq!(lines.read_so_far(), want.len());
            }
        }
    }

    #[test]
    fn a_line_too_long_is_refused_when_it_is_reached_not_before() {
        // The read buffer holds a short line and the whole of a line too
        // long to hold (as after a read into a buffer grown by earlier
        // long lines): the short line is handed out, the long one refused
        // only when it is asked for.
        let mut text = b"G0 X2\n".to_vec();
        text.extend(std::iter::repeat_n(b'x', MAX_HELD_LINE_BYTES + 10));
        text.extend_from_slice(b"\nG0 X3\n");
        let mut lines = Lines {
            filled: text.len(),
            bytes: text,
            base: 1,
            ..Lines::default()
        };
        let mut nothing = std::io::empty();
        lines.fill_to(&mut nothing, 1).unwrap();
        assert_eq!(lines.get(1), Some(&b"G0 X2\n"[..]));
        assert_eq!(lines.read_so_far(), 2, "the long line is not held");
        lines.forget_before(2);
        let e = lines.fill_to(&mut nothing, 2).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().starts_with("line 3 is longer"), "{e}");
    }
}
