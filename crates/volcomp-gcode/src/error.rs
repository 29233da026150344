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
    /// The offending line, without its line ending.
    pub source_line: String,
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
            message: message.into(),
            help: help.into(),
        }
    }

    /// Attaches the source line (line ending stripped, invalid UTF-8 replaced).
    pub fn with_source_line(mut self, line: &[u8]) -> Self {
        let n = crate::lexer::content_len(line);
        self.source_line = String::from_utf8_lossy(&line[..n]).into_owned();
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
        let caret = self.column.saturating_sub(1);
        render_located(
            f,
            &Location {
                file,
                line: self.line,
                column: self.column,
                source_line: &self.source_line,
                caret_byte: caret,
            },
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

/// Characters of the source line shown at most on either side of the caret.
const EXCERPT_HALF_WIDTH: usize = 60;

/// A bounded, escaped excerpt of `line` around byte `caret_byte`: at most
/// `2 × EXCERPT_HALF_WIDTH` characters, `…` where the line was cut, control
/// characters shown as `\x1b`-style escapes so that no terminal escape
/// sequence of the input reaches the user's terminal. Returns the excerpt and
/// the caret's character offset in it.
///
/// ```
/// let (s, at) = volcomp_gcode::error::excerpt("G1 X\u{1b}[31m5", 4);
/// assert_eq!(s, "G1 X\\x1b[31m5");
/// assert_eq!(at, 4);
/// ```
pub fn excerpt(line: &str, caret_byte: usize) -> (String, usize) {
    let caret_byte = caret_byte.min(line.len());
    let caret_char = line
        .char_indices()
        .take_while(|(i, _)| *i < caret_byte)
        .count();
    let total = line.chars().count();
    let start = caret_char.saturating_sub(EXCERPT_HALF_WIDTH);
    let end = (caret_char + EXCERPT_HALF_WIDTH).min(total);
    let mut out = String::new();
    let mut at = 0;
    if start > 0 {
        out.push('…');
    }
    for (k, c) in line.chars().enumerate().skip(start).take(end - start) {
        if k == caret_char {
            at = out.chars().count();
        }
        if c.is_control() {
            out.push_str(&format!("\\x{:02x}", c as u32));
        } else {
            out.push(c);
        }
    }
    if caret_char >= end {
        at = out.chars().count();
    }
    if end < total {
        out.push('…');
    }
    (out, at)
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
    write!(f, "{}:{}:{}: {}", at.file, at.line, at.column, message)?;
    if !at.source_line.is_empty() {
        let (text, caret) = excerpt(at.source_line, at.caret_byte);
        let gutter = at.line.to_string().len();
        write!(f, "\n{:gutter$} |\n{} | {}", "", at.line, text)?;
        write!(f, "\n{:gutter$} | {}^", "", " ".repeat(caret))?;
    }
    if !help.is_empty() {
        write!(f, "\n  help: {help}")?;
    }
    Ok(())
}

impl std::error::Error for GcodeError {}
