//! Errors that point at the file, line and column, show the line and say
//! what to do: one [`Diagnostic`] shape for every located error, and
//! [`GcodeError`], the one error type of this crate.

use std::fmt;

/// Whether volcomp refuses a valid construct it cannot interpret faithfully,
/// or the program itself is wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorClass {
    /// A construct volcomp does not interpret (parameters, rotation, …).
    Unsupported,
    /// The program is invalid G-code or inconsistent.
    Invalid,
    /// Reading the input failed.
    Io,
}

/// One located diagnostic, the one shape in which volcomp shows every
/// error in an input file (a program, a table, a model or set-up file):
///
/// ```text
/// part.ngc:3:4: F word missing with an inverse-time (G93) feed move
///   |
/// 3 | G1 X10
///   |    ^
///   help: give F (1 / minutes the move takes) on this line
/// ```
///
/// `file:line:column: message` (the form compilers use, which editors can
/// jump to), the source line with a caret under the column, and what to do.
/// [`Diagnostic::render`] (and `Display`, which calls it) is the only code
/// that draws this shape.
///
/// ```
/// use volcomp_gcode::error::Diagnostic;
/// let d = Diagnostic::new(2, 4, "bad word", "remove it")
///     .with_source_line(b"G1 Q1\n")
///     .with_file("part.ngc");
/// assert_eq!(
///     d.to_string(),
///     "part.ngc:2:4: bad word\n  |\n2 | G1 Q1\n  |    ^\n  help: remove it"
/// );
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Diagnostic {
    /// File name as the user gave it, when known (shown as `<input>`
    /// otherwise).
    pub file: Option<String>,
    /// 1-based line number (row of a table).
    pub line: u64,
    /// 1-based column: the byte in a program line, the field in a table.
    pub column: usize,
    /// An excerpt of the offending line around the column (at most about
    /// [`EXCERPT_BYTES`] bytes each side, cut with `…`), control characters
    /// and bytes that are not UTF-8 written as escapes (`\x1b`), so a hostile
    /// or binary line can neither flood nor drive the terminal. Empty: no
    /// excerpt is shown.
    pub source_line: String,
    /// Characters of `source_line` before the caret (the excerpt is bounded,
    /// so this is small).
    pub caret: u16,
    /// What is wrong.
    pub message: String,
    /// What to do about it (empty: no `help:` line).
    pub help: String,
}

impl Diagnostic {
    /// A diagnostic at a 1-based line and column, without file or excerpt.
    pub fn new(
        line: u64,
        column: usize,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        Self {
            file: None,
            line,
            column,
            source_line: String::new(),
            caret: 0,
            message: message.into(),
            help: help.into(),
        }
    }

    /// Attaches an excerpt of the source line with the caret under the
    /// diagnostic's column, read as a byte column (line ending stripped; see
    /// [`excerpt`]).
    pub fn with_source_line(self, line: &[u8]) -> Self {
        let n = crate::lexer::content_len(line);
        let caret_byte = self.column.saturating_sub(1);
        self.with_source(&line[..n], caret_byte)
    }

    /// Attaches an excerpt of `line` with the caret under byte `caret_byte`
    /// (for tables, where the column is a field number, not a byte).
    pub fn with_source(mut self, line: &[u8], caret_byte: usize) -> Self {
        let (text, caret) = excerpt(line, caret_byte);
        self.source_line = text;
        self.caret = u16::try_from(caret).unwrap_or(u16::MAX);
        self
    }

    /// Attaches the file name.
    pub fn with_file(mut self, file: impl Into<String>) -> Self {
        self.file = Some(file.into());
        self
    }

    /// Draws the diagnostic: `file:line:column: message`, the excerpt with
    /// a caret (when there is one) and `help: …` (when there is help).
    pub fn render(&self, f: &mut impl fmt::Write) -> fmt::Result {
        let file = escape_name(self.file.as_deref().unwrap_or("<input>"));
        let line = self.line;
        write!(f, "{file}:{line}:{}: {}", self.column, self.message)?;
        if !self.source_line.is_empty() {
            let gutter = line.to_string().len();
            write!(f, "\n{:gutter$} |\n{line} | {}", "", self.source_line)?;
            let pad = " ".repeat(usize::from(self.caret));
            write!(f, "\n{:gutter$} | {pad}^", "")?;
        }
        if !self.help.is_empty() {
            write!(f, "\n  help: {}", self.help)?;
        }
        Ok(())
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.render(f)
    }
}

impl std::error::Error for Diagnostic {}

/// The error of every fallible operation of volcomp-gcode that a user's
/// input can cause: a [`Diagnostic`] (where, what, what to do) and its
/// [`ErrorClass`].
///
/// It dereferences to its diagnostic, so `e.line`, `e.message` and
/// `e.help` read (and write) the diagnostic's fields.
///
/// ```
/// use volcomp_gcode::{GcodeError, ErrorClass};
/// let e = GcodeError::new(ErrorClass::Invalid, 3, 5, "bad word", "fix it")
///     .with_source_line(b"G1 X#1")
///     .with_file("part.ngc");
/// assert!(e.to_string().starts_with("part.ngc:3:5: bad word"));
/// assert_eq!((e.line, e.column), (3, 5));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GcodeError {
    /// Kind of failure.
    pub class: ErrorClass,
    /// Where it is, what is wrong and what to do (boxed, so that a
    /// `Result<_, GcodeError>` stays two words wide on the success path).
    pub diagnostic: Box<Diagnostic>,
}

