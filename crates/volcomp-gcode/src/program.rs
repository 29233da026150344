//! Running a program line by line: read, evaluate, lex, interpret.
//!
//! Lines come out **in execution order**. A program of literal lines is
//! streamed: one line buffer, one token buffer, the motions of the current
//! line; memory does not grow with the program. Lines with parameters or
//! expressions are evaluated and rendered as literal lines first
//! ([`crate::ngc`]); o-word control flow (and M98/M99) makes the walker
//! keep the program's lines from the first control statement on, so that
//! loops can go back and calls can find their subroutines, and yield each
//! executed line as often as it runs — a flat program.

use crate::error::{ErrorClass, GcodeError};
use crate::interp::{InterpOptions, Interpreter, Motion};
use crate::lexer::{self, Lexed, LineKind};
use crate::ngc::flow::{Flow, Pos, MAIN};
use crate::ngc::line::{self, Statement};
use crate::ngc::norm::Norm;
use crate::ngc::params::Scope;
use crate::ngc::source::Lines;
use crate::setup::Setup;
use std::io::BufRead;
use std::path::PathBuf;
use std::sync::Arc;

/// Longest line LinuxCNC reads, line ending included (`LINELEN` − 2 =
/// 253 bytes with its `\n`; `Interp::read`, rs274ngc_pre.cc).
const MAX_LINE_BYTES: usize = 252;

/// Whether LinuxCNC refuses `line` (with its ending) as "Command too long":
/// `fgets` into a 255-byte buffer, refused when it fills 254 bytes.
fn too_long(line: &[u8]) -> bool {
    let with_newline = line.len() + usize::from(!line.ends_with(b"\n"));
    with_newline >= MAX_LINE_BYTES + 2
}

/// Line `p` of the main program or a subroutine file, if held.
#[inline]
fn bytes_of<'a>(main: &'a Lines, flow: &'a crate::ngc::flow::Flow, p: Pos) -> Option<&'a [u8]> {
    if p.src == MAIN {
        main.get(p.line)
    } else {
        flow.lines(p.src).and_then(|l| l.get(p.line))
    }
}

/// The message of an `(abort, …)` comment, which ends the program with an
/// error in LinuxCNC (`convert_comment`, interp_convert.cc).
fn abort_comment(content: &[u8], lexed: &Lexed) -> Option<String> {
    lexed.tokens.iter().find_map(|t| match t {
        lexer::Token::Comment(r) => {
            let text = String::from_utf8_lossy(&content[r.start + 1..r.end - 1]);
            let t = text.trim_start();
            (t.len() >= 6 && t.is_char_boundary(6) && t[..6].eq_ignore_ascii_case("abort,"))
                .then(|| t[6..].trim().to_string())
        }
        _ => None,
    })
}

/// One line of the program after it has been executed.
pub struct LineEvent<'a> {
    /// 1-based line number in its file.
    pub number: u64,
    /// The subroutine file the line comes from (`None`: the program itself).
    pub file: Option<&'a str>,
    /// The line's bytes, including its line ending: the original bytes, or
    /// for a line with parameters or expressions the literal line they
    /// evaluated to.
    pub bytes: &'a [u8],
    /// Whether `bytes` were rendered from a line with parameters or
    /// expressions.
    pub rendered: bool,
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
    /// The line the walker runs next, as far as its text is known without
    /// reading or running anything ([`NextLine::bytes`]).
    pub next: NextLine<'a>,
}

/// A peek at the line a walker runs after the event's line: its text where
/// that is the main program's next line, already read into the walker's
/// buffer, with no control flow, no line LinuxCNC injects and no program
/// end between. Nothing is looked up until asked ([`NextLine::bytes`]): an
/// event carries one pointer for it.
#[derive(Clone, Copy)]
pub struct NextLine<'a>(Option<&'a dyn ReadAhead>);

impl<'a> NextLine<'a> {
    /// A next line not known (a line built outside a walker).
    pub fn unknown() -> Self {
        NextLine(None)
    }

