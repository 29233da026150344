//! o-word control flow and Fanuc-style subprograms, as LinuxCNC 2.9 runs
//! them (src/emc/rs274ngc/interp_o_word.cc `convert_control_functions`,
//! `enter_context`, `execute_call`, `execute_return`; interp_read.cc
//! `read_o`).
//!
//! * `oN sub … oN endsub` defines a subroutine where it is met (the body is
//!   skipped); `oN call [a]…` runs it with the arguments in #1–#30; a
//!   subroutine not yet defined is looked for further on in the same file,
//!   then as `N.ngc` on the subroutine path (the setup's `subroutine_path`,
//!   then the program's directory); `oN return [v]`/`oN endsub [v]` set
//!   `#<_value>`. At most 9 nested calls (LinuxCNC's 10 call levels).
//! * `if/elseif/else/endif`, `while/endwhile`, `do/while`,
//!   `repeat/endrepeat`, `break`, `continue`: a false branch or a finished
//!   loop continues after the next line with the same label and the
//!   closing keyword, as LinuxCNC's skipping does.
//! * `M98 P<n> L<k>` runs the lines after the line `O<n>` until `M99`, `k`
//!   times; M99 in the main program (LinuxCNC restarts the program for
//!   ever) is refused.
//! * Every line executed again — a pass of a loop after the first, a line
//!   of a called subroutine — counts against [`MAX_EXECUTED_LINES`], so a
//!   program that never ends is refused within seconds instead of hanging;
//!   a program without control flow runs whatever its length.

use super::expr::{eval, round_to_int, to_integer, Expr, ExprError, Param};
use super::line::{self, OKind, OWord, Setting, Statement};
use super::norm::Norm;
use super::params::{Params, Scope};
use super::source::Lines;
use crate::error::{ErrorClass, GcodeError};
use crate::interp::Interpreter;
use crate::lexer::{self, LineKind};
use crate::program::Walker;
use std::collections::HashMap;
use std::io::BufRead;
use std::path::PathBuf;

/// The source index of the main program.
pub const MAIN: usize = 0;

/// Most lines one run executes again by default (every line of a loop's
/// pass after it first ran, every line of a called subroutine): 5 million,
/// more than the 3 million of the benchmarks' million-move loop, and small
/// enough that `compensate` of an endless loop of moves (every move solved
/// and written) stops within about 6 s on a 2-core machine
/// ([`crate::InterpOptions::max_executed_lines`]). Lines of the main
/// program run for the first time are not counted.
pub const MAX_EXECUTED_LINES: u64 = 5_000_000;

/// The help of a run stopped by [`MAX_EXECUTED_LINES`]: the words a front
/// end rewords with its option.
pub const REPEATED_LINES_HELP: &str = "check the loop's condition; volcomp stops a run after this many lines of loops and calls: raise {max_repeated_lines} if the program really loops this much";

/// Most nested subroutine calls (LinuxCNC's `INTERP_SUB_ROUTINE_LEVELS`
/// is 10 levels including the main program).
pub const MAX_CALL_DEPTH: usize = 9;

/// Largest subroutine file read (bytes).
pub const MAX_SUB_FILE_BYTES: u64 = 64 * 1024 * 1024;

/// A line of a source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pos {
    /// [`MAIN`] or a subroutine file.
    pub src: usize,
    /// 0-based line.
    pub line: usize,
}

