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
        write!(f, "{file}:{}:{}: {}", self.line, self.column, self.message)?;
        if !self.source_line.is_empty() {
            let gutter = self.line.to_string().len();
            write!(
                f,
                "\n{:gutter$} |\n{} | {}",
                "", self.line, self.source_line
            )?;
            let caret_at = self
                .source_line
                .char_indices()
                .take_while(|(i, _)| *i + 1 < self.column)
                .count();
            write!(f, "\n{:gutter$} | {}^", "", " ".repeat(caret_at))?;
        }
        if !self.help.is_empty() {
            write!(f, "\n  help: {}", self.help)?;
        }
        Ok(())
    }
}

impl std::error::Error for GcodeError {}