    /// The next line's bytes with their ending, where known.
    pub fn bytes(&self) -> Option<&'a [u8]> {
        self.0.and_then(|w| w.next_bytes())
    }
}

/// A walker, read ahead without running anything ([`NextLine`]).
trait ReadAhead {
    fn next_bytes(&self) -> Option<&[u8]>;
}

impl<R: BufRead> ReadAhead for Walker<R> {
    /// The main program's line after the current one where it runs next
    /// and is already read; `None` otherwise. Reads nothing.
    fn next_bytes(&self) -> Option<&[u8]> {
        let pos = self.current;
        let next = Pos {
            src: MAIN,
            line: pos.line + 1,
        };
        // The line after an injected one (`Flow::next_injected`) is the
        // caller's: `flow.pos` is then not the line after the return.
        if pos.src != MAIN
            || self.flow.pos != next
            || self.flow.has_injected()
            || self.interp.finished()
        {
            return None;
        }
        self.main.get(next.line)
    }
}

impl LineEvent<'_> {
    /// Whether the line run after this one may move along an arc (G2,
    /// G3), read from its text ([`LineEvent::next`]) and the modal motion
    /// after this line: `true` where the next line is not known, where the
    /// modal motion is an arc (a line without a motion word continues
    /// it), or where the text does not rule an arc out. Conservative: only
    /// `false` is a statement (no G2/G3 word, no motion word the text does
    /// not show: no parameter `#`, no expression `[`, no o-word, no M70–M73
    /// (the modal state saved and restored), M98/M99 (calls, returns)).
    // Not inlined: asked once per line that may wait, it would otherwise
    // grow its caller's hot function (compensate's line writer).
    #[inline(never)]
    pub fn next_may_start_arc(&self) -> bool {
        match self.next.bytes() {
            Some(bytes) if !self.after_end => self.interp.arc_mode() || text_may_start_arc(bytes),
            _ => true,
        }
    }
}

/// Whether the literal line `bytes` may name an arc motion or change the
/// modal state or flow beyond what its text shows (see
/// [`LineEvent::next_may_start_arc`]). LinuxCNC reads a line without its
/// spaces and tabs outside comments, in either case (`close_and_downcase`,
/// rs274ngc_pre.cc): `g 0 2` is G2. Comments `( … )` and what follows `;`
/// are skipped; an unclosed comment, a signed or fractional code this scan
/// does not read, is taken as a possible arc.
///
/// The bytes between those it stops at are passed over by a lookup in
/// [`PEEK_STOPS`] (a CAM line is mostly digits, axis letters, signs and
/// points): a load and a test a byte instead of the match's comparisons.
fn text_may_start_arc(bytes: &[u8]) -> bool {
    let mut i = 0;
    while i < bytes.len() {
        let Some(k) = bytes[i..].iter().position(|&c| PEEK_STOPS[usize::from(c)]) else {
            return false;
        };
        let c = bytes[i + k];
        i += k + 1;
        match c {
            b'(' => match memchr::memchr(b')', &bytes[i..]) {
                Some(k) => i += k + 1,
                None => return true,
            },
            b';' => return false,
            b'#' | b'[' | b'o' | b'O' => return true,
            b'g' | b'G' => {
                let v = code_x10(&bytes[i..]);
                if v.is_none_or(|v| v == 20 || v == 30) {
                    return true;
                }
            }
            b'm' | b'M' => {
                let v = code_x10(&bytes[i..]);
                if v.is_none_or(|v| matches!(v, 700 | 710 | 720 | 730 | 980 | 990)) {
                    return true;
                }
            }
            _ => {}
        }
    }
    false
}

/// The bytes [`text_may_start_arc`] acts on: a comment's start, `;`, `#`,
/// `[`, an o-word's letter and the G and M words' letters, in either case.
/// Any other byte is passed over.
const PEEK_STOPS: [bool; 256] = {
    let mut table = [false; 256];
    let stops = b"(;#[oOgGmM";
    let mut k = 0;
    while k < stops.len() {
        table[stops[k] as usize] = true;
        k += 1;
    }
    table
};