impl Pos {
    fn next(self) -> Pos {
        Pos {
            src: self.src,
            line: self.line + 1,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LoopKind {
    While,
    Do,
    Repeat,
}

#[derive(Debug, Clone)]
struct Loop {
    label: String,
    kind: LoopKind,
    start: Pos,
    remaining: i64,
}

#[derive(Debug, Clone)]
struct Frame {
    name: String,
    ret: Pos,
    loops: Vec<Loop>,
    /// For M98: repeats left and the `O<n>` line.
    fanuc: Option<(i64, Pos)>,
}

/// What a control label was bound to when LinuxCNC first met it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ctl {
    If,
    While,
    Do,
    Repeat,
}

impl Ctl {
    fn keyword(self) -> &'static str {
        match self {
            Ctl::If => "if",
            Ctl::While => "while",
            Ctl::Do => "do",
            Ctl::Repeat => "repeat",
        }
    }
}

/// The control state of a running program.
#[derive(Debug)]
pub struct Flow {
    /// The next line to run.
    pub pos: Pos,
    /// The parameters.
    pub params: Params,
    /// Loops of the main program (frames hold their own).
    loops: Vec<Loop>,
    frames: Vec<Frame>,
    subs: HashMap<String, Pos>,
    /// Subroutines of the main program found further on by a call before
    /// their definition was met: LinuxCNC refuses the definition when it
    /// then reaches it in sequence.
    subs_ahead: std::collections::HashSet<String>,
    /// LinuxCNC's o-word table (`offset_map`, `control_save_offset`,
    /// interp_o_word.cc): each `if`, `while`, `do` and `repeat` label of a
    /// scope (the main program, or the subroutine being run) is bound to
    /// the line where it was first met; the same label on another line is
    /// "duplicate O-word label", and the closing words must find it.
    labels: super::Map<String, super::Map<String, (Ctl, Pos)>>,
    /// The labels of the main program's scope (most programs have no
    /// other): [`Flow::labels`] without the lookup of the scope.
    main_labels: super::Map<String, (Ctl, Pos)>,
    files: Vec<(String, Lines)>,
    /// Lines LinuxCNC generates and runs in place of the current one (the
    /// restore of an M73 at a return), run before the next line.
    injected: std::collections::VecDeque<String>,
    dirs: Vec<PathBuf>,
    keep: bool,
    /// Lines executed again (loop passes, subroutine bodies).
    executed: u64,
    max_executed: u64,
    /// The main program's first line not yet executed.
    first_unrun: usize,
}

impl Flow {
    /// A program about to start, with subroutine files searched in `dirs`.
    pub fn new(dirs: Vec<PathBuf>, max_executed: u64) -> Self {
        Self {
            pos: Pos { src: MAIN, line: 0 },
            params: Params::default(),
            loops: Vec::new(),
            frames: Vec::new(),
            subs: HashMap::new(),
            subs_ahead: std::collections::HashSet::new(),
            labels: super::Map::default(),
            main_labels: super::Map::default(),
            files: Vec::new(),
            injected: std::collections::VecDeque::new(),
            dirs,
            keep: false,
            executed: 0,
            max_executed,
            first_unrun: 0,
        }
    }

    /// From now on the main program's lines are kept (control flow may go back).
    pub fn keep_lines(&mut self) {
        self.keep = true;
    }

    /// Whether the main program's lines are kept.
    pub fn keeps_lines(&self) -> bool {
        self.keep
    }

    /// Whether lines LinuxCNC generates wait to run before the next line
    /// ([`Flow::next_injected`]).
    #[inline]
    pub fn has_injected(&self) -> bool {
        !self.injected.is_empty()
    }

    /// The next line LinuxCNC generates and runs in place of the current
    /// one (the restore of an M73 at a return), with its line ending and a
    /// comment that says where it comes from.
    #[inline]
    pub fn next_injected(&mut self) -> Option<String> {
        if self.injected.is_empty() {
            return None;
        }
        self.injected
            .pop_front()
            .map(|t| format!("{t} (volcomp: the state M73 saved, restored at the return)\n"))
    }

    /// Counts the line at `pos` about to run: a line of the main program
    /// run for the first time is free, any other (a loop's next pass, a
    /// subroutine's body) counts against the limit.
    #[inline]
    pub fn count_line(&mut self, pos: Pos) -> Result<(), GcodeError> {
        if pos.src == MAIN && pos.line >= self.first_unrun {
            self.first_unrun = pos.line + 1;
            return Ok(());
        }
        self.count_executed(pos)
    }

    /// A line run again (a loop, a call): counted against the bound (out
    /// of line, so that the first run's test above inlines).
    fn count_executed(&mut self, pos: Pos) -> Result<(), GcodeError> {
        self.executed += 1;
        if self.executed > self.max_executed {
            return Err(GcodeError::new(
                ErrorClass::Invalid,
                pos.line as u64 + 1,
                1,
                format!(
                    "the program has executed {} lines of loops and subroutine calls without ending: a loop that never ends?",
                    self.max_executed
                ),
                REPEATED_LINES_HELP,
            ));
        }
        Ok(())
    }

    /// The subroutine file of source `src`.
    pub fn file_name(&self, src: usize) -> Option<&str> {
        self.files.get(src.checked_sub(1)?).map(|f| f.0.as_str())
    }

    /// The lines of subroutine file `src`.
    pub fn lines(&self, src: usize) -> Option<&Lines> {
        self.files.get(src.checked_sub(1)?).map(|f| &f.1)
    }

    /// The main-program line after which the program continues (for
    /// copying what follows the program end).
    pub fn main_resume_line(&self, current: Pos) -> usize {
        match self.frames.first() {
            Some(f) => f.ret.line,
            None if current.src == MAIN => current.line + 1,
            None => self.pos.line,
        }
    }

    fn loops_mut(&mut self) -> &mut Vec<Loop> {
        match self.frames.last_mut() {
            Some(f) => &mut f.loops,
            None => &mut self.loops,
        }
    }