impl GcodeError {
    /// A new error at a 1-based line and column.
    pub fn new(
        class: ErrorClass,
        line: u64,
        column: usize,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        Self {
            class,
            diagnostic: Box::new(Diagnostic::new(line, column, message, help)),
        }
    }

    /// Attaches an excerpt of the source line around the error's column
    /// (line ending stripped; see [`excerpt`]).
    pub fn with_source_line(mut self, line: &[u8]) -> Self {
        *self.diagnostic = std::mem::take(&mut *self.diagnostic).with_source_line(line);
        self
    }

    /// Attaches the file name.
    pub fn with_file(mut self, file: impl Into<String>) -> Self {
        self.diagnostic.file = Some(file.into());
        self
    }
}

impl std::ops::Deref for GcodeError {
    type Target = Diagnostic;
    fn deref(&self) -> &Diagnostic {
        &self.diagnostic
    }
}

impl std::ops::DerefMut for GcodeError {
    fn deref_mut(&mut self) -> &mut Diagnostic {
        &mut self.diagnostic
    }
}

impl fmt::Display for GcodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.diagnostic.render(f)
    }
}

impl std::error::Error for GcodeError {}

/// Where a located diagnostic points, for callers that hold borrowed text:
/// file, 1-based line and column, and the source line with the byte offset
/// of the caret in it. [`render_located`] turns it into a [`Diagnostic`].
#[derive(Debug, Clone, Copy)]
pub struct Location<'a> {
    /// File name as the user gave it.
    pub file: &'a str,
    /// 1-based line (row).
    pub line: u64,
    /// 1-based column: byte column in a program, field number in a table.
    pub column: usize,
    /// The offending line (may be empty: then no excerpt is shown).
    pub source_line: &'a str,
    /// Byte offset in `source_line` under which the caret is drawn.
    pub caret_byte: usize,
}

impl Location<'_> {
    /// The diagnostic at this location.
    pub fn diagnostic(&self, message: &str, help: &str) -> Diagnostic {
        Diagnostic::new(self.line, self.column, message, help)
            .with_file(self.file)
            .with_source(self.source_line.as_bytes(), self.caret_byte)
    }
}

/// Renders a located diagnostic the one way volcomp shows every located
/// error ([`Diagnostic::render`]): `file:line:column: message`, the source
/// line with a caret under the column (bounded and escaped, see
/// [`excerpt`]), and `help: …`.
pub fn render_located(
    f: &mut impl fmt::Write,
    at: &Location<'_>,
    message: &str,
    help: &str,
) -> fmt::Result {
    at.diagnostic(message, help).render(f)
}

/// Bytes of a line shown on each side of an error's column at most.
pub const EXCERPT_BYTES: usize = 60;

/// `text` with its control characters but the line feed written as `\t`,
/// `\r` or `\xNN` (the escape of `ESC` is `\x1b`): messages that carry
/// file names and values a user gave are printed through it, so that none
/// of their bytes drives the terminal. Text without control characters is
/// borrowed as it is.
///
/// ```
/// use volcomp_gcode::error::escape_controls;
/// assert_eq!(escape_controls("a\x1b[2Jb.csv"), "a\\x1b[2Jb.csv");
/// assert_eq!(escape_controls("line 1\nline 2"), "line 1\nline 2");
/// ```
pub fn escape_controls(text: &str) -> std::borrow::Cow<'_, str> {
    escape(text, true)
}

/// A name (a file name, a column name) as printed: every control
/// character written as `\t`, `\r`, `\n` or `\xNN`.
///
/// ```
/// use volcomp_gcode::error::escape_name;
/// assert_eq!(escape_name("a\nb.ngc"), "a\\nb.ngc");
/// ```
pub fn escape_name(text: &str) -> std::borrow::Cow<'_, str> {
    escape(text, false)
}

fn escape(text: &str, keep_newline: bool) -> std::borrow::Cow<'_, str> {
    let kept = |c: char| keep_newline && c == '\n';
    if !text.chars().any(|c| c.is_control() && !kept(c)) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            c if kept(c) => out.push(c),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => {
                let mut buf = [0u8; 4];
                for b in c.encode_utf8(&mut buf).bytes() {
                    out.push_str(&format!("\\x{b:02x}"));
                }
            }
            c => out.push(c),
        }
    }
    std::borrow::Cow::Owned(out)
}