/// Ten times the code written at the start of `rest` (after a G or M),
/// spaces and tabs skipped: `Some` only for digits with at most one
/// non-zero decimal (`2`, `02`, `2.0`, `64.1`); `None` for anything else
/// (a sign, no digits, a second decimal, a number too large).
fn code_x10(rest: &[u8]) -> Option<u32> {
    let mut value: u32 = 0;
    let mut digits = 0;
    let mut decimals = 0;
    for &c in rest {
        match c {
            b' ' | b'\t' => {}
            b'0'..=b'9' if decimals == 0 => {
                value = value.checked_mul(10)?.checked_add(u32::from(c - b'0'))?;
                digits += 1;
            }
            b'.' if decimals == 0 => decimals = 1,
            b'0'..=b'9' if decimals == 1 => {
                value = value.checked_mul(10)?.checked_add(u32::from(c - b'0'))?;
                decimals = 2;
            }
            // A second decimal: only zeros are read (`2.00`).
            b'0' => {}
            b'1'..=b'9' => return None,
            _ => break,
        }
    }
    if digits == 0 {
        return None;
    }
    Some(if decimals == 2 {
        value
    } else {
        value.checked_mul(10)?
    })
}

/// Reads, evaluates, lexes and interprets a program one line at a time.
pub struct Walker<R> {
    pub(crate) reader: R,
    pub(crate) file: Option<String>,
    /// The main program's lines (only the current one until control flow
    /// needs more).
    pub(crate) main: Lines,
    pub(crate) flow: Flow,
    pub(crate) buf: Vec<u8>,
    pub(crate) rendered: bool,
    lexed: Lexed,
    motions: Vec<Motion>,
    pub(crate) interp: Interpreter,
    /// The line the last event came from.
    pub(crate) current: Pos,
    /// Where lines after the program end are copied from (main program).
    pub(crate) after_end_at: Option<usize>,
    /// Statements of lines that control flow may run again (loop bodies,
    /// subroutines), parsed once: a line's statement depends on its text
    /// alone. At most [`MAX_CACHED_STATEMENTS`].
    statements: crate::ngc::Map<(usize, usize), Arc<Statement>>,
}

/// Statements kept parsed (a bound on the memory the cache takes).
const MAX_CACHED_STATEMENTS: usize = 4096;

impl<R: BufRead> Walker<R> {
    /// Starts reading `reader`; `file` names it in error messages.
    pub fn new(reader: R, file: Option<String>, setup: Setup, options: InterpOptions) -> Self {
        // As in LinuxCNC, subroutine files are looked for only on the
        // subroutine path (its SUBROUTINE_PATH), not beside the program.
        let dirs: Vec<PathBuf> = setup.subroutine_path.clone();
        let mut flow = Flow::new(dirs, options.max_executed_lines);
        for (&n, &v) in &setup.parameters {
            flow.params.preset(n, v);
        }
        Self {
            reader,
            file,
            main: Lines::default(),
            flow,
            buf: Vec::with_capacity(256),
            rendered: false,
            lexed: Lexed::default(),
            motions: Vec::with_capacity(16),
            interp: Interpreter::new(setup, options),
            current: Pos { src: MAIN, line: 0 },
            after_end_at: None,
            statements: crate::ngc::Map::default(),
        }
    }

    /// What was assumed because the program did not say it, so far.
    pub fn warnings(&self) -> &[crate::interp::Warning] {
        self.interp.warnings()
    }

    pub(crate) fn lexed_ref(&self) -> &Lexed {
        &self.lexed
    }

    /// The interpreter (state after the last line read).
    pub fn interpreter(&self) -> &Interpreter {
        &self.interp
    }

    /// The name of the file of source `src`.
    pub(crate) fn file_name(&self, src: usize) -> Option<String> {
        if src == MAIN {
            self.file.clone()
        } else {
            self.flow.file_name(src).map(str::to_string)
        }
    }

    /// `e` located in the current line (its file, its original text).
    pub(crate) fn locate(&self, e: GcodeError) -> GcodeError {
        let e = match self.line_bytes(self.current) {
            Some(bytes) => e.with_source_line(bytes),
            None => e,
        };
        match self.file_name(self.current.src) {
            Some(f) => e.with_file(f),
            None => e,
        }
    }