    /// Applies a line's parameter settings after the line was read.
    pub fn apply_settings(
        &mut self,
        settings: &[Setting],
        values: &[f64],
        interp: &Interpreter,
    ) -> Result<(), ExprError> {
        let mut targets = Vec::with_capacity(settings.len());
        for s in settings {
            targets.push(match &s.target {
                Param::Numbered(index) => {
                    let scope = Scope {
                        params: &self.params,
                        interp,
                        line: 0,
                    };
                    Ok(super::expr::param_number(index, s.col, &scope)?)
                }
                Param::Named(name) => Err(name.clone()),
            });
        }
        for ((t, v), s) in targets.into_iter().zip(values).zip(settings) {
            match t {
                Ok(n) => self.params.set_numbered(n, *v, s.col)?,
                Err(name) => self.params.set_named(&name, *v, s.col)?,
            }
        }
        Ok(())
    }
}

/// The label and keyword of an o-word line, without evaluating anything.
fn peek(content: &[u8]) -> Option<(String, &'static str)> {
    if !line::needs_ngc(content) {
        return None;
    }
    let n = Norm::of(content);
    let mut i = usize::from(n.byte(0) == b'/');
    if n.byte(i) != b'o' {
        return None;
    }
    i += 1;
    let start = i;
    let label = if n.byte(i) == b'<' {
        let end = n.text[i..].iter().position(|&b| b == b'>')? + i;
        i = end + 1;
        String::from_utf8_lossy(&n.text[start + 1..end]).into_owned()
    } else {
        while n.byte(i).is_ascii_digit() || n.byte(i) == b'.' {
            i += 1;
        }
        let v: f64 = std::str::from_utf8(&n.text[start..i]).ok()?.parse().ok()?;
        // `read_o` reads the number with `read_integer_value`.
        to_integer(v, 0).ok()?.to_string()
    };
    let rest = &n.text[i.min(n.text.len())..];
    const KW: [&str; 15] = [
        "sub",
        "endsub",
        "call",
        "do",
        "while",
        "repeat",
        "if",
        "elseif",
        "else",
        "endif",
        "break",
        "continue",
        "endwhile",
        "endrepeat",
        "return",
    ];
    KW.iter()
        .find(|k| rest.starts_with(k.as_bytes()))
        .map(|k| (label, *k))
}

/// What an M98/M99 line asks.
pub(crate) enum Fanuc {
    Call { program: i64, times: i64 },
    Return,
}

impl<R: BufRead> Walker<R> {
    pub(crate) fn expr_error(&self, pos: Pos, e: ExprError) -> GcodeError {
        let _ = pos;
        self.locate(GcodeError::new(
            ErrorClass::Invalid,
            self.current.line as u64 + 1,
            e.column + 1,
            e.message,
            e.help,
        ))
    }

    fn at_current(
        &self,
        msg: impl Into<String>,
        help: impl Into<String>,
        col: usize,
    ) -> GcodeError {
        self.locate(GcodeError::new(
            ErrorClass::Invalid,
            self.current.line as u64 + 1,
            col + 1,
            msg,
            help,
        ))
    }

    fn eval_at(&self, e: &Expr) -> Result<f64, GcodeError> {
        let scope = Scope {
            params: &self.flow.params,
            interp: &self.interp,
            line: self.current.line as u64 + 1,
        };
        eval(e, &scope).map_err(|err| self.expr_error(self.current, err))
    }

    /// The next line after `from` in its source that is `o<label>` with one
    /// of `keywords`.
    fn skip_to(
        &mut self,
        from: Pos,
        label: &str,
        keywords: &[&str],
    ) -> Result<Option<(Pos, &'static str)>, GcodeError> {
        let mut p = from.next();
        loop {
            if !self.fetch(p)? {
                return Ok(None);
            }
            let bytes = self.line_bytes(p).unwrap_or(&[]);
            let content = &bytes[..lexer::content_len(bytes)];
            // LinuxCNC reads no further than the `%` that ends the tape.
            if p.src == MAIN && lexer::classify(content) == LineKind::Percent {
                return Ok(None);
            }
            if let Some((l, kw)) = peek(content) {
                if l == label && keywords.contains(&kw) {
                    return Ok(Some((p, kw)));
                }
                if kw == "sub" && keywords == ["endsub"] {
                    self.current = p;
                    return Err(self.at_current(
                        format!(
                            "subroutine o{} is defined inside the definition of o{}",
                            show_label(&l),
                            show_label(label)
                        ),
                        "LinuxCNC does not nest subroutine definitions: end the first with its endsub before the next sub",
                        0,
                    ));
                }
            }
            p = p.next();
        }
    }