/// A printable excerpt of `line` around byte `column` (0-based), and how many
/// characters of it precede that byte (where the caret goes).
///
/// At most [`EXCERPT_BYTES`] bytes are kept on each side of the column; a cut
/// is marked with `…`. Tabs are shown as `\t`, other control characters
/// (ESC, BEL, NUL, DEL, …) and bytes that are not valid UTF-8 as `\xNN`:
/// printing them raw would let a program's bytes drive the terminal.
///
/// ```
/// let (text, caret) = volcomp_gcode::error::excerpt(b"G0 X1 \x1b[31m", 6);
/// assert_eq!(text, "G0 X1 \\x1b[31m");
/// assert_eq!(caret, 6);
/// ```
pub fn excerpt(line: &[u8], column: usize) -> (String, usize) {
    let column = column.min(line.len());
    let mut start = column.saturating_sub(EXCERPT_BYTES);
    let mut end = (column + EXCERPT_BYTES).min(line.len());
    // Cut on character boundaries where the bytes are UTF-8.
    while start > 0 && start < line.len() && (line[start] & 0xC0) == 0x80 {
        start -= 1;
    }
    while end < line.len() && (line[end] & 0xC0) == 0x80 {
        end += 1;
    }
    let mut out = String::new();
    let mut caret = 0;
    if start > 0 {
        out.push('…');
        caret += 1;
    }
    let mut i = start;
    let mut push = |s: &str, before: bool, out: &mut String| {
        out.push_str(s);
        if before {
            caret += s.chars().count();
        }
    };
    while i < end {
        let before = i < column;
        let b = line[i];
        let width = match b {
            0x00..=0x7F => 1,
            0xC2..=0xDF => 2,
            0xE0..=0xEF => 3,
            0xF0..=0xF4 => 4,
            _ => 0,
        };
        let ch = (width > 0 && i + width <= end)
            .then(|| std::str::from_utf8(&line[i..i + width]).ok())
            .flatten()
            .and_then(|s| s.chars().next());
        match ch {
            Some('\t') => push("\\t", before, &mut out),
            Some(c) if c.is_control() => {
                let mut esc = String::new();
                for byte in &line[i..i + width] {
                    esc.push_str(&format!("\\x{byte:02x}"));
                }
                push(&esc, before, &mut out)
            }
            Some(c) => push(c.encode_utf8(&mut [0u8; 4]), before, &mut out),
            None => {
                push(&format!("\\x{b:02x}"), before, &mut out);
                i += 1;
                continue;
            }
        }
        i += width;
    }
    if end < line.len() {
        out.push('…');
    }
    (out, caret)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpt_of_a_huge_line_is_bounded_and_marks_both_cuts() {
        let mut line = vec![b'X'; 10_000_000];
        line[5_000_000] = b'#';
        let (text, caret) = excerpt(&line, 5_000_000);
        assert_eq!(text.chars().count(), 2 * EXCERPT_BYTES + 2);
        assert!(text.starts_with('…') && text.ends_with('…'));
        assert_eq!(text.chars().nth(caret), Some('#'));
    }

    #[test]
    fn control_bytes_and_invalid_utf8_are_escaped() {
        let (text, caret) = excerpt(b"G1\x07 X\xe92 (caf\xc3\xa9)\x1b", 5);
        assert_eq!(text, "G1\\x07 X\\xe92 (café)\\x1b");
        // The caret sits under the escaped byte: `G1\x07 X` is 8 characters.
        assert_eq!(caret, 8);
        assert!(!text.chars().any(char::is_control));
    }

    #[test]
    fn a_table_location_renders_in_the_same_shape() {
        // Row 12, field 3 of a CSV line: the caret goes under the byte the
        // caller names (the start of the third field), not under byte 3.
        let mut shown = String::new();
        let at = Location {
            file: "x.csv",
            line: 12,
            column: 3,
            source_line: "100,0.5,abc",
            caret_byte: 8,
        };
        render_located(&mut shown, &at, "`abc` is not a number", "write 1.5").unwrap();
        assert_eq!(
            shown,
            "x.csv:12:3: `abc` is not a number\n   |\n12 | 100,0.5,abc\n   |         ^\n  help: write 1.5"
        );
        assert_eq!(
            at.diagnostic("`abc` is not a number", "write 1.5")
                .to_string(),
            shown
        );
    }

    #[test]
    fn a_diagnostic_without_file_excerpt_or_help_is_one_line() {
        let d = Diagnostic::new(4, 1, "program ends without M2", "");
        assert_eq!(d.to_string(), "<input>:4:1: program ends without M2");
        let e = GcodeError::new(ErrorClass::Io, 9, 2, "cannot read", "check it").with_file("a.ngc");
        assert_eq!((e.line, e.column, e.file.as_deref()), (9, 2, Some("a.ngc")));
        assert_eq!(e.to_string(), "a.ngc:9:2: cannot read\n  help: check it");
    }

    #[test]
    fn display_puts_the_caret_under_the_column() {
        let e = GcodeError::new(ErrorClass::Invalid, 7, 5, "bad", "")
            .with_source_line(b"\x1bG1 #1\r\n");
        let shown = e.to_string();
        assert!(shown.contains("7 | \\x1bG1 #1"), "{shown}");
        assert!(shown.contains("  |        ^"), "{shown}");
        assert!(!shown.contains('\x1b'));
    }
}
