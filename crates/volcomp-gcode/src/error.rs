//! Errors that point at the file, line and column, show the line and say what to do.

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

/// A located error in a G-code program.
///
/// ```
/// use volcomp_gcode::{GcodeError, ErrorClass};
/// let e = GcodeError::new(ErrorClass::Invalid, 3, 5, "bad word", "fix it")
///     .with_source_line(b"G1 X#1")
///     .with_file("part.ngc");
/// assert!(e.to_string().starts_with("part.ngc:3:5: bad word"));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GcodeError {
    /// Kind of failure.
    pub class: ErrorClass,
    /// File name, when known.
    pub file: Option<String>,
    /// 1-based line number.
    pub line: u64,
    /// 1-based column (byte) in the line.
    pub column: usize,
    /// An excerpt of the offending line around the column (at most about
    /// [`EXCERPT_BYTES`] bytes, cut with `…`), control characters and bytes
    /// that are not UTF-8 written as escapes (`\x1b`), so a hostile or binary
    /// line can neither flood nor drive the terminal.
    pub source_line: String,
    /// Characters of `source_line` before the caret (the excerpt is bounded,
    /// so this is small).
    pub caret: u16,
    /// What is wrong.
    pub message: String,
    /// What to do about it.
    pub help: String,
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
            file: None,
            line,
            column,
            source_line: String::new(),
            caret: 0,
            message: message.into(),
            help: help.into(),
        }
    }

    /// Attaches an excerpt of the source line around the error's column
    /// (line ending stripped; see [`excerpt`]).
    pub fn with_source_line(mut self, line: &[u8]) -> Self {
        let n = crate::lexer::content_len(line);
        let (text, caret) = excerpt(&line[..n], self.column.saturating_sub(1));
        self.source_line = text;
        self.caret = u16::try_from(caret).unwrap_or(u16::MAX);
        self
    }

    /// Attaches the file name.
    pub fn with_file(mut self, file: impl Into<String>) -> Self {
        self.file = Some(file.into());
        self
    }
}

impl fmt::Display for GcodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let file = self.file.as_deref().unwrap_or("<input>");
        render_excerpt(
            f,
            file,
            self.line,
            self.column,
            &self.source_line,
            usize::from(self.caret),
            &self.message,
            &self.help,
        )
    }
}

/// Where a located diagnostic points: file, 1-based line and column, and the
/// source line with the byte offset of the caret in it.
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

/// Renders a located diagnostic the one way volcomp shows every located
/// error: `file:line:column: message`, the source line with a caret under
/// the column (bounded and escaped, see [`excerpt`]), and `help: …`.
pub fn render_located(
    f: &mut impl fmt::Write,
    at: &Location<'_>,
    message: &str,
    help: &str,
) -> fmt::Result {
    let (text, caret) = excerpt(at.source_line.as_bytes(), at.caret_byte);
    render_excerpt(f, at.file, at.line, at.column, &text, caret, message, help)
}

/// The one shape of a located diagnostic, given an excerpt already bounded
/// and escaped by [`excerpt`] and the caret's character offset in it.
#[allow(clippy::too_many_arguments)]
fn render_excerpt(
    f: &mut impl fmt::Write,
    file: &str,
    line: u64,
    column: usize,
    text: &str,
    caret: usize,
    message: &str,
    help: &str,
) -> fmt::Result {
    write!(f, "{file}:{line}:{column}: {message}")?;
    if !text.is_empty() {
        let gutter = line.to_string().len();
        write!(f, "\n{:gutter$} |\n{line} | {text}", "")?;
        write!(f, "\n{:gutter$} | {}^", "", " ".repeat(caret))?;
    }
    if !help.is_empty() {
        write!(f, "\n  help: {help}")?;
    }
    Ok(())
}

impl std::error::Error for GcodeError {}

/// Bytes of a line shown on each side of an error's column at most.
pub const EXCERPT_BYTES: usize = 60;

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
    fn display_puts_the_caret_under_the_column() {
        let e = GcodeError::new(ErrorClass::Invalid, 7, 5, "bad", "")
            .with_source_line(b"\x1bG1 #1\r\n");
        let shown = e.to_string();
        assert!(shown.contains("7 | \\x1bG1 #1"), "{shown}");
        assert!(shown.contains("  |        ^"), "{shown}");
        assert!(!shown.contains('\x1b'));
    }
}