    fn require_skip(
        &mut self,
        from: Pos,
        label: &str,
        keywords: &[&str],
        col: usize,
    ) -> Result<(Pos, &'static str), GcodeError> {
        match self.skip_to(from, label, keywords)? {
            Some(found) => Ok(found),
            None => Err(self.at_current(
                format!(
                    "no matching `o{} {}` follows",
                    show_label(label),
                    keywords.join("` or `o… ")
                ),
                "close every o-word construct with its matching line (same label)",
                col,
            )),
        }
    }

    fn parse_at(&mut self, p: Pos) -> Result<OWord, GcodeError> {
        self.current = p;
        let bytes = self.line_bytes(p).unwrap_or(&[]);
        let norm = Norm::of(&bytes[..lexer::content_len(bytes)]);
        match line::parse(&norm) {
            Ok(Statement::OWord(o)) => Ok(o),
            Ok(_) => Err(self.at_current("an o-word statement was expected here", "", 0)),
            Err(e) => Err(self.expr_error(p, e)),
        }
    }

    /// What `label` is bound to in the current scope: LinuxCNC prefixes a
    /// control label with the name of the subroutine being run (`read_o`;
    /// none, or an empty name: the main program's scope).
    fn label_binding(&self, label: &str) -> Option<&(Ctl, Pos)> {
        match self.flow.frames.last().filter(|f| !f.name.is_empty()) {
            None => self.flow.main_labels.get(label),
            Some(f) => self.flow.labels.get(&f.name).and_then(|m| m.get(label)),
        }
    }

    /// Binds an opening label (`if`, `while`, `do`, `repeat`) to `pos` as
    /// `convert_control_functions` does, refusing it where LinuxCNC finds
    /// the label already bound to another line.
    fn bind_label(
        &mut self,
        pos: Pos,
        label: &str,
        ctl: Ctl,
        col: usize,
    ) -> Result<(), GcodeError> {
        match self.label_binding(label) {
            // A `while` that closes a `do`, or a `do` met again.
            Some((found, _)) if ctl == Ctl::Do || (ctl == Ctl::While && *found == Ctl::Do) => {
                Ok(())
            }
            Some((_, at)) if *at != pos => {
                let at = at.line + 1;
                Err(self.at_current(
                    format!(
                        "the label o{} is already used on line {at}: LinuxCNC binds each control label to one line (\"duplicate O-word label\")",
                        show_label(label)
                    ),
                    "give this block a label of its own",
                    col,
                ))
            }
            Some(_) => Ok(()),
            None => {
                let labels = match self.flow.frames.last().filter(|f| !f.name.is_empty()) {
                    None => &mut self.flow.main_labels,
                    Some(f) => self.flow.labels.entry(f.name.clone()).or_default(),
                };
                labels.insert(label.to_string(), (ctl, pos));
                Ok(())
            }
        }
    }

    /// Checks that a closing or inner word (`else`, `endif`, `break`, …)
    /// finds its label bound to one of `opening`, as LinuxCNC does.
    fn check_label(
        &self,
        label: &str,
        keyword: &str,
        opening: &[Ctl],
        col: usize,
    ) -> Result<(), GcodeError> {
        match self.label_binding(label) {
            None => Err(self.at_current(
                format!(
                    "`o{} {keyword}` has no open block with its label: LinuxCNC refuses it (\"undefined O-word label\")",
                    show_label(label)
                ),
                "use the label of the block it belongs to",
                col,
            )),
            Some((found, at)) if !opening.contains(found) => Err(self.at_current(
                format!(
                    "`o{} {keyword}` belongs to the `{}` of line {}: LinuxCNC refuses it (\"no matching label\")",
                    show_label(label),
                    found.keyword(),
                    at.line + 1
                ),
                format!(
                    "close the block with its own word, or give the {} block a label of its own",
                    opening.iter().map(|c| c.keyword()).collect::<Vec<_>>().join("/")
                ),
                col,
            )),
            Some(_) => Ok(()),
        }
    }

