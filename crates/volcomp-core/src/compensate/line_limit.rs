//! Every written line within LinuxCNC's line length: `Interp::read_text`
//! (src/emc/rs274ngc/interp_read.cc) reads a line into a 256-byte buffer
//! (`LINELEN`) and refuses one of 254 bytes or more with its line feed
//! ("Command too long"): at most 252 bytes before the `\n` (a `\r` counts).
//!
//! A compensated line can grow past it where the program's own line was
//! near the limit: a long comment kept beside coordinates written with more
//! decimals. Such a line is written with its comments on lines of their own
//! just before it (a comment alone changes nothing the machine does; the
//! order of the comments and of the blocks is kept). A comment still too
//! long for a line of its own is written as several comments, its text cut
//! between them and kept byte for byte; but a comment LinuxCNC acts on
//! (see [`acted_on`]) is one command and cannot be cut: the program is
//! refused at its line. A line of words that is still too long is refused,
//! with what to do. Lines within the limit pass byte for byte.

use super::size::Blocks;
use crate::error::CompensationError;
use std::io::{self, Write};
use volcomp_gcode::lexer::{self, Token};
use volcomp_gcode::{ErrorClass, GcodeError};

/// Most bytes of a line before its `\n` that LinuxCNC reads.
pub const MAX_LINE_BYTES: usize = 252;

/// A writer that keeps every line within [`MAX_LINE_BYTES`].
pub(super) struct LineLimit<'a> {
    inner: &'a mut dyn Write,
    /// The current line, until its `\n`.
    line: Vec<u8>,
    /// Lines split because they were too long.
    pub(super) split: u64,
    /// The program's file and the number of its line being written, to
    /// name where a line that cannot be written comes from.
    pub(super) file: &'a str,
    pub(super) source_line: u64,
    /// Why writing stopped, when it stopped on a comment that cannot be
    /// cut (the `io::Error` returned then only says that it stopped).
    refused: Option<GcodeError>,
    /// Bytes and blocks written (counted here, where the line ends are
    /// found anyway, rather than by a stage after).
    bytes: u64,
    blocks: Blocks,
}

impl<'a> LineLimit<'a> {
    pub(super) fn new(inner: &'a mut dyn Write) -> Self {
        LineLimit {
            inner,
            line: Vec::with_capacity(256),
            split: 0,
            file: "",
            source_line: 0,
            refused: None,
            bytes: 0,
            blocks: Blocks::default(),
        }
    }

    /// `(bytes, blocks)` written ([`Blocks`]), the last line included.
    pub(super) fn counts(&self) -> (u64, u64) {
        (self.bytes, self.blocks.finish())
    }

    /// Writes `bytes`, counted.
    fn put(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.inner.write_all(bytes)?;
        self.bytes += bytes.len() as u64;
        self.blocks.scan(bytes);
        Ok(())
    }

    /// The error a failed write gives: the refusal of a comment that
    /// cannot be cut, with its file and line, or `e` itself.
    pub(super) fn error(&mut self, e: CompensationError) -> CompensationError {
        self.refused.take().map_or(e, CompensationError::from)
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
            return self.put(line);
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
        // A `\r\n` ending's `\r` counts (as above).
        let most = MAX_LINE_BYTES - usize::from(ending == 2);
        for c in comments {
            if c.len() <= most {
                self.put(c)?;
                self.put(eol)?;
                continue;
            }
            let Some(pieces) = cut_comment(c, most) else {
                return Err(self.refuse(c, most));
            };
            for p in pieces {
                self.put(p.0)?;
                self.put(p.1)?;
                self.put(p.2)?;
                self.put(eol)?;
            }
        }
        if !rest.is_empty() {
            self.put(&rest)?;
            if ending > 0 {
                self.put(eol)?;
            }
        }
        self.split += 1;
        Ok(())
    }
}

impl LineLimit<'_> {
    /// Writes whole lines whose blocks are already counted.
    fn write_run(&mut self, run: &[u8]) -> io::Result<()> {
        self.inner.write_all(run)?;
        self.bytes += run.len() as u64;
        Ok(())
    }

    /// Notes why comment `c` cannot be written and returns the error that
    /// stops the writing.
    #[cold]
    fn refuse(&mut self, c: &[u8], most: usize) -> io::Error {
        let shown = String::from_utf8_lossy(&c[..c.len().min(40)]);
        let why = if acted_on(c) {
            "LinuxCNC acts on this comment (interp_convert.cc `convert_comment`, emccanon.cc `COMMENT`), so it cannot be cut into several"
        } else {
            "it cannot be cut into comments LinuxCNC would not act on"
        };
        let e = GcodeError::new(
            ErrorClass::Invalid,
            self.source_line,
            1,
            format!(
                "a comment of {} characters, `{shown}…`, would be written on a line of its own, more than the {most} LinuxCNC reads (\"Command too long\"), and {why}",
                c.len()
            ),
            "shorten the comment",
        )
        .with_file(self.file);
        self.refused = Some(e);
        io::Error::new(io::ErrorKind::InvalidData, "a comment cannot be written")
    }
}

