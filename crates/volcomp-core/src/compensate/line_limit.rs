//! Every written line within LinuxCNC's line length: `Interp::read_text`
//! (src/emc/rs274ngc/interp_read.cc) reads a line into a 256-byte buffer
//! (`LINELEN`) and refuses one of 254 bytes or more with its line feed
//! ("Command too long"): at most 252 bytes before the `\n` (a `\r` counts).
//!
//! A compensated line can grow past it where the program's own line was
//! near the limit: a long comment kept beside coordinates written with more
//! decimals. Such a line is written with its comments on lines of their own
//! just before it (a comment alone changes nothing the machine does; the
//! order of the comments and of the blocks is kept). A line that is still
//! too long is refused, with what to do. Lines within the limit pass byte
//! for byte.

use std::io::{self, Write};
use volcomp_gcode::lexer::{self, Token};

/// Most bytes of a line before its `\n` that LinuxCNC reads.
pub const MAX_LINE_BYTES: usize = 252;

/// A writer that keeps every line within [`MAX_LINE_BYTES`].
pub(super) struct LineLimit<'a> {
    inner: &'a mut dyn Write,
    /// The current line, until its `\n`.
    line: Vec<u8>,
    /// Lines split because they were too long.
    pub(super) split: u64,
}

impl<'a> LineLimit<'a> {
    pub(super) fn new(inner: &'a mut dyn Write) -> Self {
        LineLimit {
            inner,
            line: Vec::with_capacity(256),
            split: 0,
        }
    }

    /// Writes the last line (one without a line ending).
    pub(super) fn end(&mut self) -> io::Result<()> {
        if !self.line.is_empty() {
            let line = std::mem::take(&mut self.line);
            self.emit(&line)?;
        }
        self.inner.flush()
    }

    /// Writes one line (with its ending, if any), split if too long.
    fn emit(&mut self, line: &[u8]) -> io::Result<()> {
        let ending = if line.ends_with(b"\r\n") {
            2
        } else {
            usize::from(line.ends_with(b"\n"))
        };
        let content = &line[..line.len() - ending];
        // LinuxCNC counts the `\r` of a `\r\n` ending as part of the line.
        let counted = content.len() + usize::from(ending == 2);
        if counted <= MAX_LINE_BYTES {
            return self.inner.write_all(line);
        }
        let eol: &[u8] = if ending == 2 { b"\r\n" } else { b"\n" };
        let (comments, rest) = split_comments(content);
        let rest_len = rest.len() + usize::from(ending == 2);
        if comments.is_empty() || rest_len > MAX_LINE_BYTES {
            let shown = String::from_utf8_lossy(&content[..content.len().min(60)]);
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "a written line would be {counted} characters long, more than the {MAX_LINE_BYTES} LinuxCNC reads (\"Command too long\"), even with its comments on lines of their own: `{shown}…`; write fewer decimals (--decimals) or split the program's line"
                ),
            ));
        }
        for c in comments {
            self.inner.write_all(c)?;
            self.inner.write_all(eol)?;
        }
        if !rest.is_empty() {
            self.inner.write_all(&rest)?;
            if ending > 0 {
                self.inner.write_all(eol)?;
            }
        }
        self.split += 1;
        Ok(())
    }
}

/// The comments of a line (each `( … )` and the `;` comment), and the line
/// without them (blanks at its end cut). A line that does not lex is
/// returned whole, without comments.
fn split_comments(content: &[u8]) -> (Vec<&[u8]>, Vec<u8>) {
    let mut lexed = lexer::Lexed::default();
    if lexer::classify(content) != lexer::LineKind::Block
        || lexer::lex_block(content, &mut lexed).is_err()
    {
        return (Vec::new(), content.to_vec());
    }
    let mut comments = Vec::new();
    let mut rest = Vec::with_capacity(content.len());
    let mut at = 0;
    for t in &lexed.tokens {
        if let Token::Comment(r) | Token::LineComment(r) = t {
            rest.extend_from_slice(&content[at..r.start]);
            comments.push(&content[r.clone()]);
            at = r.end;
        }
    }
    rest.extend_from_slice(&content[at..]);
    while rest.last().is_some_and(|b| matches!(b, b' ' | b'\t')) {
        rest.pop();
    }
    (comments, rest)
}