    /// Runs one o-word statement at `pos`.
    pub(crate) fn control(&mut self, pos: Pos, o: &OWord) -> Result<(), GcodeError> {
        // For speed, the statement is borrowed (no copy of its
        // expressions per pass of a loop).
        let evaluated;
        let label: &str = match &o.label_expr {
            Some((e, col)) => {
                // `read_o`: `read_integer_value` of the label's value.
                let v = self.eval_at(e)?;
                evaluated = to_integer(v, *col)
                    .map_err(|err| self.expr_error(pos, err))?
                    .to_string();
                &evaluated
            }
            None => &o.label,
        };
        let col = o.col;
        let keyword = o.kind.keyword();
        match &o.kind {
            OKind::Do => self.bind_label(pos, label, Ctl::Do, col)?,
            OKind::While(_) => self.bind_label(pos, label, Ctl::While, col)?,
            OKind::Repeat(_) => self.bind_label(pos, label, Ctl::Repeat, col)?,
            OKind::If(_) => self.bind_label(pos, label, Ctl::If, col)?,
            OKind::Elseif(_) | OKind::Else | OKind::Endif => {
                self.check_label(label, keyword, &[Ctl::If], col)?
            }
            OKind::Break | OKind::Continue => {
                self.check_label(label, keyword, &[Ctl::While, Ctl::Do], col)?
            }
            OKind::Endwhile => self.check_label(label, keyword, &[Ctl::While], col)?,
            OKind::Endrepeat => self.check_label(label, keyword, &[Ctl::Repeat], col)?,
            OKind::Sub => {
                if self.flow.subs.get(label) == Some(&pos) && self.flow.subs_ahead.contains(label) {
                    return Err(self.at_current(
                        format!(
                            "the definition of subroutine o{} is reached in sequence after a call found it further on: LinuxCNC refuses it here (\"sub: o|{}| found in illegal location\")",
                            show_label(label),
                            label
                        ),
                        "end the main program (M2 or M30) before the subroutine definitions, or define the subroutine before its first call",
                        col,
                    ));
                }
                if let Some(at) = self.flow.subs.get(label).filter(|at| **at != pos) {
                    let at = at.line + 1;
                    return Err(self.at_current(
                        format!(
                            "subroutine o{} is already defined on line {at}: LinuxCNC refuses a second definition (\"redefining sub\")",
                            show_label(label)
                        ),
                        "give the subroutine another name, or remove one definition",
                        col,
                    ));
                }
            }
            _ => {}
        }
        match &o.kind {
            OKind::Sub => {
                // Met in sequence: a definition. Record it, skip its body.
                self.flow.subs.insert(label.to_string(), pos);
                match self.skip_to(pos, label, &["endsub"])? {
                    Some((end, _)) => self.flow.pos = end.next(),
                    None if pos.src == MAIN && self.flow.frames.is_empty() => {
                        // LinuxCNC skips to the end of the file looking for
                        // the endsub, runs none of it, and then reports the
                        // end of the file: the rest is copied as it is,
                        // this line included.
                        let what = format!(
                            "subroutine o{} has no `o{} endsub`: LinuxCNC skips from here to the end of the file looking for it, runs none of it",
                            show_label(label),
                            show_label(label)
                        );
                        self.interp
                            .end_of_file_reached(pos.line as u64 + 1, col + 1, &what);
                        self.after_end_at = Some(pos.line);
                    }
                    None => {
                        self.require_skip(pos, label, &["endsub"], col)?;
                    }
                }
            }
            OKind::Endsub(v) | OKind::Return(v) => {
                let Some(frame) = self.flow.frames.last() else {
                    return Err(self.at_current(
                        format!("`o{} {}` outside a subroutine", show_label(label), keyword),
                        "end a subroutine only inside its definition (o… sub … o… endsub)",
                        col,
                    ));
                };
                if frame.fanuc.is_some() {
                    return Err(self.at_current(
                        "a subprogram called with M98 ends with M99, not with an o-word",
                        "end it with M99",
                        col,
                    ));
                }
                let value = match v {
                    Some(e) => Some(self.eval_at(e)?),
                    None => None,
                };
                let ret = frame.ret;
                self.flow.frames.pop();
                self.flow.params.pop_call(value);
                self.flow.pos = ret;
                // An M73 of the call restores the state it saved: the
                // lines LinuxCNC generates run in place of the return.
                let line = self.current.line as u64 + 1;
                let restore = self.interp.leave_call(line).map_err(|e| self.locate(e))?;
                self.flow.injected.extend(restore);
            }
            OKind::Call(args) => {
                let mut values = Vec::with_capacity(args.len());
                for a in args {
                    values.push(self.eval_at(a)?);
                }
                if self.flow.frames.len() >= MAX_CALL_DEPTH {
                    return Err(self.at_current(
                        format!(
                            "more than {MAX_CALL_DEPTH} nested subroutine calls (LinuxCNC's limit)"
                        ),
                        "check for a subroutine that calls itself without end",
                        col,
                    ));
                }
                let target = self.find_sub(pos, label, col)?;
                self.flow.params.push_call(&values);
                self.interp.enter_call();
                self.flow.frames.push(Frame {
                    name: label.to_string(),
                    ret: pos.next(),
                    loops: Vec::new(),
                    fanuc: None,
                });
                self.flow.pos = target.next();
            }
            OKind::Do => {
                self.flow.loops_mut().push(Loop {
                    label: label.to_string(),
                    kind: LoopKind::Do,
                    start: pos,
                    remaining: 0,
                });
            }
            OKind::While(c) => {
                // The innermost loop: whether it has this label, its kind, its line.
                let top = self
                    .flow
                    .loops_mut()
                    .last()
                    .map(|l| (l.label == label, l.kind, l.start));
                match top {
                    Some((true, LoopKind::Do, start)) => {
                        if self.eval_at(c)? != 0.0 {
                            self.flow.pos = start.next();
                        } else {
                            self.flow.loops_mut().pop();
                        }
                    }
                    _ => {
                        let reentry =
                            matches!(top, Some((true, LoopKind::While, start)) if start == pos);
                        if self.eval_at(c)? != 0.0 {
                            if !reentry {
                                self.flow.loops_mut().push(Loop {
                                    label: label.to_string(),
                                    kind: LoopKind::While,
                                    start: pos,
                                    remaining: 0,
                                });
                            }
                        } else {
                            if reentry {
                                self.flow.loops_mut().pop();
                            }
                            let (end, _) = self.require_skip(pos, label, &["endwhile"], col)?;
                            self.flow.pos = end.next();
                        }
                    }
                }
            }
            OKind::Endwhile => {
                let i = self.find_loop(label, Some(LoopKind::While), "endwhile", col)?;
                let start = self.flow.loops_mut()[i].start;
                self.flow.loops_mut().truncate(i + 1);
                self.flow.pos = start;
            }
            OKind::Repeat(n) => {
                // LinuxCNC counts `round_to_int(test_value)` passes
                // (interp_o_word.cc, O_repeat): half to even, 2.5 → 2.
                let count = round_to_int(self.eval_at(n)?);
                if count > 0 {
                    self.flow.loops_mut().push(Loop {
                        label: label.to_string(),
                        kind: LoopKind::Repeat,
                        start: pos,
                        remaining: count - 1,
                    });
                } else {
                    let (end, _) = self.require_skip(pos, label, &["endrepeat"], col)?;
                    self.flow.pos = end.next();
                }
            }
            OKind::Endrepeat => {
                let i = self.find_loop(label, Some(LoopKind::Repeat), "endrepeat", col)?;
                let loops = self.flow.loops_mut();
                loops.truncate(i + 1);
                if loops[i].remaining > 0 {
                    loops[i].remaining -= 1;
                    let start = loops[i].start;
                    self.flow.pos = start.next();
                } else {
                    loops.truncate(i);
                }
            }
            OKind::If(c) => {
                if self.eval_at(c)? == 0.0 {
                    self.if_false(pos, label, col)?;
                }
            }
            OKind::Elseif(_) | OKind::Else => {
                // Met in sequence: the branch before it ran.
                let (end, _) = self.require_skip(pos, label, &["endif"], col)?;
                self.flow.pos = end.next();
            }
            // A Fanuc-style program start: execution runs on.
            OKind::Endif | OKind::Program => {}
            OKind::Break => {
                let i = self.find_loop(label, None, "break", col)?;
                let l = self.flow.loops_mut()[i].clone();
                let kw = match l.kind {
                    LoopKind::While => "endwhile",
                    LoopKind::Repeat => "endrepeat",
                    LoopKind::Do => "while",
                };
                let (end, _) = self.require_skip(pos, label, &[kw], col)?;
                self.flow.loops_mut().truncate(i);
                self.flow.pos = end.next();
            }
            OKind::Continue => {
                let i = self.find_loop(label, None, "continue", col)?;
                let l = self.flow.loops_mut()[i].clone();
                self.flow.loops_mut().truncate(i + 1);
                match l.kind {
                    LoopKind::While => self.flow.pos = l.start,
                    LoopKind::Repeat => {
                        let (end, _) = self.require_skip(pos, label, &["endrepeat"], col)?;
                        self.flow.pos = end;
                    }
                    LoopKind::Do => {
                        let (end, _) = self.require_skip(pos, label, &["while"], col)?;
                        self.flow.pos = end;
                    }
                }
            }
        }
        Ok(())
    }

