//! Streaming a program line by line: read, lex, interpret.
//!
//! Memory does not grow with the program: one line buffer, one token buffer
//! and the motions of the current line are reused for every line.

use crate::error::{ErrorClass, GcodeError};
use crate::interp::{InterpOptions, Interpreter, Motion};
use crate::lexer::{self, LexErrorKind, Lexed, LineKind};
use crate::setup::Setup;
use std::io::BufRead;

/// One line of the program after it has been executed.
pub struct LineEvent<'a> {
    /// 1-based line number.
    pub number: u64,
    /// The line's bytes, including its line ending.
    pub bytes: &'a [u8],
    /// What kind of line it is.
    pub kind: LineKind,
    /// Its tokens (empty for `%` and program-number lines).
    pub lexed: &'a Lexed,
    /// The motions it produced, in order.
    pub motions: &'a [Motion],
    /// The interpreter after the line (its modal state applies to the line's motions).
    pub interp: &'a Interpreter,
    /// Whether the line lies after the program end and was not executed.
    pub after_end: bool,
}

/// Reads, lexes and interprets a program one line at a time.
pub struct Walker<R> {
    reader: R,
    file: Option<String>,
    number: u64,
    buf: Vec<u8>,
    lexed: Lexed,
    motions: Vec<Motion>,
    interp: Interpreter,
}

impl<R: BufRead> Walker<R> {
    /// Starts reading `reader`; `file` names it in error messages.
    pub fn new(reader: R, file: Option<String>, setup: Setup, options: InterpOptions) -> Self {
        Self {
            reader,
            file,
            number: 0,
            buf: Vec::with_capacity(256),
            lexed: Lexed::default(),
            motions: Vec::with_capacity(16),
            interp: Interpreter::new(setup, options),
        }
    }

    /// What was assumed because the program did not say it, so far.
    pub fn warnings(&self) -> &[crate::interp::Warning] {
        self.interp.warnings()
    }

    /// The interpreter (state after the last line read).
    pub fn interpreter(&self) -> &Interpreter {
        &self.interp
    }

    fn locate(&self, e: GcodeError) -> GcodeError {
        let e = e.with_source_line(&self.buf);
        match &self.file {
            Some(f) => e.with_file(f.clone()),
            None => e,
        }
    }

    /// The next line, or `None` at the end of the input.
    pub fn next_line(&mut self) -> Result<Option<LineEvent<'_>>, GcodeError> {
        self.buf.clear();
        self.motions.clear();
        self.lexed.tokens.clear();
        let n = self.reader.read_until(b'\n', &mut self.buf).map_err(|e| {
            let err = GcodeError::new(
                ErrorClass::Io,
                self.number + 1,
                1,
                format!("cannot read: {e}"),
                "check that the file is readable",
            );
            match &self.file {
                Some(f) => err.with_file(f.clone()),
                None => err,
            }
        })?;
        if n == 0 {
            return Ok(None);
        }
        self.number += 1;
        let content = &self.buf[..lexer::content_len(&self.buf)];
        let kind = lexer::classify(content);
        let after_end = self.interp.finished();
        if !after_end {
            match kind {
                LineKind::Percent => self.interp.percent_line(),
                LineKind::ProgramNumber => {}
                LineKind::Block => {
                    if let Err(e) = lexer::lex_block(content, &mut self.lexed) {
                        let (msg, help) = lex_message(&e.kind);
                        let class = match e.kind {
                            LexErrorKind::Parameter
                            | LexErrorKind::Expression
                            | LexErrorKind::OWord => ErrorClass::Unsupported,
                            _ => ErrorClass::Invalid,
                        };
                        let err = GcodeError::new(class, self.number, e.column + 1, msg, help);
                        return Err(self.locate(err));
                    }
                    if let Err(e) = self
                        .interp
                        .execute(self.number, &self.lexed, &mut self.motions)
                    {
                        return Err(self.locate(e));
                    }
                }
            }
        }
        Ok(Some(LineEvent {
            number: self.number,
            bytes: &self.buf,
            kind,
            lexed: &self.lexed,
            motions: &self.motions,
            interp: &self.interp,
            after_end,
        }))
    }
}

fn lex_message(kind: &LexErrorKind) -> (String, String) {
    match kind {
        LexErrorKind::UnclosedComment => {
            ("comment is not closed".into(), "add the closing `)`".into())
        }
        LexErrorKind::NestedComment => (
            "nested comment".into(),
            "comments cannot contain `(`".into(),
        ),
        LexErrorKind::MissingNumber(c) => (
            format!("{c} word without a number"),
            "every letter needs a number, e.g. X10".into(),
        ),
        LexErrorKind::Parameter => (
            "`#` parameters are not interpreted by volcomp".into(),
            "post the program with numeric values (no variables)".into(),
        ),
        LexErrorKind::Expression => (
            "`[ ]` expressions are not interpreted by volcomp".into(),
            "post the program with numeric values (no expressions)".into(),
        ),
        LexErrorKind::OWord => (
            "o-word subroutines and control flow are not interpreted by volcomp".into(),
            "post the program with subroutines and loops expanded".into(),
        ),
        LexErrorKind::UnexpectedByte(0) => (
            "NUL byte in the program: this is a binary file, or text in UTF-16".into(),
            "save the program as plain text (ASCII or UTF-8)".into(),
        ),
        LexErrorKind::UnexpectedByte(b) if !b.is_ascii() => (
            format!("byte 0x{b:02X} is not ASCII: outside comments G-code is ASCII (the file may be in another encoding, such as Latin-1 or UTF-16)"),
            "remove the character or put it inside a comment; save the file as ASCII or UTF-8".into(),
        ),
        LexErrorKind::UnexpectedByte(b) if b.is_ascii_control() => (
            format!("control character 0x{b:02X} is not G-code"),
            "remove it; it may be a sign that the file is damaged or binary".into(),
        ),
        LexErrorKind::UnexpectedByte(b) => (
            format!("unexpected character {:?}", char::from(*b)),
            "remove it or put it inside a comment".into(),
        ),
        LexErrorKind::NumberTooLong => ("number too long".into(), "write at most 40 digits".into()),
    }
}
