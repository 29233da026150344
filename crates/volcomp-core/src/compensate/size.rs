//! The size of a program: bytes and blocks (lines with more than comments,
//! blanks and `%`), counted alike for the input and the output.

use std::io::Write;

/// Counts blocks in bytes given in any pieces: a line is a block when it
/// holds a character outside parenthesised comments, before any `;`
/// comment, that is neither blank nor `%`.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Blocks {
    count: u64,
    /// The current line has a word character.
    word: bool,
    /// Inside `( … )`.
    paren: bool,
    /// After `;` (the rest of the line is a comment).
    semicolon: bool,
}

impl Blocks {
    pub(super) fn scan(&mut self, mut bytes: &[u8]) {
        while let Some((&b, rest)) = bytes.split_first() {
            if self.word || self.semicolon {
                // Nothing more on this line can change the count: skip to
                // its end (most lines start with a word).
                match memchr::memchr(b'\n', bytes) {
                    Some(end) => {
                        self.end_line();
                        bytes = &bytes[end + 1..];
                        continue;
                    }
                    None => return,
                }
            }
            bytes = rest;
            match b {
                b'\n' => self.end_line(),
                b'(' => self.paren = true,
                b')' if self.paren => self.paren = false,
                _ if self.paren => {}
                b';' => self.semicolon = true,
                b' ' | b'\t' | b'\r' | b'%' => {}
                _ => self.word = true,
            }
        }
    }

    /// [`Blocks::scan`] of one whole line (ending in `\n`): a line that
    /// begins with a letter at a line start, as almost every block does,
    /// is a block without a look further.
    #[inline]
    pub(super) fn scan_line(&mut self, line: &[u8]) {
        match line.first() {
            Some(b) if b.is_ascii_alphabetic() && !(self.word || self.paren || self.semicolon) => {
                self.count += 1;
            }
            _ => self.scan(line),
        }
    }

    fn end_line(&mut self) {
        self.count += u64::from(self.word);
        *self = Blocks {
            count: self.count,
            ..Blocks::default()
        };
    }

    /// The count, the last line included when it has no line end.
    pub(super) fn finish(self) -> u64 {
        self.count + u64::from(self.word)
    }
}

/// The blocks of lines written whole (each without its line ending), as
/// [`Blocks`] counts them in any text made of these lines.
pub(super) fn blocks_of_lines<'a>(lines: impl IntoIterator<Item = &'a [u8]>) -> u64 {
    lines
        .into_iter()
        .map(|l| {
            let mut b = Blocks::default();
            b.scan(l);
            b.finish()
        })
        .sum()
}

/// A writer that counts the bytes passing through it. (The blocks are
/// counted where the lines are made: the body's by the line-length stage,
/// [`super::line_limit::LineLimit`], which finds every line's end anyway,
/// and the header's from its lines; not a second time here.)
pub(super) struct Counted<'a> {
    inner: &'a mut dyn Write,
    bytes: u64,
}

impl<'a> Counted<'a> {
    pub(super) fn new(inner: &'a mut dyn Write) -> Self {
        Counted { inner, bytes: 0 }
    }

    /// Bytes written.
    pub(super) fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl Write for Counted<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_are_lines_with_more_than_comments() {
        let mut b = Blocks::default();
        // 1: words; 2: comment only; 3: blank; 4: '%'; 5: words after a
        // comment; 6: ';' comment only; 7: words split across two pieces,
        // no line end.
        b.scan(b"G1 X1\n(only a comment)\n   \n%\n(c) X2\n; note X3\nG");
        b.scan(b"0 X4");
        assert_eq!(b.finish(), 3);
    }

    /// Lines handed one at a time, each with its `\n` ([`Blocks::scan_line`],
    /// as the compensation counts the lines it reads and writes), count
    /// what a scan of the whole text counts (the second method): lines
    /// that begin with a letter, a blank, `(`, `;`, `%`, `/`, a digit, a
    /// comment left open to the line's end, `\r\n` endings, empty lines.
    #[test]
    fn lines_one_at_a_time_count_as_the_whole_text() {
        let lines: [&[u8]; 14] = [
            b"G1 X1\n",
            b"(only)\n",
            b"  G0 Z1\n",
            b"(open comment\n",
            b"X2 (then) Y3\n",
            b"; G1 X9\n",
            b"%\n",
            b"/G1 X4\n",
            b"\n",
            b"m2\r\n",
            b"(a) (b)\r\n",
            b"1 (odd)\n",
            b"\t;\n",
            b"N10 G1 X5\n",
        ];
        let mut whole = Blocks::default();
        let mut one_by_one = Blocks::default();
        let mut text = Vec::new();
        for (k, l) in lines.iter().cycle().take(200).enumerate() {
            // Lines in every order the cycle and a shift give.
            let l = if k % 3 == 0 {
                lines[(k * 7) % lines.len()]
            } else {
                l
            };
            one_by_one.scan_line(l);
            text.extend_from_slice(l);
        }
        whole.scan(&text);
        assert!(whole.finish() > 50, "{}", whole.finish());
        assert_eq!(one_by_one.finish(), whole.finish());
        // By hand, the fourteen once: G1 X1, G0 Z1, X2 … Y3, /G1 X4, m2,
        // 1 (odd), N10 G1 X5.
        let mut b = Blocks::default();
        lines.iter().for_each(|l| b.scan_line(l));
        assert_eq!(b.finish(), 7);
    }

    /// The same count whatever the pieces: the text in one piece, byte by
    /// byte, and cut at every place in two; by hand 5 blocks (`G1 X1`,
    /// `(c) X2`, `/G0 Z1`, `( a ; b ) M3`, `M2`), lines that begin inside
    /// a comment, after blanks, with `;` or `%`, and a `\r\n` ending.
    #[test]
    fn blocks_are_counted_alike_in_any_pieces() {
        let text: &[u8] = b"G1 X1\r\n(only)\n  ;G1\n(c) X2\n%\n/G0 Z1\n( a ; b ) M3\n(x\n\n\tM2";
        let count = |pieces: &[&[u8]]| {
            let mut b = Blocks::default();
            for p in pieces {
                b.scan(p);
            }
            b.finish()
        };
        assert_eq!(count(&[text]), 5);
        let bytes: Vec<&[u8]> = text.chunks(1).collect();
        assert_eq!(count(&bytes), 5);
        for k in 0..=text.len() {
            let (a, b) = text.split_at(k);
            assert_eq!(count(&[a, b]), 5, "cut at {k}");
        }
    }
}