    fn find_loop(
        &self,
        label: &str,
        kind: Option<LoopKind>,
        what: &str,
        col: usize,
    ) -> Result<usize, GcodeError> {
        let loops = match self.flow.frames.last() {
            Some(f) => &f.loops,
            None => &self.flow.loops,
        };
        loops
            .iter()
            .rposition(|l| l.label == label && kind.is_none_or(|k| l.kind == k))
            .ok_or_else(|| {
                self.at_current(
                    format!(
                        "`o{} {what}` is not inside a loop labelled o{}",
                        show_label(label),
                        show_label(label)
                    ),
                    "match the label of the loop's while, do or repeat line",
                    col,
                )
            })
    }

    /// After a false `if`/`elseif`: on to the next branch of the same label.
    fn if_false(&mut self, pos: Pos, label: &str, col: usize) -> Result<(), GcodeError> {
        let mut from = pos;
        loop {
            let (p, kw) = self.require_skip(from, label, &["elseif", "else", "endif"], col)?;
            match kw {
                "elseif" => {
                    let o = self.parse_at(p)?;
                    if let OKind::Elseif(c) = o.kind {
                        if self.eval_at(&c)? != 0.0 {
                            self.flow.pos = p.next();
                            return Ok(());
                        }
                    }
                    from = p;
                }
                _ => {
                    self.flow.pos = p.next();
                    return Ok(());
                }
            }
        }
    }

