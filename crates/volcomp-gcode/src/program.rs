//! Streaming a program line by line: read, lex, interpret.
//!
//! Memory does not grow with the program: one line buffer, one token buffer
//! and the motions of the current line are reused for every line.

use crate::error::{ErrorClass, GcodeError};
use crate::interp::{InterpOptions, Interpreter, Motion};
use crate::lexer::{self, Lexed, LineKind};
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
            if let Err(e) = self.interp.end_of_input(self.number) {
                return Err(match &self.file {
                    Some(f) => e.with_file(f.clone()),
                    None => e,
                });
            }
            return Ok(None);
        }
        self.number += 1;
        let content = &self.buf[..lexer::content_len(&self.buf)];
        let kind = lexer::classify(content);
        let after_end = self.interp.finished();
        if !after_end {
            match kind {
                LineKind::Percent => {
                    if let Err(e) = self.interp.percent_line(self.number) {
                        return Err(self.locate(e));
                    }
                }
                LineKind::ProgramNumber => self.interp.note_nonblank_line(),
                LineKind::Block => {
                    if let Err(e) = lexer::lex_block(content, &mut self.lexed) {
                        return Err(self.locate(e.at_line(self.number)));
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