    pub(crate) fn line_bytes(&self, p: Pos) -> Option<&[u8]> {
        bytes_of(&self.main, &self.flow, p)
    }

    /// Makes line `p` available (reads the main program up to it).
    #[inline]
    pub(crate) fn fetch(&mut self, p: Pos) -> Result<bool, GcodeError> {
        if p.src == MAIN {
            if let Err(e) = self.main.fill_to(&mut self.reader, p.line) {
                return Err(self.read_error(p, e));
            }
            return Ok(self.main.holds(p.line));
        }
        Ok(self.line_bytes(p).is_some())
    }

    /// The error of reading the main program up to line `p`.
    #[cold]
    fn read_error(&self, p: Pos, e: std::io::Error) -> GcodeError {
        let err = if e.kind() == std::io::ErrorKind::InvalidData {
            // A line too long to hold: the line after those held.
            GcodeError::new(
                ErrorClass::Invalid,
                self.main.read_so_far() as u64 + 1,
                MAX_LINE_BYTES + 1,
                e.to_string(),
                "split the line, or shorten its comment",
            )
        } else {
            GcodeError::new(
                ErrorClass::Io,
                p.line as u64 + 1,
                1,
                format!("cannot read: {e}"),
                "check that the file is readable",
            )
        };
        match &self.file {
            Some(f) => err.with_file(f.clone()),
            None => err,
        }
    }