/// Whether LinuxCNC acts on comment `c` (`( … )` or `;…`) rather than
/// ignoring it: a `( … )` whose text, after leading blanks and in any case,
/// starts with `msg,`, `debug,`, `print,`, `log,`, `logopen,`,
/// `logappend,`, `logclose`, `py,`, `pyrun,`, `pyreload` or `abort,`
/// (LinuxCNC 2.9 src/emc/rs274ngc/interp_convert.cc,
/// `Interp::convert_comment`), or `PROBEOPEN`, `PROBECLOSE` (src/emc/task/
/// emccanon.cc, `COMMENT`; taken here in any case); and a `;py,` comment
/// (interp_read.cc, `Interp::read_semicolon`, which acts on it at the
/// start of a line; taken here anywhere).
pub(super) fn acted_on(c: &[u8]) -> bool {
    const ACTIVE: [&[u8]; 13] = [
        b"msg,",
        b"debug,",
        b"print,",
        b"log,",
        b"logopen,",
        b"logappend,",
        b"logclose",
        b"py,",
        b"pyrun,",
        b"pyreload",
        b"abort,",
        b"probeopen",
        b"probeclose",
    ];
    match c.first() {
        Some(b'(') => {
            let text = &c[1..];
            // C's `isspace`: blank, tab, line feed, vertical tab, form feed, CR.
            let start = text
                .iter()
                .position(|b| !matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r'))
                .unwrap_or(text.len());
            let text = &text[start..];
            ACTIVE
                .iter()
                .any(|a| text.len() >= a.len() && text[..a.len()].eq_ignore_ascii_case(a))
        }
        Some(b';') => c.len() >= 4 && c[1..4].eq_ignore_ascii_case(b"py,"),
        _ => false,
    }
}

/// One comment of a cut one: its opening (`(` or `;`), a piece of the
/// text, its closing (`)`, or nothing after `;`).
type Piece<'a> = (&'a [u8], &'a [u8], &'a [u8]);

/// A comment too long for a line of `most` bytes as several comments of
/// at most `most` bytes each (`( … )` pieces of a `( … )` comment, `;…`
/// pieces of a `;` comment), each `(open, text, close)`: the texts joined
/// are the comment's text, byte for byte. A cut never falls inside a UTF-8
/// character, and never where the piece after it would be a comment
/// LinuxCNC acts on ([`acted_on`]). `None` for a comment LinuxCNC acts on,
/// or one that cannot be cut so.
fn cut_comment(c: &[u8], most: usize) -> Option<Vec<Piece<'_>>> {
    if acted_on(c) {
        return None;
    }
    let (open, text, close): (&[u8], &[u8], &[u8]) = match c.first() {
        Some(b'(') if c.len() >= 2 && c.ends_with(b")") => (b"(", &c[1..c.len() - 1], b")"),
        Some(b';') => (b";", &c[1..], b""),
        _ => return None,
    };
    let room = most
        .checked_sub(open.len() + close.len())
        .filter(|r| *r > 0)?;
    let mut pieces = Vec::new();
    let mut at = 0;
    while at < text.len() {
        let mut end = (at + room).min(text.len());
        while end > at
            && end < text.len()
            && (is_continuation(text[end]) || acted_on(&[open, &text[end..], close].concat()))
        {
            end -= 1;
        }
        if end == at {
            return None;
        }
        pieces.push((open, &text[at..end], close));
        at = end;
    }
    Some(pieces)
}