    /// Where subroutine `label` is defined: already met, further on in the
    /// same file, or in `label.ngc` on the subroutine path.
    fn find_sub(&mut self, pos: Pos, label: &str, col: usize) -> Result<Pos, GcodeError> {
        if let Some(p) = self.flow.subs.get(label) {
            return Ok(*p);
        }
        if let Some((p, _)) = self.skip_to(pos, label, &["sub"])? {
            self.flow.subs.insert(label.to_string(), p);
            if p.src == MAIN {
                self.flow.subs_ahead.insert(label.to_string());
            }
            return Ok(p);
        }
        let name = format!("{label}.ngc");
        for dir in self.flow.dirs.clone() {
            let path = dir.join(&name);
            let Ok(meta) = std::fs::metadata(&path) else {
                continue;
            };
            if meta.len() > MAX_SUB_FILE_BYTES {
                return Err(self.at_current(
                    format!(
                        "subroutine file {} is larger than {MAX_SUB_FILE_BYTES} bytes",
                        path.display()
                    ),
                    "check that this is the right file",
                    col,
                ));
            }
            // Recorded as read, so that no output of the command replaces it
            // (volcomp_geom::inputs); bounded like the size check above, for
            // a name that is a FIFO or a device.
            let role = format!("the subroutine file of `o{} call`", show_label(label));
            let text = volcomp_geom::inputs::read_at_most(&path, &role, MAX_SUB_FILE_BYTES)
                .map_err(|e| {
                    self.at_current(
                        format!("cannot read {}: {e}", path.display()),
                        "check the file",
                        col,
                    )
                })?;
            self.flow
                .files
                .push((path.display().to_string(), Lines::of(text)));
            let src = self.flow.files.len();
            let start = Pos { src, line: 0 };
            // The definition may be on the file's first line.
            let bytes = self.line_bytes(start).unwrap_or(&[]);
            let first = peek(&bytes[..lexer::content_len(bytes)]);
            let found = if matches!(&first, Some((l, "sub")) if l == label) {
                Some(start)
            } else {
                self.skip_to(start, label, &["sub"])?.map(|(p, _)| p)
            };
            return match found {
                Some(p) => {
                    self.flow.subs.insert(label.to_string(), p);
                    Ok(p)
                }
                None => Err(self.at_current(
                    format!(
                        "{} does not define `o{} sub`",
                        path.display(),
                        show_label(label)
                    ),
                    "the file of a subroutine must hold its o<name> sub … o<name> endsub",
                    col,
                )),
            };
        }
        let dirs: Vec<String> = self
            .flow
            .dirs
            .iter()
            .map(|d| d.display().to_string())
            .collect();
        Err(self.at_current(
            format!(
                "subroutine o{} is not defined in the program, and no file {name} was found (searched: {})",
                show_label(label),
                if dirs.is_empty() { "nowhere".to_string() } else { dirs.join(", ") }
            ),
            "define the subroutine in the program, or name its directory in the setup file's subroutine_path",
            col,
        ))
    }

    /// An M98 or M99 on the current (lexed) line.
    pub(crate) fn fanuc_call(&self) -> Result<Option<Fanuc>, GcodeError> {
        let lexed = self.lexed_ref();
        let mut m = None;
        let (mut p, mut l) = (None, None);
        for w in lexed.words() {
            match w.letter {
                b'M' if w.value == 98.0 || w.value == 99.0 => m = Some((w.value, w.span.start)),
                b'P' => p = Some((w.value, w.span.start)),
                b'L' => l = Some((w.value, w.span.start)),
                _ => {}
            }
        }
        let Some((m, mcol)) = m else {
            return Ok(None);
        };
        if let Some(w) = lexed
            .words()
            .find(|w| !matches!(w.letter, b'M' | b'P' | b'L' | b'N'))
        {
            return Err(self.at_current(
                format!("M{m} shares its line with a {} word", char::from(w.letter)),
                "put M98/M99 on a line of its own (with P and L)",
                w.span.start,
            ));
        }
        if m == 99.0 {
            return Ok(Some(Fanuc::Return));
        }
        let Some((p, pcol)) = p else {
            return Err(self.at_current(
                "M98 without a P word",
                "write M98 P<program number>",
                mcol,
            ));
        };
        let program = to_integer(p, pcol).map_err(|e| self.expr_error(self.current, e))?;
        let times = match l {
            Some((l, lcol)) => to_integer(l, lcol).map_err(|e| self.expr_error(self.current, e))?,
            None => 1,
        };
        Ok(Some(Fanuc::Call { program, times }))
    }