    /// The next line, or `None` at the end of the input.
    pub fn next_line(&mut self) -> Result<Option<LineEvent<'_>>, GcodeError> {
        self.motions.clear();
        self.lexed.tokens.clear();
        loop {
            if self.interp.finished() {
                return self.next_after_end();
            }
            // Lines LinuxCNC generates in place of a return
            // (an M73 restore), run as a rendered line of the return.
            if let Some(text) = self.flow.next_injected() {
                let line = self.current.line as u64 + 1;
                self.buf.clear();
                self.buf.extend_from_slice(text.as_bytes());
                self.rendered = true;
                let n = lexer::content_len(&self.buf);
                if let Err(e) = lexer::lex_block(&self.buf[..n], &mut self.lexed) {
                    return Err(self.locate_rendered(e.at_line(line)));
                }
                if let Err(e) = self.interp.execute(line, &self.lexed, &mut self.motions) {
                    return Err(self.locate_rendered(e));
                }
                return Ok(Some(self.event(self.current, LineKind::Block, false)));
            }
            let pos = self.flow.pos;
            if !self.flow.keeps_lines() && pos.src == MAIN {
                // Nothing jumps back: the line before is done with.
                self.main.forget_before(pos.line);
            }
            if !self.fetch(pos)? {
                self.end_of_source(pos)?;
                if self.interp.finished() {
                    continue;
                }
                return Ok(None);
            }
            self.current = pos;
            self.flow.pos.line += 1;
            if let Err(e) = self.flow.count_line(pos) {
                return Err(self.locate(e));
            }
            if let Some(ev_kind) = self.prepare(pos)? {
                return Ok(Some(self.event(pos, ev_kind, false)));
            }
        }
    }

    #[inline]
    fn event(&self, pos: Pos, kind: LineKind, after_end: bool) -> LineEvent<'_> {
        LineEvent {
            number: pos.line as u64 + 1,
            file: if pos.src == MAIN {
                None
            } else {
                self.flow.file_name(pos.src)
            },
            bytes: if self.rendered {
                &self.buf
            } else {
                bytes_of(&self.main, &self.flow, pos).unwrap_or(&[])
            },
            rendered: self.rendered,
            kind,
            lexed: &self.lexed,
            motions: &self.motions,
            interp: &self.interp,
            after_end,
            next: NextLine((!after_end).then_some(self as &dyn ReadAhead)),
        }
    }

    /// Evaluates, lexes and executes line `pos`; `None` when it yields no
    /// event (control statements, parameter settings alone).
    fn prepare(&mut self, pos: Pos) -> Result<Option<LineKind>, GcodeError> {
        self.rendered = false;
        // For speed, the line is looked up once on the common path.
        let original = bytes_of(&self.main, &self.flow, pos).unwrap_or(&[]);
        let content_len = lexer::content_len(original);
        if original.len() > MAX_LINE_BYTES && too_long(original) {
            return Err(self.too_long_error(pos, original, content_len));
        }
        let content = &original[..content_len];
        // A literal line is lexed where it was read: one pass, no copy. The
        // lexer stops at the first `#`, `[` or o-word and notes them in
        // comments; only then is the line looked at as a whole. A line the
        // lexer reads is a block: a `%` line or a program number stops it
        // at its first character, so it is classified only then.
        let lexed = lexer::lex_block(content, &mut self.lexed);
        if lexed.is_ok() && !self.lexed.ngc_in_comment {
            self.check_block(pos, content)?;
            return self.execute_block(pos);
        }
        let kind = lexer::classify(content);
        match kind {
            LineKind::Percent => {
                if pos.src == MAIN {
                    // The line's text decides `%` alone vs. stray.
                    let r = self.interp.percent_line(pos.line as u64 + 1, content);
                    r.map_err(|e| self.locate(e))?;
                }
                return Ok(Some(kind));
            }
            LineKind::ProgramNumber => {
                self.interp.note_nonblank_line();
                self.flow.keep_lines();
                return Ok(Some(kind));
            }
            LineKind::Block => {}
        }
        if let Err(e) = lexed {
            if !line::needs_ngc(content) {
                let e = e.at_line(pos.line as u64 + 1);
                return Err(self.locate(e));
            }
        }
        self.prepare_ngc(pos, content_len)
    }

    /// The refusal of line `pos`, too long for LinuxCNC's reader.
    #[cold]
    fn too_long_error(&self, pos: Pos, original: &[u8], content_len: usize) -> GcodeError {
        // The ending counts: LinuxCNC's fgets holds 253 bytes of a line
        // and its ending, so a CR LF line may have one character less
        // (checked against rs274: 252 characters and CR LF are refused).
        let crlf = original[content_len..].starts_with(b"\r");
        let (ending, most, help) = if crlf {
            (" and ends in CR LF", MAX_LINE_BYTES - 1, "split the line, or shorten its comment; saved with LF endings it may have one character more")
        } else {
            ("", MAX_LINE_BYTES, "split the line, or shorten its comment")
        };
        let e = GcodeError::new(
            ErrorClass::Invalid,
            pos.line as u64 + 1,
            most + 1,
            format!(
                "the line is {content_len} characters long{ending}; LinuxCNC reads {most} characters at most before {} (\"Command too long\")",
                if crlf { "CR LF" } else { "LF" }
            ),
            help,
        );
        self.locate(e)
    }

    /// Line `pos` with parameters, expressions or control flow (the lexer
    /// stopped at them): evaluated as a whole, rendered as a literal line
    /// when it is a block, lexed again and executed.
    fn prepare_ngc(
        &mut self,
        pos: Pos,
        content_len: usize,
    ) -> Result<Option<LineKind>, GcodeError> {
        self.buf.clear();
        let stmt = match self.statements.get(&(pos.src, pos.line)) {
            Some(stmt) => Arc::clone(stmt),
            None => {
                let original = bytes_of(&self.main, &self.flow, pos).unwrap_or(&[]);
                let norm = Norm::of(&original[..content_len]);
                let stmt = line::parse(&norm).map_err(|e| self.expr_error(pos, e))?;
                let stmt = Arc::new(stmt);
                if self.flow.keeps_lines() && self.statements.len() < MAX_CACHED_STATEMENTS {
                    self.statements
                        .insert((pos.src, pos.line), Arc::clone(&stmt));
                }
                stmt
            }
        };
        match &*stmt {
            Statement::OWord(o) => {
                self.flow.keep_lines();
                self.control(pos, o)?;
                return Ok(None);
            }
            Statement::Block { words, settings } => {
                if !words.is_empty() || !settings.is_empty() {
                    let line_no = pos.line as u64 + 1;
                    let mut out = std::mem::take(&mut self.buf);
                    let values = {
                        let scope = Scope {
                            params: &self.flow.params,
                            interp: &self.interp,
                            line: line_no,
                        };
                        let original = self.line_bytes(pos).unwrap_or(&[]);
                        line::render(
                            &original[..content_len],
                            words,
                            settings,
                            &scope,
                            // Computed values in the program's decimals.
                            self.interp.computed_decimals(),
                            &mut out,
                        )
                    };
                    let values = values.map_err(|e| self.expr_error(pos, e))?;
                    let original = self.line_bytes(pos).unwrap_or(&[]);
                    out.extend_from_slice(&original[content_len..]);
                    self.buf = out;
                    self.rendered = true;
                    // Settings take effect after the line is read.
                    self.flow
                        .apply_settings(settings, &values, &self.interp)
                        .map_err(|e| self.expr_error(pos, e))?;
                    if words.is_empty()
                        && self.buf[..lexer::content_len(&self.buf)]
                            .iter()
                            .all(|b| matches!(b, b' ' | b'\t' | b'\r'))
                    {
                        return Ok(None);
                    }
                }
            }
        }
        let lexed = if self.rendered {
            let n = lexer::content_len(&self.buf);
            lexer::lex_block(&self.buf[..n], &mut self.lexed)
        } else {
            let original = bytes_of(&self.main, &self.flow, pos).unwrap_or(&[]);
            lexer::lex_block(&original[..content_len], &mut self.lexed)
        };
        if let Err(e) = lexed {
            let e = e.at_line(pos.line as u64 + 1);
            return Err(self.locate_rendered(e));
        }
        let content = if self.rendered {
            &self.buf[..lexer::content_len(&self.buf)]
        } else {
            let original = bytes_of(&self.main, &self.flow, pos).unwrap_or(&[]);
            &original[..content_len]
        };
        self.check_block(pos, content)?;
        self.execute_block(pos)
    }

    /// What LinuxCNC's reader refuses in a lexed block `content` (only a
    /// `( )` comment or a byte-order mark can hold it, so most lines skip
    /// the check), and an `(abort, …)` comment.
    #[inline(always)]
    fn check_block(&self, pos: Pos, content: &[u8]) -> Result<(), GcodeError> {
        if self.lexed.has_comment || content.starts_with(lexer::UTF8_BOM) {
            if let Err(e) = crate::interp::check_line(pos.line as u64 + 1, content, &self.lexed) {
                return Err(self.locate_rendered(e));
            }
        }
        if self.lexed.has_comment {
            if let Some(msg) = abort_comment(content, &self.lexed) {
                return Err(self.locate_rendered(GcodeError::new(
                ErrorClass::Invalid,
                pos.line as u64 + 1,
                1,
                format!("the program aborts here: {msg}"),
                "an (abort, …) comment stops the program in LinuxCNC; remove it if the program should run",
            )));
            }
        }
        Ok(())
    }

    /// Runs the lexed block of line `pos`: an M98/M99 call or return, or
    /// the interpreter.
    #[inline(always)]
    fn execute_block(&mut self, pos: Pos) -> Result<Option<LineKind>, GcodeError> {
        // M98/M99 (a line without M words calls nothing).
        if self.lexed.has_letter(b'M') {
            if let Some(m) = self.fanuc_call()? {
                self.flow.keep_lines();
                self.fanuc(pos, m)?;
                return Ok(None);
            }
        }
        let line_no = pos.line as u64 + 1;
        if let Err(e) = self.interp.execute(line_no, &self.lexed, &mut self.motions) {
            return Err(self.locate_rendered(e));
        }
        Ok(Some(LineKind::Block))
    }

    /// Locates an error of a rendered line: the caret under the rendered
    /// text when the line was rendered, else under the original.
    fn locate_rendered(&self, e: GcodeError) -> GcodeError {
        if self.rendered {
            let e = e.with_source_line(&self.buf);
            match self.file_name(self.current.src) {
                Some(f) => e.with_file(f),
                None => e,
            }
        } else {
            self.locate(e)
        }
    }

    /// Lines after the end of the program, copied as they are.
    fn next_after_end(&mut self) -> Result<Option<LineEvent<'_>>, GcodeError> {
        let at = match self.after_end_at {
            Some(at) => at,
            None => {
                let at = self.flow.main_resume_line(self.current);
                self.after_end_at = Some(at);
                at
            }
        };
        let pos = Pos {
            src: MAIN,
            line: at,
        };
        if !self.fetch(pos)? {
            return Ok(None);
        }
        self.after_end_at = Some(at + 1);
        self.main.forget_before(at);
        self.rendered = false;
        let bytes = self.main.get(at).unwrap_or(&[]);
        let kind = lexer::classify(&bytes[..lexer::content_len(bytes)]);
        self.current = pos;
        Ok(Some(self.event(pos, kind, true)))
    }
}