impl Write for LineLimit<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut rest = buf;
        if !self.line.is_empty() {
            // The end of a line begun in an earlier piece.
            let Some(end) = memchr::memchr(b'\n', rest) else {
                self.line.extend_from_slice(rest);
                return Ok(buf.len());
            };
            self.line.extend_from_slice(&rest[..=end]);
            let line = std::mem::take(&mut self.line);
            self.emit(&line)?;
            self.line = line;
            self.line.clear();
            rest = &rest[end + 1..];
        }
        // The common case: whole lines in the piece. A line of `n` bytes
        // with its `\n` counts `n − 1` for LinuxCNC (a `\r\n`'s `\r`
        // included), so one whose `\n` lies at most `MAX_LINE_BYTES` in
        // passes byte for byte: the lines before a long one are written
        // together, as they are.
        let mut run = 0;
        while let Some(end) = memchr::memchr(b'\n', &rest[run..]) {
            if end <= MAX_LINE_BYTES {
                run += end + 1;
                continue;
            }
            self.inner.write_all(&rest[..run])?;
            self.emit(&rest[run..=run + end])?;
            rest = &rest[run + end + 1..];
            run = 0;
        }
        if run > 0 {
            self.inner.write_all(&rest[..run])?;
        }
        self.line.extend_from_slice(&rest[run..]);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn through(text: &str) -> io::Result<String> {
        let mut out = Vec::new();
        let mut w = LineLimit::new(&mut out);
        // In two pieces, split inside a line.
        let (a, b) = text.split_at(text.len() / 2);
        w.write_all(a.as_bytes())?;
        w.write_all(b.as_bytes())?;
        w.end()?;
        Ok(String::from_utf8(out).unwrap())
    }

    #[test]
    fn short_lines_pass_byte_for_byte() {
        let text = "G1 X1 (a comment)\r\nG0 Z5 ; end\nM2";
        assert_eq!(through(text).unwrap(), text);
    }

    #[test]
    fn a_long_line_gets_its_comments_on_lines_of_their_own() {
        let comment = format!("({})", "c".repeat(200));
        let words = "G1 X12.345678 Y-23.456789 Z-0.123456 F1000.5";
        let line = format!("{words} {comment} ;tail\n");
        assert!(line.len() > MAX_LINE_BYTES);
        let out = through(&format!("G0 X0\n{line}M2\n")).unwrap();
        assert_eq!(out, format!("G0 X0\n{comment}\n;tail\n{words}\nM2\n"));
        assert!(out.lines().all(|l| l.len() <= MAX_LINE_BYTES));
        // With CRLF the `\r` counts, as in LinuxCNC.
        let exact = format!("G1 X1 ({})\r\n", "c".repeat(MAX_LINE_BYTES - 8));
        assert_eq!(exact.len() - 1, MAX_LINE_BYTES + 1);
        let out = through(&exact).unwrap();
        assert!(out.starts_with("(c"), "{out}");
        assert!(out.ends_with("\r\nG1 X1\r\n"), "{out}");
    }

    /// Lines written in one piece give the bytes they give written one
    /// byte at a time (every line then ends in a piece of its own and is
    /// checked alone), at the limit and one past it, with `\n` and `\r\n`:
    /// 252 bytes before the `\n` pass, 253 are split (LinuxCNC's `LINELEN`,
    /// interp_read.cc: the `\r` counts).
    #[test]
    fn lines_in_one_piece_pass_as_lines_one_by_one() {
        let at = |n: usize, eol: &str| format!("G1 X1 ({}){eol}", "c".repeat(n - 8));
        let mut text = String::new();
        for n in [9, 251, 252, 253] {
            text += &at(n, "\n");
            text += "G0 X2\n";
            text += &at(n, "\r\n");
        }
        text += "M2";
        let mut whole = Vec::new();
        let mut w = LineLimit::new(&mut whole);
        w.write_all(text.as_bytes()).unwrap();
        w.end().unwrap();
        let mut bytes = Vec::new();
        let mut w = LineLimit::new(&mut bytes);
        for b in text.as_bytes() {
            w.write_all(std::slice::from_ref(b)).unwrap();
        }
        w.end().unwrap();
        assert_eq!(whole, bytes);
        let out = String::from_utf8(whole).unwrap();
        // By hand: the 252-byte lines whole, the 253-byte ones (and the
        // 252 + `\r\n`) split, their comment first.
        assert!(out.contains(&at(252, "\n")), "{out}");
        assert!(out.contains(&at(251, "\r\n")), "{out}");
        assert!(!out.contains(&at(253, "\n")), "{out}");
        assert!(!out.contains(&at(252, "\r\n")), "{out}");
        assert!(out.contains("\nG1 X1\r\n"), "{out}");
        assert!(out.split('\n').all(|l| l.len() <= MAX_LINE_BYTES), "{out}");
        // A piece that ends inside a line, then the rest.
        let mut pieces = Vec::new();
        let mut w = LineLimit::new(&mut pieces);
        let (a, b) = text.split_at(text.len() / 3);
        w.write_all(a.as_bytes()).unwrap();
        w.write_all(b.as_bytes()).unwrap();
        w.end().unwrap();
        assert_eq!(pieces, bytes);
    }

    #[test]
    fn a_line_of_words_too_long_is_refused_with_what_to_do() {
        let words: String = (0..40).map(|i| format!("X{i}.123456 ")).collect();
        let e = through(&format!("{words}\n")).unwrap_err();
        assert!(e.to_string().contains("Command too long"), "{e}");
        assert!(e.to_string().contains("--decimals"), "{e}");
    }
}