    /// Runs an M98 call or M99 return at `pos`.
    pub(crate) fn fanuc(&mut self, pos: Pos, f: Fanuc) -> Result<(), GcodeError> {
        match f {
            Fanuc::Call { program, times } => {
                if times <= 0 {
                    return Ok(());
                }
                if self.flow.frames.len() >= MAX_CALL_DEPTH {
                    return Err(self.at_current(
                        format!(
                            "more than {MAX_CALL_DEPTH} nested subprogram calls (LinuxCNC's limit)"
                        ),
                        "check for a subprogram that calls itself without end",
                        0,
                    ));
                }
                let target = self.find_program_number(program)?;
                self.interp.enter_call();
                self.flow.frames.push(Frame {
                    name: program.to_string(),
                    ret: pos.next(),
                    loops: Vec::new(),
                    fanuc: Some((times - 1, target)),
                });
                self.flow.pos = target.next();
            }
            Fanuc::Return => {
                let Some(frame) = self.flow.frames.last_mut() else {
                    return Err(self.at_current(
                        "M99 in the main program: LinuxCNC would start the program again, for ever",
                        "end the program with M2 or M30",
                        0,
                    ));
                };
                match &mut frame.fanuc {
                    Some((left, start)) if *left > 0 => {
                        *left -= 1;
                        self.flow.pos = start.next();
                    }
                    Some(_) => {
                        let ret = frame.ret;
                        self.flow.frames.pop();
                        self.flow.pos = ret;
                        let line = self.current.line as u64 + 1;
                        let restore = self.interp.leave_call(line).map_err(|e| self.locate(e))?;
                        self.flow.injected.extend(restore);
                    }
                    None => {
                        return Err(self.at_current(
                            "M99 ends a subroutine called with o… call",
                            "end it with o… endsub or o… return",
                            0,
                        ))
                    }
                }
            }
        }
        Ok(())
    }

    /// The line `O<n>` of the main program.
    fn find_program_number(&mut self, n: i64) -> Result<Pos, GcodeError> {
        let mut p = Pos {
            src: MAIN,
            line: self.main_first_held(),
        };
        loop {
            if !self.fetch(p)? {
                return Err(self.at_current(
                    format!("M98 calls O{n}, but the program has no line O{n}"),
                    "add the subprogram (O<n> … M99) to the program",
                    0,
                ));
            }
            let bytes = self.line_bytes(p).unwrap_or(&[]);
            let content = &bytes[..lexer::content_len(bytes)];
            if lexer::classify(content) == LineKind::ProgramNumber {
                let digits: String = content
                    .iter()
                    .skip_while(|b| !b.is_ascii_digit())
                    .take_while(|b| b.is_ascii_digit() || **b == b' ')
                    .filter(|b| b.is_ascii_digit())
                    .map(|&b| char::from(b))
                    .collect();
                if digits.parse::<i64>().ok() == Some(n) {
                    return Ok(p);
                }
            }
            p = p.next();
        }
    }

    /// Checks the end of source at `pos` (nothing left to read there).
    pub(crate) fn end_of_source(&mut self, pos: Pos) -> Result<(), GcodeError> {
        let open = |w: &Self| -> Option<String> {
            if let Some(f) = w.flow.frames.last() {
                return Some(format!(
                    "subroutine o{} has no endsub/return",
                    show_label(&f.name)
                ));
            }
            w.flow.loops.last().map(|l| {
                format!(
                    "the loop o{} (opened on line {}) is not closed",
                    show_label(&l.label),
                    l.start.line + 1
                )
            })
        };
        if pos.src != MAIN || !self.flow.frames.is_empty() || !self.flow.loops.is_empty() {
            let what = open(self).unwrap_or_else(|| "a subroutine is not closed".into());
            let last = pos.line as u64;
            let e = GcodeError::new(
                ErrorClass::Invalid,
                last.max(1),
                1,
                format!("the file ends while {what}"),
                "close every o-word construct with its matching line",
            );
            return Err(match self.file_name(pos.src) {
                Some(f) => e.with_file(f),
                None => e,
            });
        }
        self.interp
            .end_of_input(pos.line as u64)
            .map_err(|e| match &self.file {
                Some(f) => e.with_file(f.clone()),
                None => e,
            })
    }

    fn main_first_held(&self) -> usize {
        self.main.read_so_far() - self.main.held()
    }
}

fn show_label(label: &str) -> String {
    if label.bytes().all(|b| b.is_ascii_digit() || b == b'-') {
        label.to_string()
    } else {
        format!("<{label}>")
    }
}