#[cfg(test)]
mod peek_tests {
    use super::*;

    /// The scan as it was written before the lookup table: every byte
    /// through the match (the second method).
    fn by_match(bytes: &[u8]) -> bool {
        let mut i = 0;
        while i < bytes.len() {
            let c = bytes[i];
            i += 1;
            match c {
                b'(' => match memchr::memchr(b')', &bytes[i..]) {
                    Some(k) => i += k + 1,
                    None => return true,
                },
                b';' => return false,
                b'#' | b'[' | b'o' | b'O' => return true,
                b'g' | b'G' => {
                    let v = code_x10(&bytes[i..]);
                    if v.is_none_or(|v| v == 20 || v == 30) {
                        return true;
                    }
                }
                b'm' | b'M' => {
                    let v = code_x10(&bytes[i..]);
                    if v.is_none_or(|v| matches!(v, 700 | 710 | 720 | 730 | 980 | 990)) {
                        return true;
                    }
                }
                _ => {}
            }
        }
        false
    }

    /// The table holds exactly the bytes the match acts on, and the scan
    /// through it decides as the byte-by-byte match on 200,000 random
    /// lines of G-code's characters (words, codes with decimals and
    /// spaces, comments open and closed, `;`, `#`, `[`, o-words) and on
    /// hand cases; both answers occur often.
    #[test]
    fn the_scan_through_the_table_decides_as_the_match() {
        for c in 0..=255u8 {
            let acts = matches!(
                c,
                b'(' | b';' | b'#' | b'[' | b'o' | b'O' | b'g' | b'G' | b'm' | b'M'
            );
            assert_eq!(PEEK_STOPS[usize::from(c)], acts, "{c}");
        }
        for line in [
            &b"G1 X52.833 Z-6.260"[..],
            b"G2 X1 Y1 I1",
            b"g 0 3",
            b"G1 (G2) X1",
            b"G1 (G2 X1",
            b"X1 ; G3",
            b"M98 P1",
            b"M3 S1000",
            b"G3.0",
            b"G3.05",
            b"",
            b"#1 = 2",
        ] {
            assert_eq!(text_may_start_arc(line), by_match(line), "{line:?}");
        }
        let alphabet = b"GgMmXYZIJKFSoO0123456789.- \t();#[]";
        let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
        let (mut yes, mut no) = (0, 0);
        let mut line = Vec::new();
        for _ in 0..200_000 {
            line.clear();
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let len = (seed % 24) as usize;
            for _ in 0..len {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                // Digits and axis letters most often, as in CAM output.
                let k = (seed >> 32) as usize;
                let c = if k.is_multiple_of(3) {
                    alphabet[k / 3 % alphabet.len()]
                } else {
                    b"XYZ0123456789. -"[k / 3 % 16]
                };
                line.push(c);
            }
            let got = text_may_start_arc(&line);
            assert_eq!(got, by_match(&line), "{:?}", String::from_utf8_lossy(&line));
            if got {
                yes += 1;
            } else {
                no += 1;
            }
        }
        assert!(yes > 10_000 && no > 10_000, "{yes} {no}");
    }
}