/// A byte inside a UTF-8 character (not its first).
fn is_continuation(b: u8) -> bool {
    b & 0xC0 == 0x80
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
        // Whole lines from a line start: each counted as it is found.
        let mut run = 0;
        // A piece ends with its last line's `\n` (the writers hand whole
        // lines): no search is made in the nothing after it.
        while run < rest.len() {
            let Some(end) = memchr::memchr(b'\n', &rest[run..]) else {
                break;
            };
            if end <= MAX_LINE_BYTES {
                self.blocks.scan_line(&rest[run..=run + end]);
                run += end + 1;
                continue;
            }
            self.write_run(&rest[..run])?;
            self.emit(&rest[run..=run + end])?;
            rest = &rest[run + end + 1..];
            run = 0;
        }
        if run > 0 {
            self.write_run(&rest[..run])?;
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
        text += "(a comment)\n;one more\n%\n  \n(c) G0 X3\n";
        text += "M2";
        let mut whole = Vec::new();
        let mut w = LineLimit::new(&mut whole);
        w.write_all(text.as_bytes()).unwrap();
        w.end().unwrap();
        let whole_counts = w.counts();
        let mut bytes = Vec::new();
        let mut w = LineLimit::new(&mut bytes);
        for b in text.as_bytes() {
            w.write_all(std::slice::from_ref(b)).unwrap();
        }
        w.end().unwrap();
        let byte_counts = w.counts();
        assert_eq!(whole, bytes);
        // The counts are those of the bytes written, counted by `Blocks`
        // in one piece (the second method); by hand 14 blocks: the twelve
        // `G1`/`G0` lines, the `G0 X3` after a comment, the last `M2`.
        let mut blocks = Blocks::default();
        blocks.scan(&whole);
        assert_eq!(byte_counts, (whole.len() as u64, blocks.finish()));
        assert_eq!(byte_counts.1, 14);
        assert_eq!(whole_counts, byte_counts);
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

    /// A plain comment too long for a line of its own: cut into comments
    /// of at most 252 bytes (by hand: 250 bytes of text between `(` and
    /// `)`, 251 after `;`, one less with `\r\n`), the texts joined giving
    /// the comment's text; a line of words keeps its words after them.
    #[test]
    fn a_plain_comment_too_long_is_cut_into_comments() {
        let text: String = (0..300)
            .map(|i| char::from(b'a' + (i % 26) as u8))
            .collect();
        let out = through(&format!("G0 X0\n({text})\nM2\n")).unwrap();
        let want = format!("G0 X0\n({})\n({})\nM2\n", &text[..250], &text[250..]);
        assert_eq!(out, want);
        let out = through(&format!("G1 X1 ;{text}\r\n")).unwrap();
        let want = format!(";{}\r\n;{}\r\nG1 X1\r\n", &text[..250], &text[250..]);
        assert_eq!(out, want);
        let out = through(&format!(";{text}\n")).unwrap();
        assert_eq!(out, format!(";{}\n;{}\n", &text[..251], &text[251..]));
        for l in out.lines() {
            assert!(l.len() <= MAX_LINE_BYTES, "{l}");
        }
    }

    /// A cut falls neither inside a UTF-8 character (`é` is two bytes) nor
    /// where the next piece would be a comment LinuxCNC acts on (` MSG,`
    /// after blanks): it moves back, by hand one byte and two bytes.
    #[test]
    fn a_cut_keeps_characters_whole_and_makes_no_comment_linuxcnc_acts_on() {
        let text = format!("{}é{}", "c".repeat(249), "d".repeat(100));
        let out = through(&format!("({text})\n")).unwrap();
        assert_eq!(
            out,
            format!("({})\n(é{})\n", "c".repeat(249), "d".repeat(100))
        );
        let text = format!("{} MSG,{}", "c".repeat(250), "d".repeat(100));
        let out = through(&format!("({text})\n")).unwrap();
        assert_eq!(
            out,
            format!("({})\n(c MSG,{})\n", "c".repeat(249), "d".repeat(100))
        );
        assert!(!acted_on(b"(c MSG,x)"));
    }

    /// The comments LinuxCNC acts on (interp_convert.cc `convert_comment`,
    /// emccanon.cc `COMMENT`, interp_read.cc `read_semicolon`) and some it
    /// does not.
    #[test]
    fn comments_linuxcnc_acts_on_are_known() {
        for c in [
            "(MSG,hi)",
            "( \tdebug,#1)",
            "(Print,x)",
            "(LOG,x)",
            "(logopen,f)",
            "(LOGAPPEND,f)",
            "(LOGCLOSE)",
            "(py,x)",
            "(PYRUN,x)",
            "(pyreload)",
            "(abort,x)",
            "(PROBEOPEN f)",
            "(PROBECLOSE)",
            ";py,x",
        ] {
            assert!(acted_on(c.as_bytes()), "{c}");
        }
        for c in [
            "(message)",
            "(MSG x)",
            "(a msg,x)",
            "(logging)",
            ";msg,x",
            "; py,x",
            "(pylon)",
        ] {
            assert!(!acted_on(c.as_bytes()), "{c}");
        }
    }

    /// A comment LinuxCNC acts on, too long for a line, is refused with
    /// the program's file and line, and nothing of its line is written.
    #[test]
    fn a_comment_linuxcnc_acts_on_too_long_is_refused_at_its_line() {
        let comment = format!("( msg,{})", "m".repeat(260));
        let mut out = Vec::new();
        let mut w = LineLimit::new(&mut out);
        w.file = "part.ngc";
        w.source_line = 7;
        w.write_all(b"G0 X0\n").unwrap();
        let e = w
            .write_all(format!("G1 X1 {comment}\nM2\n").as_bytes())
            .unwrap_err();
        let e = w.error(e.into()).to_string();
        assert!(
            e.starts_with("part.ngc:7:1: a comment of 267 characters"),
            "{e}"
        );
        assert!(e.contains("cannot be cut"), "{e}");
        assert_eq!(out, b"G0 X0\n");
    }

    #[test]
    fn a_line_of_words_too_long_is_refused_with_what_to_do() {
        let words: String = (0..40).map(|i| format!("X{i}.123456 ")).collect();
        let e = through(&format!("{words}\n")).unwrap_err();
        assert!(e.to_string().contains("Command too long"), "{e}");
        assert!(e.to_string().contains("--decimals"), "{e}");
    }
}
